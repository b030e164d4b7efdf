// The HTML report from real result.json documents (the fuzz corpus, written by `curvecheck analyze`): the key
// figures carry the document's exact numbers, every image is embedded (charts PNG, photo overlays JPEG), strings
// are escaped, warnings of the fit are shown, missing overlays are said. What it does not prove: that a browser
// renders the page (that is tests/report_browser_test.cc, in headless Chromium).
#include "analysis/report.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "analysis/result_reader.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/gnuplot.h"
#include "core/image_decode.h"

#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace curvecheck {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ::testing::HasSubstr;
using ::testing::Not;

json Corpus(const std::string& name) {
  return ReadResultJson(fs::path(std::getenv("CURVECHECK_SOURCE_DIR")) / "fuzz/corpus/fuzz_result_json" / name);
}

// The data-value of the element with `id`, or "(absent)" (string search: the page holds megabytes of base64).
std::string DataValue(const std::string& html, const std::string& id) {
  const size_t at = html.find(" id=\"" + id + "\"");
  if (at == std::string::npos) return "(absent)";
  const size_t end = html.find('>', at), value = html.find(" data-value=\"", at);
  if (value == std::string::npos || value > end) return "(absent)";
  const size_t begin = value + 13;
  return html.substr(begin, html.find('"', begin) - begin);
}

int Count(const std::string& text, const std::string& piece) {
  int n = 0;
  for (size_t at = text.find(piece); at != std::string::npos; at = text.find(piece, at + 1)) ++n;
  return n;
}

ReportOptions NoCharts() {
  ReportOptions o;
  o.charts = false;
  return o;
}

TEST(Report, KeyFiguresCarryTheDocumentsNumbers) {
  const json r = Corpus("cylinder-1080r.json");
  ReportAssets assets;
  assets.source = "out/result.json";
  // A small real PNG as the overlay (drawn by gnuplot: the test needs no image library).
  assets.overlay_png["photo-exact.png"] = RenderGnuplot("plot x", ChartFormat::kPng, {200, 150});
  const std::string html = ReportHtml(r, assets);

  EXPECT_EQ(DataValue(html, "radius-mm"), fmt::format("{}", r["fit"]["radius_mm"].get<double>()));
  EXPECT_EQ(DataValue(html, "radius-sigma-mm"), fmt::format("{}", r["fit"]["radius_sigma_mm"].get<double>()));
  EXPECT_EQ(DataValue(html, "radius-ci95-lo-mm"), fmt::format("{}", r["fit"]["radius_ci95_mm"][0].get<double>()));
  EXPECT_EQ(DataValue(html, "chosen-model"), "cylinder");
  EXPECT_EQ(DataValue(html, "feature-count"), "12");
  EXPECT_EQ(DataValue(html, "tolerance-display-px"), "0.5");
  EXPECT_THAT(html, HasSubstr("id=\"verdict\" class=\"verdict fail\" data-pass=\"false\" data-verdict=\"fail\">FAIL<"));
  // The radius as read: 1071.6477 +- 1.462 mm -> one decimal.
  EXPECT_THAT(html, HasSubstr(">1071.6</span> &#177; <span id=\"radius-sigma-mm\" class=\"value\" data-value=\""));
  // The model table: every candidate, the chosen one marked.
  EXPECT_EQ(Count(html, "<tr data-model="), static_cast<int>(r["fit"]["candidates"].size()));
  EXPECT_THAT(html, HasSubstr("<tr data-model=\"cylinder\" data-chosen=\"true\""));
  EXPECT_THAT(html, HasSubstr("<tr data-photo=\"photo-exact.png\" data-status=\"used\" data-features=\"138\""));
  // The stated assumptions.
  for (const json& a : r["fit"]["assumptions"]) EXPECT_THAT(html, HasSubstr(a.get<std::string>().substr(0, 30)));

  // Images: the overlay and four charts (radius, histogram, deviation map, the photo's residual map), all PNG
  // data: URIs; nothing else is referenced.
  EXPECT_EQ(Count(html, "<img "), 5);
  EXPECT_EQ(Count(html, "src=\"data:image/png;base64,iVBORw0KGgo"), 5);  // base64 of the PNG signature
  EXPECT_EQ(Count(html, "src="), 5);
  EXPECT_THAT(html, Not(HasSubstr("http://")));
  EXPECT_THAT(html, Not(HasSubstr("https://")));
  EXPECT_THAT(html, Not(HasSubstr("No chart")));
}

