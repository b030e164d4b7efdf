#include "mpcdi/mpcdi_file.h"

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <minizip/unzip.h>
#include <minizip/zip.h>
#include <tinyxml2.h>

#include <cctype>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <memory>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"

namespace curvecheck {
namespace fs = std::filesystem;
namespace {

constexpr char kWarpMember[] = "warp.pfm";
constexpr char kAlphaMember[] = "alpha.png";
constexpr char kXmlMember[] = "mpcdi.xml";
constexpr int kMaxGridSamples = 8192;

void PutFloatLe(std::string& out, float f) {
  uint32_t bits;
  std::memcpy(&bits, &f, sizeof bits);
  for (int k = 0; k < 4; ++k) out.push_back(static_cast<char>((bits >> (8 * k)) & 0xff));
}

float GetFloat(const unsigned char* p, bool little_endian) {
  uint32_t bits = 0;
  for (int k = 0; k < 4; ++k) bits |= static_cast<uint32_t>(p[little_endian ? k : 3 - k]) << (8 * k);
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

std::string XmlEscape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '&': out += "&amp;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string NowUtc() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  return fmt::format("{:%Y-%m-%d %H:%M:%S}", tm);
}

// One ZIP member, deflated.
void AddMember(zipFile zf, const std::string& name, std::string_view data, const fs::path& path) {
  // The member's time stamp: now (minizip takes the full year; an all-zero date is an invalid 1980-01-00).
  zip_fileinfo info{};
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  info.tmz_date.tm_sec = static_cast<uInt>(tm.tm_sec);
  info.tmz_date.tm_min = static_cast<uInt>(tm.tm_min);
  info.tmz_date.tm_hour = static_cast<uInt>(tm.tm_hour);
  info.tmz_date.tm_mday = static_cast<uInt>(tm.tm_mday);
  info.tmz_date.tm_mon = static_cast<uInt>(tm.tm_mon);
  info.tmz_date.tm_year = static_cast<uInt>(tm.tm_year + 1900);
  if (zipOpenNewFileInZip64(zf, name.c_str(), &info, nullptr, 0, nullptr, 0, nullptr, Z_DEFLATED,
                            Z_DEFAULT_COMPRESSION, data.size() >= 0xffffffffu ? 1 : 0) != ZIP_OK ||
      zipWriteInFileInZip(zf, data.data(), static_cast<unsigned>(data.size())) != ZIP_OK ||
      zipCloseFileInZip(zf) != ZIP_OK) {
    throw Error(path.string(), fmt::format("writing the archive member {} failed", name),
                "check the disk space and permissions of the folder");
  }
}

// The text of child element `name` of `parent`; throws naming the file and element path if missing.
std::string ChildText(const tinyxml2::XMLElement* parent, const char* name, const std::string& where,
                      const std::string& source) {
  const tinyxml2::XMLElement* e = parent->FirstChildElement(name);
  if (!e || !e->GetText()) {
    throw Error(source, fmt::format("mpcdi.xml: <{}> has no <{}>", where, name),
                "write it per MPCDI v2.0 (README \"MPCDI export\")");
  }
  std::string text = e->GetText();
  const size_t a = text.find_first_not_of(" \t\r\n"), b = text.find_last_not_of(" \t\r\n");
  return a == std::string::npos ? std::string() : text.substr(a, b - a + 1);
}

int ChildInt(const tinyxml2::XMLElement* parent, const char* name, const std::string& where, const std::string& source) {
  const std::string text = ChildText(parent, name, where, source);
  try {
    size_t used = 0;
    const int v = std::stoi(text, &used);
    if (used == text.size()) return v;
  } catch (const std::exception&) {
  }
  throw Error(source, fmt::format("mpcdi.xml: <{}><{}> is '{}', not an integer", where, name, text), "");
}

int IntAttribute(const tinyxml2::XMLElement* e, const char* name, const std::string& where, const std::string& source) {
  int v = 0;
  if (e->QueryIntAttribute(name, &v) != tinyxml2::XML_SUCCESS) {
    throw Error(source, fmt::format("mpcdi.xml: <{}> has no integer attribute {}", where, name), "");
  }
  return v;
}

// RAII for an open archive being read.
struct UnzCloser {
  void operator()(void* f) const { unzClose(f); }
};

std::string ReadMember(unzFile zf, const std::string& name, const std::string& source) {
  if (unzLocateFile(zf, name.c_str(), 1) != UNZ_OK) {
    throw Error(source, fmt::format("the archive has no member '{}'", name), "the .mpcdi file is incomplete");
  }
  unz_file_info64 info{};
  if (unzGetCurrentFileInfo64(zf, &info, nullptr, 0, nullptr, 0, nullptr, 0) != UNZ_OK ||
      info.uncompressed_size > (1ull << 31) || unzOpenCurrentFile(zf) != UNZ_OK) {
    throw Error(source, fmt::format("the archive member '{}' cannot be read", name), "the .mpcdi file is damaged");
  }
  std::string data(info.uncompressed_size, '\0');
  const int got = data.empty() ? 0 : unzReadCurrentFile(zf, data.data(), static_cast<unsigned>(data.size()));
  const int closed = unzCloseCurrentFile(zf);  // checks the CRC
  if (got != static_cast<int>(data.size()) || closed != UNZ_OK) {
    throw Error(source, fmt::format("the archive member '{}' is damaged (short read or CRC mismatch)", name),
                "export the file again");
  }
  return data;
}

}  // namespace

std::string EncodeWarpPfm(const WarpGrid& g) {
  g.Check("warp grid");
  std::string out = fmt::format("PF\n{} {}\n-1.0\n", g.cols, g.rows);
  out.reserve(out.size() + static_cast<size_t>(g.cols) * g.rows * 12);
  for (int j = g.rows - 1; j >= 0; --j) {  // netpbm: the bottom row first
    for (int i = 0; i < g.cols; ++i) {
      PutFloatLe(out, g.At(i, j).x());
      PutFloatLe(out, g.At(i, j).y());
      PutFloatLe(out, 0.0f);
    }
  }
  return out;
}

WarpGrid DecodeWarpPfm(std::string_view bytes, const std::string& source, int display_width_px, int display_height_px) {
  // Header: three whitespace-separated tokens after "PF", the last followed by exactly one whitespace byte.
  size_t pos = 0;
  auto token = [&]() -> std::string {
    while (pos < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[pos]))) ++pos;
    const size_t start = pos;
    while (pos < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[pos])) && pos - start < 32) ++pos;
    return std::string(bytes.substr(start, pos - start));
  };
  const std::string magic = token();
  if (magic != "PF") {
    throw Error(source, fmt::format("the warp is not a colour PFM (starts '{}', not 'PF')", magic.substr(0, 8)),
                "write R = u, G = v, B = 0 as a 3-channel PFM");
  }
  int cols = 0, rows = 0;
  double scale = 0;
  try {
    cols = std::stoi(token());
    rows = std::stoi(token());
    scale = std::stod(token());
  } catch (const std::exception&) {
    throw Error(source, "the PFM header is damaged (width, height and scale expected)", "");
  }
  if (pos >= bytes.size() || !std::isspace(static_cast<unsigned char>(bytes[pos]))) {
    throw Error(source, "the PFM header is not followed by its data", "");
  }
  ++pos;
  if (cols < 2 || rows < 2 || cols > kMaxGridSamples || rows > kMaxGridSamples || !(std::abs(scale) > 0) ||
      !std::isfinite(scale)) {
    throw Error(source, fmt::format("PFM of {} x {} samples, scale {}: not a warp grid", cols, rows, scale),
                fmt::format("2 to {} samples across and down, a non-zero scale", kMaxGridSamples));
  }
  const size_t need = static_cast<size_t>(cols) * rows * 12;
  if (bytes.size() - pos != need) {
    throw Error(source, fmt::format("PFM of {} x {} samples holds {} data bytes, not {}", cols, rows,
                                    bytes.size() - pos, need), "the file is truncated or not a 3-channel PFM");
  }
  WarpGrid g;
  g.cols = cols;
  g.rows = rows;
  g.display_width_px = display_width_px;
  g.display_height_px = display_height_px;
  g.uv.resize(static_cast<size_t>(cols) * rows);
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data() + pos);
  const bool little = scale < 0;
  for (int r = 0; r < rows; ++r) {
    const int j = rows - 1 - r;  // the file's first row is the bottom one
    for (int i = 0; i < cols; ++i, p += 12) {
      g.uv[static_cast<size_t>(j) * cols + i] = Eigen::Vector2f(GetFloat(p, little), GetFloat(p + 4, little));
    }
  }
  g.Check(source.c_str());
  return g;
}

