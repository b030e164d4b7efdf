// The MPCDI 2d archive and its PFM: byte layout (netpbm row order, little-endian), write -> read round trip with
// the shipped reader, and refusal of damaged or foreign files.
#include "mpcdi/mpcdi_file.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>

#include "core/error.h"
#include "core/file_io.h"
#include "core/test_util.h"

namespace curvecheck {
namespace {

namespace fs = std::filesystem;
using testing::MessageOf;

// A 3 x 2 grid with distinct values: u = i/10 + j/100, v = 1 - j.
WarpGrid SmallGrid() {
  WarpGrid g;
  g.cols = 3;
  g.rows = 2;
  g.display_width_px = 30;
  g.display_height_px = 20;
  for (int j = 0; j < 2; ++j) {
    for (int i = 0; i < 3; ++i) g.uv.emplace_back(i / 10.0f + j / 100.0f, 1.0f - j);
  }
  return g;
}

float FloatAt(const std::string& bytes, size_t offset) {
  uint32_t bits = 0;
  for (int k = 0; k < 4; ++k) bits |= static_cast<uint32_t>(static_cast<unsigned char>(bytes[offset + k])) << (8 * k);
  float f;
  std::memcpy(&f, &bits, 4);
  return f;
}

TEST(WarpPfm, NetpbmRowOrderLittleEndianRgIsUv) {
  const std::string pfm = EncodeWarpPfm(SmallGrid());
  const std::string header = "PF\n3 2\n-1.0\n";
  ASSERT_EQ(pfm.substr(0, header.size()), header);
  ASSERT_EQ(pfm.size(), header.size() + 3 * 2 * 12);
  // The first sample in the file is the bottom-left one (grid row 1): u = 0.01, v = 0; B = 0.
  EXPECT_FLOAT_EQ(FloatAt(pfm, header.size()), 0.01f);
  EXPECT_FLOAT_EQ(FloatAt(pfm, header.size() + 4), 0.0f);
  EXPECT_FLOAT_EQ(FloatAt(pfm, header.size() + 8), 0.0f);
  // The last one is the top-right (grid row 0): u = 0.2, v = 1.
  EXPECT_FLOAT_EQ(FloatAt(pfm, pfm.size() - 12), 0.2f);
  EXPECT_FLOAT_EQ(FloatAt(pfm, pfm.size() - 8), 1.0f);
  const WarpGrid back = DecodeWarpPfm(pfm, "test.pfm", 30, 20);
  EXPECT_EQ(back.uv, SmallGrid().uv);
}

TEST(WarpPfm, BigEndianIsReadByTheScaleSign) {
  std::string pfm = "PF\n2 2\n1.0\n";
  for (int k = 0; k < 4; ++k) {
    for (float f : {0.25f * k, 0.5f, 0.0f}) {
      uint32_t bits;
      std::memcpy(&bits, &f, 4);
      for (int b = 3; b >= 0; --b) pfm.push_back(static_cast<char>((bits >> (8 * b)) & 0xff));
    }
  }
  const WarpGrid g = DecodeWarpPfm(pfm, "be.pfm", 10, 10);
  EXPECT_FLOAT_EQ(g.At(0, 1).x(), 0.0f);   // the file's first sample: bottom-left
  EXPECT_FLOAT_EQ(g.At(1, 0).x(), 0.75f);  // its last: top-right
}

TEST(WarpPfm, RefusesForeignAndDamagedData) {
  const std::string pfm = EncodeWarpPfm(SmallGrid());
  EXPECT_THAT(MessageOf([&] { DecodeWarpPfm(pfm.substr(0, pfm.size() - 1), "w.pfm", 30, 20); }),
              ::testing::HasSubstr("holds 71 data bytes, not 72"));
  EXPECT_THAT(MessageOf([&] { DecodeWarpPfm("Pf\n3 2\n-1.0\n", "w.pfm", 30, 20); }),
              ::testing::HasSubstr("not a colour PFM"));
  EXPECT_THAT(MessageOf([&] { DecodeWarpPfm("PF\n1 2\n-1.0\n", "w.pfm", 30, 20); }),
              ::testing::HasSubstr("not a warp grid"));
  std::string nan = pfm;
  std::memset(nan.data() + nan.size() - 12, 0xff, 4);
  EXPECT_THAT(MessageOf([&] { DecodeWarpPfm(nan, "w.pfm", 30, 20); }), ::testing::HasSubstr("not a finite number"));
}

TEST(WarpAlpha, MasksWhereTheWarpReadsOutsideTheSource) {
  WarpGrid g = SmallGrid();
  g.uv[0] = Eigen::Vector2f(-0.5f, 1.0f);  // top-left sample outside: u < 0
  const std::vector<uint8_t> alpha = AlphaFromWarp(g);
  ASSERT_EQ(alpha.size(), 30u * 20u);
  EXPECT_EQ(alpha[0], 0);          // top-left pixel reads u ~ -0.48
  EXPECT_EQ(alpha[29], 255);       // top-right
  EXPECT_EQ(alpha[19 * 30], 255);  // bottom-left
}

class MpcdiArchive : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = std::make_unique<TempFolder>("mpcdi_test", "the test"); }
  fs::path Path(const std::string& name) const { return dir_->path() / name; }
  std::unique_ptr<TempFolder> dir_;
};

TEST_F(MpcdiArchive, WriteThenReadRoundTrip) {
  const WarpGrid g = SmallGrid();
  MpcdiWriteOptions o;
  o.comment = "test -- with dashes & <marks>";
  o.date = "2026-12-02 07:00:00";
  WriteMpcdi(Path("w.mpcdi"), g, o);
  const MpcdiContents c = ReadMpcdi(Path("w.mpcdi"));
  EXPECT_EQ(c.profile, "2d");
  EXPECT_EQ(c.version, "2.0");
  EXPECT_EQ(c.buffer_width_px, 30);
  EXPECT_EQ(c.buffer_height_px, 20);
  EXPECT_EQ(c.warp_path, "warp.pfm");
  EXPECT_EQ(c.interpolation, "linear");
  EXPECT_EQ(c.component_depth, 3);
  EXPECT_EQ(c.bit_depth, 32);
  EXPECT_EQ(c.warp.cols, 3);
  EXPECT_EQ(c.warp.rows, 2);
  EXPECT_EQ(c.warp.display_width_px, 30);
  EXPECT_EQ(c.warp.uv, g.uv);
  EXPECT_EQ(c.alpha_path, "alpha.png");
  EXPECT_EQ(c.alpha_width_px, 30);
  EXPECT_EQ(c.alpha_height_px, 20);
  EXPECT_EQ(c.alpha, AlphaFromWarp(g));
  EXPECT_THAT(c.xml, ::testing::HasSubstr("date=\"2026-12-02 07:00:00\""));
  EXPECT_THAT(c.xml, ::testing::HasSubstr("<xSize>3</xSize>"));
  // No temporary is left beside the output.
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir_->path())) files += e.is_regular_file() ? 1 : 0;
  EXPECT_EQ(files, 1);
}

TEST_F(MpcdiArchive, RefusesWhatIsNotAnMpcdiFile) {
  WriteFileAtomic(Path("not.mpcdi"), "plain text");
  EXPECT_THAT(MessageOf([&] { ReadMpcdi(Path("not.mpcdi")); }), ::testing::HasSubstr("is not a ZIP archive"));
  EXPECT_THAT(MessageOf([&] { ReadMpcdi(Path("missing.mpcdi")); }), ::testing::HasSubstr("is not a file"));
}

}  // namespace
}  // namespace curvecheck