TEST(Report, WarningsOfTheFitAreShownAndANullRadiusIsNotANumber) {
  json r = Corpus("cylinder-1080r.json");
  r["fit"]["radius_mm"] = nullptr;
  r["fit"]["radius_sigma_mm"] = nullptr;
  r["fit"]["radius_ci95_mm"] = {nullptr, nullptr};
  r["fit"]["warnings"] = {"radius ill-conditioned: the photos cover 20% of the width"};
  r["fit"]["candidates"][1]["condition_note"] = "radius unobservable <along> the view";
  const std::string html = ReportHtml(r, {}, NoCharts());
  EXPECT_EQ(DataValue(html, "radius-mm"), "null");
  EXPECT_EQ(DataValue(html, "radius-sigma-mm"), "null");
  EXPECT_THAT(html, HasSubstr("The radius is not measurable as a number"));
  const size_t box = html.find("<div id=\"warnings\">");
  ASSERT_NE(box, std::string::npos);
  const std::string warnings = html.substr(box, html.find("</div>", box) - box);
  EXPECT_THAT(warnings, HasSubstr("radius ill-conditioned: the photos cover 20% of the width"));
  EXPECT_THAT(warnings, HasSubstr("Model <b>cylinder</b> (chosen): radius unobservable &lt;along&gt; the view"));
  // The page comes before the figures: warnings sit above the model table.
  EXPECT_LT(box, html.find("<table id=\"models\">"));
}

// The model choice's strip veto (screen_fit.h FitOptions::heldout_strips): a candidate's held-out error on strips of
// the screen is shown beside the shuffled one, and a vetoed candidate says why in its notes; older documents
// without the keys show the shuffled error alone.
TEST(Report, StripErrorsAndTheVetoAreShownInTheModelTable) {
  json r = Corpus("cylinder-1080r.json");
  json& c = r["fit"]["candidates"][3];
  const auto row_of = [&](const std::string& html) {
    const size_t row = html.find("<tr data-model=\"" + c["model"].get<std::string>() + "\"");
    return row == std::string::npos ? std::string() : html.substr(row, html.find("</tr>", row) - row);
  };
  const std::string before = row_of(ReportHtml(r, {}, NoCharts()));
  ASSERT_FALSE(before.empty());
  EXPECT_THAT(before, Not(HasSubstr(" / ")));
  EXPECT_THAT(before, Not(HasSubstr("left out: predicts strips")));
  c["heldout_rms_px"] = 0.1234;
  c["heldout_strips_px"] = 0.5678;
  c["vetoed"] = true;
  const std::string html = ReportHtml(r, {}, NoCharts());
  const std::string tr = row_of(html);
  ASSERT_FALSE(tr.empty());
  EXPECT_THAT(tr, HasSubstr("0.1234 / 0.5678"));
  EXPECT_THAT(tr, HasSubstr("left out: predicts strips of the screen left out of the fit worse than a simpler "
                            "adequate model"));
  EXPECT_THAT(html, HasSubstr("held-out RMS, px (shuffled / strips)"));
}