std::vector<uint8_t> AlphaFromWarp(const WarpGrid& g) {
  g.Check("warp grid");
  std::vector<uint8_t> alpha(static_cast<size_t>(g.display_width_px) * g.display_height_px);
  for (int y = 0; y < g.display_height_px; ++y) {
    for (int x = 0; x < g.display_width_px; ++x) {
      const Eigen::Vector2d uv = g.Sample({x, y});
      const bool inside = uv.x() >= 0 && uv.x() <= 1 && uv.y() >= 0 && uv.y() <= 1;
      alpha[static_cast<size_t>(y) * g.display_width_px + x] = inside ? 255 : 0;
    }
  }
  return alpha;
}

std::string MpcdiXml(const WarpGrid& g, const MpcdiWriteOptions& o) {
  g.Check("warp grid");
  const int w = g.display_width_px, h = g.display_height_px;
  std::string comment = o.comment;
  for (size_t k; (k = comment.find("--")) != std::string::npos;) comment.replace(k, 2, "- -");  // not allowed in comments
  return fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<!-- {comment} -->\n"
      "<MPCDI profile=\"2d\" geometry=\"1\" color=\"1\" version=\"2.0\" date=\"{date}\">\n"
      "  <display>\n"
      "    <buffer id=\"display\" xResolution=\"{w}\" yResolution=\"{h}\">\n"
      "      <region id=\"display\" x=\"0\" y=\"0\" xSize=\"1\" ySize=\"1\" xResolution=\"{w}\" yResolution=\"{h}\"/>\n"
      "    </buffer>\n"
      "  </display>\n"
      "  <files>\n"
      "    <fileset region=\"display\">\n"
      "      <geometryWarpFile>\n"
      "        <path>{warp}</path>\n"
      "        <interpolation>linear</interpolation>\n"
      "        <componentDepth>3</componentDepth>\n"
      "        <bitDepth>32</bitDepth>\n"
      "        <xSize>{cols}</xSize>\n"
      "        <ySize>{rows}</ySize>\n"
      "      </geometryWarpFile>\n"
      "      <alphaMap>\n"
      "        <path>{alpha}</path>\n"
      "        <componentDepth>1</componentDepth>\n"
      "        <bitDepth>8</bitDepth>\n"
      "        <gammaEmbedded>1.0</gammaEmbedded>\n"
      "      </alphaMap>\n"
      "    </fileset>\n"
      "  </files>\n"
      "</MPCDI>\n",
      fmt::arg("comment", XmlEscape(comment)), fmt::arg("date", XmlEscape(o.date.empty() ? NowUtc() : o.date)),
      fmt::arg("w", w), fmt::arg("h", h), fmt::arg("warp", kWarpMember), fmt::arg("cols", g.cols),
      fmt::arg("rows", g.rows), fmt::arg("alpha", kAlphaMember));
}

