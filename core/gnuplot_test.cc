#include "core/gnuplot.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <limits>

#include "core/error.h"
#include "core/file_io.h"

namespace curvecheck {
namespace {
namespace fs = std::filesystem;

TEST(Gnuplot, StringEscapesQuotesBackslashesAndNewlines) {
  EXPECT_EQ(GnuplotString("a\"b\\c\nd"), "\"a\\\"b\\\\c\\nd\"");
}

TEST(Gnuplot, Base64MatchesRfc4648Vectors) {
  // RFC 4648 section 10 test vectors.
  EXPECT_EQ(Base64(""), "");
  EXPECT_EQ(Base64("f"), "Zg==");
  EXPECT_EQ(Base64("fo"), "Zm8=");
  EXPECT_EQ(Base64("foo"), "Zm9v");
  EXPECT_EQ(Base64("foob"), "Zm9vYg==");
  EXPECT_EQ(Base64("fooba"), "Zm9vYmE=");
  EXPECT_EQ(Base64("foobar"), "Zm9vYmFy");
  EXPECT_EQ(Base64(std::string("\xff\x00\x80", 3)), "/wCA");
}

TEST(Gnuplot, ParetoFrontKeepsOnlyUndominatedFinitePoints) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  //                        0    1    2    3    4    5
  const std::vector<double> t{1, 2, 2, 3, 0.5, nan};
  const std::vector<double> e{5, 1, 2, 0.5, 9, 0};
  const std::vector<bool> f = ParetoFront(t, e);
  EXPECT_EQ(f, (std::vector<bool>{true, true, false, true, true, false}));
  EXPECT_THROW(ParetoFront({1}, {}), Error);
}

TEST(Gnuplot, RendersPngAndSvgAndWritesTheScript) {
  const fs::path dir = fs::temp_directory_path() / ("curvecheck_gnuplot_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  WriteFileAtomic(dir / "data.csv", "1,2\n2,4\n3,9\n");
  const std::string script = "set datafile separator ','\nplot 'data.csv' using 1:2 with linespoints title 'y'\n";
  const std::string png = RenderGnuplot(script, ChartFormat::kPng, {320, 200}, dir);
  ASSERT_GT(png.size(), 8u);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  const std::string svg = RenderGnuplot(script, ChartFormat::kSvg, {320, 200}, dir);
  EXPECT_NE(svg.find("<svg"), std::string::npos);
  const fs::path gp = WriteGnuplotChart(dir / "chart.svg", script, {320, 200});
  EXPECT_TRUE(fs::exists(dir / "chart.svg"));
  EXPECT_EQ(gp, dir / "chart.gp");
  EXPECT_NE(ReadFileToString(gp).find("plot 'data.csv'"), std::string::npos);
  fs::remove_all(dir);
}

TEST(Gnuplot, ABrokenScriptIsAnErrorWithGnuplotsMessage) {
  try {
    RenderGnuplot("plot 'no-such-file.csv' using 1:2", ChartFormat::kPng, {100, 100});
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no-such-file.csv"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace curvecheck