TEST(Report, EveryStringIsEscaped) {
  json r = Corpus("cylinder-1080r.json");
  const std::string evil = "<script>alert('x')</script>&\"";
  r["inputs"]["monitor"]["name"] = evil;
  r["command"] = evil;
  r["fit"]["choice_reason"] = evil;
  r["fit"]["assumptions"][0] = evil;
  r["features"][0]["id"] = evil;
  const std::string html = ReportHtml(r, {}, NoCharts());
  EXPECT_THAT(html, Not(HasSubstr("<script>alert")));
  EXPECT_EQ(Count(html, "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;&amp;&quot;"), 7);
  // (monitor name in the title, the heading and the provenance; command; choice reason; assumption; feature id)
  EXPECT_EQ(Count(html, "<script>"), 1);  // the page's own image check
}

TEST(Report, MissingOverlaysAreSaidNotFailed) {
  const json r = Corpus("cylinder-1080r.json");
  const fs::path dir = fs::path(::testing::TempDir()) / "report_test_assets";
  fs::remove_all(dir);
  fs::create_directories(dir);
  ReportAssets assets = LoadReportAssets(r, dir, (dir / "result.json").string());
  EXPECT_TRUE(assets.overlay_png.empty());
  ASSERT_EQ(assets.overlay_missing.count("photo-exact.png"), 1u);
  const std::string html = ReportHtml(r, assets, NoCharts());
  EXPECT_THAT(html, HasSubstr("No overlay image: overlay-photo-exact.png was not found beside result.json."));
  EXPECT_EQ(Count(html, "<img "), 0);

  WriteFileAtomic(dir / "overlay-photo-exact.png", "not a png at all");
  assets = LoadReportAssets(r, dir, "result.json");
  EXPECT_THAT(assets.overlay_missing["photo-exact.png"], HasSubstr("is not a PNG image"));
  WriteFileAtomic(dir / "overlay-photo-exact.png", RenderGnuplot("plot x", ChartFormat::kPng, {200, 150}));
  assets = LoadReportAssets(r, dir, "result.json");
  EXPECT_EQ(assets.overlay_png.count("photo-exact.png"), 1u);
  EXPECT_EQ(Count(ReportHtml(r, assets, NoCharts()), "<img "), 1);
}

// Issue 18: a photo-like overlay is embedded as JPEG at its own size (the page stays small without showing less);
// a small flat image (gnuplot's PNG above) stays PNG because JPEG would not be smaller.
TEST(Report, APhotoOverlayIsEmbeddedAsJpegOfTheSameSizeAndPixels) {
  const json r = Corpus("cylinder-1080r.json");
  // 1200 x 800 gray texture (smooth noise, like a photo's sensor noise over a pattern) with one red and one green
  // 3 px line, as WriteOverlays draws them.
  cv::Mat noise(100, 150, CV_8UC1), img;
  cv::randu(noise, 40, 220);
  cv::Mat big;
  cv::resize(noise, big, cv::Size(1200, 800), 0, 0, cv::INTER_LINEAR);
  cv::merge(std::vector<cv::Mat>{big, big, big}, img);
  img.rowRange(400, 403).setTo(cv::Scalar(0, 0, 255));
  img.colRange(600, 603).setTo(cv::Scalar(0, 160, 0));
  std::vector<uchar> png;
  ASSERT_TRUE(cv::imencode(".png", img, png));
  ReportAssets assets;
  assets.overlay_png["photo-exact.png"] = std::string(png.begin(), png.end());
  const std::string html = ReportHtml(r, assets, NoCharts());
  const std::string head = "src=\"data:image/jpeg;base64,";
  ASSERT_EQ(Count(html, head), 1);
  EXPECT_EQ(Count(html, "src=\"data:image/png;"), 0);
  const size_t begin = html.find(head) + head.size();
  const std::string b64 = html.substr(begin, html.find('"', begin) - begin);
  EXPECT_LT(b64.size(), png.size() / 2);  // measured 0.19x the PNG's size
  // Base64 back to bytes (RFC 4648), then the same size and nearly the same pixels: mean |difference| < 1.5 grey
  // levels, the lines still there (measured 0.85).
  std::string bytes;
  int bits = 0, value = 0;
  for (const char c : b64) {
    const auto at = std::string_view("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/").find(c);
    if (at == std::string_view::npos) continue;
    value = (value << 6) | static_cast<int>(at);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      bytes.push_back(static_cast<char>((value >> bits) & 0xff));
    }
  }
  const cv::Mat shown = DecodeImage(bytes, "the page's overlay");
  ASSERT_EQ(shown.size(), img.size());
  ASSERT_EQ(shown.type(), img.type());
  cv::Mat diff;
  cv::absdiff(shown, img, diff);
  const cv::Scalar mean = cv::mean(diff);
  std::cout << "jpeg " << b64.size() * 3 / 4 << " bytes against png " << png.size() << "; mean |difference| "
            << (mean[0] + mean[1] + mean[2]) / 3 << " grey levels\n";
  EXPECT_LT((mean[0] + mean[1] + mean[2]) / 3, 1.5);
  EXPECT_GT(shown.at<cv::Vec3b>(401, 100)[2], 200);  // the red line
  EXPECT_LT(shown.at<cv::Vec3b>(401, 100)[0], 60);
  EXPECT_GT(shown.at<cv::Vec3b>(100, 601)[1], 120);  // the green line
  EXPECT_LT(shown.at<cv::Vec3b>(100, 601)[2], 60);
}

