#include "capture/exif.h"

#include <cstdint>
#include <string>

namespace curvecheck {
namespace {

// TIFF structure inside the EXIF block: header (byte order, 42, offset of IFD0), IFDs of 12-byte entries
// (tag, type, count, value or offset). All offsets are from the TIFF header.
class Tiff {
 public:
  explicit Tiff(std::string_view b) : b_(b) {}
  bool Init() {
    if (b_.size() < 8) return false;
    if (b_.substr(0, 2) == "II") {
      le_ = true;
    } else if (b_.substr(0, 2) == "MM") {
      le_ = false;
    } else {
      return false;
    }
    return U16(2) == 42;
  }
  bool In(size_t off, size_t n) const { return off <= b_.size() && n <= b_.size() - off; }
  uint32_t U16(size_t off) const {
    if (!In(off, 2)) return 0;
    const auto p = [&](size_t i) { return static_cast<uint32_t>(static_cast<uint8_t>(b_[off + i])); };
    return le_ ? p(0) | p(1) << 8 : p(0) << 8 | p(1);
  }
  uint32_t U32(size_t off) const { return le_ ? U16(off) | U16(off + 2) << 16 : U16(off) << 16 | U16(off + 2); }

  // Reads the entries of the IFD at `off` into `out`; returns the Exif sub-IFD offset (0 if none).
  uint32_t ReadIfd(uint32_t off, nlohmann::json& out) const {
    const uint32_t n = U16(off);
    uint32_t exif_ifd = 0;
    for (uint32_t i = 0; i < n && i < 500; ++i) {
      const size_t e = off + 2 + 12 * size_t{i};
      if (!In(e, 12)) break;
      const uint32_t tag = U16(e), type = U16(e + 2), count = U32(e + 4);
      const size_t value_off = e + 8;
      switch (tag) {
        case 0x010F: Ascii(type, count, value_off, "make", out); break;
        case 0x0110: Ascii(type, count, value_off, "model", out); break;
        case 0x0132: Ascii(type, count, value_off, "date_time", out); break;
        case 0x9003: Ascii(type, count, value_off, "date_time_original", out); break;
        case 0x829A: Rational(type, value_off, "exposure_time_s", out); break;
        case 0x829D: Rational(type, value_off, "f_number", out); break;
        case 0x920A: Rational(type, value_off, "focal_length_mm", out); break;
        case 0xA405:
          if (type == 3 && U16(value_off) > 0) out["focal_length_35mm"] = U16(value_off);
          break;
        case 0x8827:
          if (type == 3) out["iso"] = U16(value_off);
          break;
        case 0x8769: exif_ifd = U32(value_off); break;
        default: break;
      }
    }
    return exif_ifd;
  }

 private:
  void Ascii(uint32_t type, uint32_t count, size_t value_off, const char* key, nlohmann::json& out) const {
    if (type != 2 || count == 0) return;
    const size_t off = count <= 4 ? value_off : U32(value_off);
    if (!In(off, count)) return;
    std::string s(b_.substr(off, count));
    while (!s.empty() && (s.back() == '\0' || s.back() == ' ')) s.pop_back();
    for (char& c : s) {
      if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) > 126) c = '?';
    }
    if (!s.empty()) out[key] = s;
  }
  void Rational(uint32_t type, size_t value_off, const char* key, nlohmann::json& out) const {
    if (type != 5) return;
    const uint32_t off = U32(value_off);
    if (!In(off, 8)) return;
    const uint32_t num = U32(off), den = U32(off + 4);
    if (den != 0) out[key] = static_cast<double>(num) / den;
  }

  std::string_view b_;
  bool le_ = true;
};

nlohmann::json ReadTiff(std::string_view tiff) {
  nlohmann::json out = nlohmann::json::object();
  Tiff t(tiff);
  if (!t.Init()) return out;
  const uint32_t exif = t.ReadIfd(t.U32(4), out);
  if (exif != 0) t.ReadIfd(exif, out);
  return out;
}

}  // namespace

nlohmann::json ReadExif(std::string_view b) {
  if (b.size() >= 4 && (b.substr(0, 4) == std::string_view("II*\0", 4) || b.substr(0, 4) == std::string_view("MM\0*", 4))) {
    return ReadTiff(b);
  }
  if (b.size() < 4 || static_cast<uint8_t>(b[0]) != 0xFF || static_cast<uint8_t>(b[1]) != 0xD8) {
    return nlohmann::json::object();
  }
  // JPEG: walk the marker segments up to the start of scan.
  size_t pos = 2;
  while (pos + 4 <= b.size() && static_cast<uint8_t>(b[pos]) == 0xFF) {
    const uint8_t marker = static_cast<uint8_t>(b[pos + 1]);
    if (marker == 0xDA || marker == 0xD9) break;
    const size_t len = static_cast<size_t>(static_cast<uint8_t>(b[pos + 2])) << 8 | static_cast<uint8_t>(b[pos + 3]);
    if (len < 2 || pos + 2 + len > b.size()) break;
    const std::string_view seg = b.substr(pos + 4, len - 2);
    if (marker == 0xE1 && seg.size() > 6 && seg.substr(0, 6) == std::string_view("Exif\0\0", 6)) {
      return ReadTiff(seg.substr(6));
    }
    pos += 2 + len;
  }
  return nlohmann::json::object();
}

}  // namespace curvecheck
