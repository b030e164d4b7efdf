#include "capture/exif.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <string>

namespace curvecheck {
namespace {

// Little-endian TIFF writer for the test: IFD0 with Make, Model and an Exif pointer; the Exif IFD with
// DateTimeOriginal, ExposureTime, FNumber and ISO.
class TiffBuilder {
 public:
  void U16(std::string& s, uint32_t v) {
    s += static_cast<char>(v & 0xFF);
    s += static_cast<char>(v >> 8 & 0xFF);
  }
  void U32(std::string& s, uint32_t v) {
    U16(s, v & 0xFFFF);
    U16(s, v >> 16);
  }
  std::string Build() {
    std::string t = "II";
    U16(t, 42);
    U32(t, 8);
    // IFD0 at 8: 3 entries -> 2 + 36 + 4 = 42 bytes, data from 50.
    const std::string make = "Canon", model = "Canon EOS R6";  // both longer than 4 bytes: stored by offset
    const uint32_t data0 = 50;
    const uint32_t exif_ifd = data0 + static_cast<uint32_t>(make.size() + 1 + model.size() + 1);
    U16(t, 3);
    Entry(t, 0x010F, 2, static_cast<uint32_t>(make.size() + 1), data0);
    Entry(t, 0x0110, 2, static_cast<uint32_t>(model.size() + 1), data0 + static_cast<uint32_t>(make.size() + 1));
    Entry(t, 0x8769, 4, 1, exif_ifd);
    U32(t, 0);
    t += make + '\0' + model + '\0';
    // Exif IFD: 4 entries -> 2 + 48 + 4 = 54 bytes, then date (20), two rationals (16).
    const uint32_t date = exif_ifd + 54, exposure = date + 20, fnum = exposure + 8;
    U16(t, 4);
    Entry(t, 0x829A, 5, 1, exposure);
    Entry(t, 0x829D, 5, 1, fnum);
    Entry(t, 0x8827, 3, 1, 400);
    Entry(t, 0x9003, 2, 20, date);
    U32(t, 0);
    t += std::string("2024:05:01 12:34:56") + '\0';
    U32(t, 1);
    U32(t, 125);
    U32(t, 56);
    U32(t, 10);
    return t;
  }

 private:
  void Entry(std::string& s, uint32_t tag, uint32_t type, uint32_t count, uint32_t value) {
    U16(s, tag);
    U16(s, type);
    U32(s, count);
    U32(s, value);
  }
};

TEST(Exif, ReadsTheRecordedTagsFromAJpeg) {
  const std::string tiff = TiffBuilder().Build();
  std::string app1 = std::string("Exif\0\0", 6) + tiff;
  std::string jpeg = "\xFF\xD8\xFF\xE1";
  const size_t len = app1.size() + 2;
  jpeg += static_cast<char>(len >> 8);
  jpeg += static_cast<char>(len & 0xFF);
  jpeg += app1 + "\xFF\xDA";
  const nlohmann::json e = ReadExif(jpeg);
  EXPECT_EQ(e.value("make", ""), "Canon");
  EXPECT_EQ(e.value("model", ""), "Canon EOS R6");
  EXPECT_EQ(e.value("date_time_original", ""), "2024:05:01 12:34:56");
  EXPECT_DOUBLE_EQ(e.value("exposure_time_s", 0.0), 1.0 / 125);
  EXPECT_DOUBLE_EQ(e.value("f_number", 0.0), 5.6);
  EXPECT_EQ(e.value("iso", 0), 400);
}

TEST(Exif, NothingFromFilesWithoutExifOrBroken) {
  EXPECT_TRUE(ReadExif("\x89PNG\r\n\x1a\n").empty());
  EXPECT_TRUE(ReadExif("").empty());
  std::string truncated = "\xFF\xD8\xFF\xE1\x00\x40";
  truncated += std::string("Exif\0\0II*\0", 10);
  EXPECT_TRUE(ReadExif(truncated).empty());
  const std::string tiff = TiffBuilder().Build();
  EXPECT_EQ(ReadExif(tiff.substr(0, 60)).value("make", ""), "Canon");  // cut inside: what is there is read
}

}  // namespace
}  // namespace curvecheck