void WriteMpcdi(const fs::path& path, const WarpGrid& g, const MpcdiWriteOptions& o) {
  const std::string xml = MpcdiXml(g, o);
  const std::string pfm = EncodeWarpPfm(g);
  std::string png;
  {
    const TempFolder tmp("curvecheck_mpcdi", "the alpha map");
    const std::vector<uint8_t> alpha = AlphaFromWarp(g);
    WritePng8(tmp.path() / kAlphaMember, g.display_width_px, g.display_height_px, 1, alpha.data());
    png = ReadFileToString(tmp.path() / kAlphaMember);
  }
  OutputSet set;
  set.WriteWith(path, [&](const fs::path& staged) {
    zipFile zf = zipOpen64(staged.c_str(), APPEND_STATUS_CREATE);
    if (!zf) {
      throw Error(staged.string(), "cannot be created as a ZIP archive", "check the folder's permissions");
    }
    try {
      AddMember(zf, kXmlMember, xml, staged);
      AddMember(zf, kWarpMember, pfm, staged);
      AddMember(zf, kAlphaMember, png, staged);
    } catch (...) {
      zipClose(zf, nullptr);
      throw;
    }
    if (zipClose(zf, nullptr) != ZIP_OK) {
      throw Error(staged.string(), "finishing the ZIP archive failed", "check the disk space");
    }
  });
  set.Publish();
}