TEST(Report, WithoutAFitThePageSaysWhyAndKeepsTheVerification) {
  const json r = Corpus("rejected-photos-nofit.json");
  const std::string html = ReportHtml(r, {});
  EXPECT_EQ(DataValue(html, "radius-mm"), "null");
  EXPECT_EQ(DataValue(html, "chosen-model"), "");
  EXPECT_THAT(html, HasSubstr("No screen fit: the screen fit was not requested"));
  EXPECT_THAT(html, HasSubstr("2 of 3 photos were rejected"));
  EXPECT_THAT(html, Not(HasSubstr("<table id=\"models\">")));
  EXPECT_EQ(Count(html, "<tr data-photo="), 3);
  EXPECT_THAT(html, HasSubstr("data-status=\"rejected\""));
  EXPECT_THAT(html, HasSubstr("5120 x 1440 px but the camera model"));
  // Charts without data say so: the deviation map (no fit); the histogram and the residual map are drawn.
  EXPECT_THAT(html, HasSubstr("No chart: the result has no deviations"));
  EXPECT_EQ(Count(html, "src=\"data:image/png;base64,iVBORw0KGgo"), 2);
  EXPECT_EQ(DataValue(html, "p95-display-px"), fmt::format("{}", r["verification"]["p95_display_px"].get<double>()));
}

TEST(Report, OddNamesDoNotBreakTheCharts) {
  // Names reach gnuplot as tick labels (radius chart) and titles (residual map): quotes, backslashes, comment
  // characters and line breaks must not break the scripts.
  json r = Corpus("cylinder-1080r.json");
  r["fit"]["candidates"][3]["model"] = "odd \"model\" #1 \\ \n'x'";
  const std::string html = ReportHtml(r, {});
  EXPECT_THAT(html, Not(HasSubstr("No chart")));
  EXPECT_EQ(Count(html, "src=\"data:image/png;base64,iVBORw0KGgo"), 4);
}

TEST(Report, RefusesABrokenDocumentNamingItsSource) {
  json r = Corpus("cylinder-1080r.json");
  r["fit"]["candidates"][2]["radius_mm"] = "1000";
  ReportAssets assets;
  assets.source = "here/result.json";
  try {
    ReportHtml(r, assets, NoCharts());
    FAIL() << "accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("here/result.json: key 'fit.candidates[2].radius_mm' is a string"));
  }
}

TEST(Report, OverlayNamesMatchTheAnalysis) {
  EXPECT_EQ(OverlayFileName("photo-exact.png"), "overlay-photo-exact.png");
  EXPECT_EQ(OverlayFileName("IMG_0001.JPG"), "overlay-IMG_0001.png");
}

}  // namespace
}  // namespace curvecheck