MpcdiContents ReadMpcdi(const fs::path& path) {
  const std::string source = path.string();
  if (!fs::is_regular_file(path)) {
    throw Error(source, "is not a file", "give the .mpcdi file export-mpcdi wrote");
  }
  std::unique_ptr<void, UnzCloser> zf(unzOpen64(path.c_str()));
  if (!zf) throw Error(source, "is not a ZIP archive", "an .mpcdi file is a ZIP with mpcdi.xml inside");
  MpcdiContents c;
  c.xml = ReadMember(zf.get(), kXmlMember, source);
  tinyxml2::XMLDocument doc;
  if (doc.Parse(c.xml.data(), c.xml.size()) != tinyxml2::XML_SUCCESS) {
    throw Error(source, fmt::format("mpcdi.xml is not valid XML: {}", doc.ErrorStr()), "");
  }
  const tinyxml2::XMLElement* root = doc.FirstChildElement("MPCDI");
  if (!root) throw Error(source, "mpcdi.xml has no <MPCDI> root element", "");
  c.profile = root->Attribute("profile") ? root->Attribute("profile") : "";
  c.version = root->Attribute("version") ? root->Attribute("version") : "";
  if (c.profile != "2d") {
    throw Error(source, fmt::format("profile '{}' is not the 2d profile this reader reads", c.profile), "");
  }
  const tinyxml2::XMLElement* display = root->FirstChildElement("display");
  const tinyxml2::XMLElement* buffer = display ? display->FirstChildElement("buffer") : nullptr;
  const tinyxml2::XMLElement* region = buffer ? buffer->FirstChildElement("region") : nullptr;
  if (!region) throw Error(source, "mpcdi.xml has no <display><buffer><region>", "");
  c.buffer_id = buffer->Attribute("id") ? buffer->Attribute("id") : "";
  c.region_id = region->Attribute("id") ? region->Attribute("id") : "";
  c.buffer_width_px = IntAttribute(buffer, "xResolution", "buffer", source);
  c.buffer_height_px = IntAttribute(buffer, "yResolution", "buffer", source);
  const int region_w = IntAttribute(region, "xResolution", "region", source);
  const int region_h = IntAttribute(region, "yResolution", "region", source);
  const tinyxml2::XMLElement* files = root->FirstChildElement("files");
  const tinyxml2::XMLElement* fileset = files ? files->FirstChildElement("fileset") : nullptr;
  while (fileset && c.region_id != (fileset->Attribute("region") ? fileset->Attribute("region") : "")) {
    fileset = fileset->NextSiblingElement("fileset");
  }
  if (!fileset) throw Error(source, fmt::format("mpcdi.xml has no <files><fileset region=\"{}\">", c.region_id), "");
  const tinyxml2::XMLElement* warp = fileset->FirstChildElement("geometryWarpFile");
  if (!warp) throw Error(source, "mpcdi.xml: the fileset has no <geometryWarpFile>", "");
  c.warp_path = ChildText(warp, "path", "geometryWarpFile", source);
  c.interpolation = ChildText(warp, "interpolation", "geometryWarpFile", source);
  c.component_depth = ChildInt(warp, "componentDepth", "geometryWarpFile", source);
  c.bit_depth = ChildInt(warp, "bitDepth", "geometryWarpFile", source);
  const int x_size = ChildInt(warp, "xSize", "geometryWarpFile", source);
  const int y_size = ChildInt(warp, "ySize", "geometryWarpFile", source);
  c.warp = DecodeWarpPfm(ReadMember(zf.get(), c.warp_path, source), source + ": " + c.warp_path, region_w, region_h);
  if (c.warp.cols != x_size || c.warp.rows != y_size) {
    throw Error(source, fmt::format("{} holds {} x {} samples, mpcdi.xml says {} x {}", c.warp_path, c.warp.cols,
                                    c.warp.rows, x_size, y_size), "");
  }
  if (const tinyxml2::XMLElement* alpha = fileset->FirstChildElement("alphaMap")) {
    c.alpha_path = ChildText(alpha, "path", "alphaMap", source);
    const Image8 img = DecodeImage8(ReadMember(zf.get(), c.alpha_path, source), source + ": " + c.alpha_path);
    if (img.channels != 1) {
      throw Error(source, fmt::format("{} has {} channels, not 1 (grey)", c.alpha_path, img.channels), "");
    }
    c.alpha_width_px = img.width;
    c.alpha_height_px = img.height;
    c.alpha = img.pixels;
  }
  return c;
}

}  // namespace curvecheck
