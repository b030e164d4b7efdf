#include "capture/session.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdint>
#include <ctime>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "capture/exif.h"
#include "core/config.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/path_check.h"

namespace curvecheck {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string Fnv1a64Hex(std::string_view bytes) {
  uint64_t h = 14695981039346656037ull;
  for (char c : bytes) {
    h ^= static_cast<uint8_t>(c);
    h *= 1099511628211ull;
  }
  return fmt::format("{:016x}", h);
}

// Copies the pattern (PNG if given, and JSON) into the folder under content-hash names, unless already there.
// Returns the stored names (png name empty if none).
std::pair<std::string, std::string> StorePattern(const fs::path& png, const fs::path& pattern_json,
                                                 const fs::path& folder) {
  const std::string png_bytes = png.empty() ? std::string() : ReadFileToString(png);
  const std::string json_bytes = ReadFileToString(pattern_json);
  const std::string hash = Fnv1a64Hex(png_bytes + '\0' + json_bytes);
  const std::string png_name = png.empty() ? std::string() : "pattern_" + hash + ".png";
  const std::string json_name = "pattern_" + hash + ".json";
  if (!png_name.empty() && !fs::exists(folder / png_name)) WriteFileAtomic(folder / png_name, png_bytes);
  if (!fs::exists(folder / json_name)) WriteFileAtomic(folder / json_name, json_bytes);
  return {png_name, json_name};
}

void CheckPatternJson(const fs::path& p, const std::string& where) {
  if (ClassifyPath(p) == PathKind::kLinkLoop) RequireFile(p);
  if (ClassifyPath(p) != PathKind::kFile) {
    throw Error(where, fmt::format("pattern.json '{}' does not exist", p.string()),
                "keep the .json that `curvecheck render` wrote beside the pattern PNG");
  }
  json j;
  try {
    j = json::parse(ReadFileToString(p));
  } catch (const json::exception& e) {
    throw Error(p.string(), fmt::format("is not valid JSON ({})", e.what()), "give the pattern.json from render");
  }
  if (!j.is_object() || j.value("format", "") != "curvecheck.pattern/1") {
    throw Error(p.string(), "has no \"format\": \"curvecheck.pattern/1\"", "give the pattern.json from render");
  }
}

std::string ShotName(int index_1based, const std::string& ext) { return fmt::format("shot_{:04d}{}", index_1based, ext); }

std::string FileTimeUtc(const fs::path& p) {
  const auto ft = fs::last_write_time(p);
  const auto sys = std::chrono::file_clock::to_sys(ft);
  const std::time_t t = std::chrono::system_clock::to_time_t(sys);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

bool FolderIsEmptyOrMissing(const fs::path& folder) {
  const PathKind kind = ClassifyPath(folder);
  if (kind == PathKind::kLinkLoop) RequireFolder(folder, "");
  std::error_code ec;
  return kind == PathKind::kMissing || (kind == PathKind::kFolder && fs::is_empty(folder, ec) && !ec);
}

void PrepareNewFolder(const fs::path& folder, bool resume_possible) {
  if (!FolderIsEmptyOrMissing(folder)) {
    throw Error(folder.string(), "exists and is not empty",
                resume_possible ? "continue it with --resume, or choose another -o" : "choose another -o");
  }
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) throw Error(folder.string(), "cannot be created: " + ec.message(), "check the path and permissions");
}

void WriteManifest(const fs::path& folder, json& manifest) {
  manifest["updated_utc"] = NowUtcIso8601();
  WriteFileAtomic(folder / kManifestName, manifest.dump(2) + "\n");
}

}  // namespace

SessionPlan LoadSessionPlan(const fs::path& plan_file) {
  const ConfigMap root = ConfigMap::Load(plan_file);  // syntax errors with line and column
  root.RejectUnknownKeys({"shots"});
  const std::string src = plan_file.string();
  const YAML::Node shots = YAML::Load(ReadFileToString(plan_file))["shots"];
  if (!shots || !shots.IsSequence() || shots.size() == 0) {
    throw Error(src, "key 'shots' must be a non-empty list of shots", "see `curvecheck capture session --help`");
  }
  SessionPlan plan;
  plan.source = plan_file;
  const fs::path base = plan_file.parent_path();
  for (size_t i = 0; i < shots.size(); ++i) {
    const std::string where = fmt::format("{} shots[{}]", src, i);
    if (!shots[i].IsMap()) throw Error(where, "is not a mapping", "give pattern: path/to/pattern.png");
    const ConfigMap shot = ConfigMap::Parse(YAML::Dump(shots[i]), where);
    shot.RejectUnknownKeys({"pattern", "viewpoint_mm", "repeat"});
    PlannedShot p;
    p.pattern_png = base / shot.String("pattern");
    if (p.pattern_png.extension() != ".png") {
      throw Error(where, fmt::format("pattern '{}' is not a .png", p.pattern_png.string()),
                  "give the PNG that `curvecheck render` wrote");
    }
    if (ClassifyPath(p.pattern_png) == PathKind::kLinkLoop) RequireFile(p.pattern_png);
    if (ClassifyPath(p.pattern_png) != PathKind::kFile) {
      throw Error(where, fmt::format("pattern '{}' does not exist", p.pattern_png.string()), "check the path");
    }
    p.pattern_json = fs::path(p.pattern_png).replace_extension(".json");
    CheckPatternJson(p.pattern_json, where);
    if (shot.Has("viewpoint_mm")) p.viewpoint_mm = shot.Numbers("viewpoint_mm", 3);
    const int repeat = shot.Has("repeat") ? shot.PositiveInt("repeat") : 1;
    for (int r = 0; r < repeat; ++r) plan.shots.push_back(p);
  }
  return plan;
}

SessionResult RunSession(const SessionPlan& plan, FrameSource& source, const ShowPattern& show,
                         const SessionOptions& options, Progress* progress) {
  const fs::path& folder = options.folder;
  const fs::path manifest_path = folder / kManifestName;
  const int total = static_cast<int>(plan.shots.size());
  json manifest;
  if (options.resume) {
    if (ClassifyPath(manifest_path) != PathKind::kFile) {
      throw Error(folder.string(), "has no manifest.json to resume", "start the session without --resume");
    }
    try {
      manifest = json::parse(ReadFileToString(manifest_path));
    } catch (const json::exception& e) {
      throw Error(manifest_path.string(), fmt::format("is not valid JSON ({})", e.what()), "start a new session");
    }
    if (!manifest.is_object() || manifest.value("format", "") != kSessionFormat || !manifest["shots"].is_array()) {
      throw Error(manifest_path.string(), fmt::format("is not a {} manifest", kSessionFormat), "start a new session");
    }
    if (manifest.value("shots_planned", -1) != total) {
      throw Error(manifest_path.string(),
                  fmt::format("was made for a plan of {} shots, this plan has {}", manifest.value("shots_planned", -1),
                              total),
                  "resume with the same plan");
    }
  } else {
    PrepareNewFolder(folder, ClassifyPath(manifest_path) == PathKind::kFile);
    manifest = {{"format", kSessionFormat},  {"command", options.command}, {"plan", plan.source.string()},
                {"source", source.Describe()}, {"shots_planned", total},    {"created_utc", NowUtcIso8601()},
                {"shots", json::array()}};
    WriteManifest(folder, manifest);
  }
  SessionResult result;
  result.total = total;
  result.resumed_after = static_cast<int>(manifest["shots"].size());
  // Each recorded shot must be the plan's shot at that place (same pattern contents).
  for (int i = 0; i < result.resumed_after && i < total; ++i) {
    const auto [png_name, json_name] = StorePattern(plan.shots[static_cast<size_t>(i)].pattern_png,
                                                    plan.shots[static_cast<size_t>(i)].pattern_json, folder);
    if (manifest["shots"][static_cast<size_t>(i)].value("pattern", "") != png_name) {
      throw Error(manifest_path.string(),
                  fmt::format("shot {} was taken with another pattern than this plan's shot {}", i + 1, i + 1),
                  "resume with the same plan and pattern files");
    }
  }
  if (progress != nullptr) progress->Skip(result.resumed_after);
  for (int i = result.resumed_after; i < total; ++i) {
    const PlannedShot& shot = plan.shots[static_cast<size_t>(i)];
    try {
      const auto [png_name, json_name] = StorePattern(shot.pattern_png, shot.pattern_json, folder);
      show(static_cast<size_t>(i), shot);
      Capture c = source.Grab();
      const std::string ext = c.original_bytes.empty() ? ".png" : c.original_extension;
      const std::string photo = ShotName(i + 1, ext);
      if (fs::exists(folder / photo)) {
        throw Error((folder / photo).string(), "exists but is not in the manifest (left by an interrupted run?)",
                    "move it away and resume; it is never overwritten");
      }
      if (c.original_bytes.empty()) {
        if (c.image.depth() != CV_8U) throw Error(source.Describe(), "delivered a photo that is not 8-bit", "");
        const cv::Mat img = c.image.isContinuous() ? c.image : c.image.clone();
        WritePng8(folder / photo, img.cols, img.rows, img.channels(), img.data);
      } else {
        WriteFileAtomic(folder / photo, c.original_bytes);
      }
      json entry = {{"index", i + 1},
                    {"photo", photo},
                    {"pattern", png_name},
                    {"pattern_json", json_name},
                    {"pattern_source", shot.pattern_png.string()},
                    {"viewpoint_mm", shot.viewpoint_mm ? json(*shot.viewpoint_mm) : json(nullptr)},
                    {"time_utc", c.metadata.value("capture_time_utc", NowUtcIso8601())},
                    {"source", source.Describe()},
                    {"metadata", c.metadata}};
      manifest["shots"].push_back(entry);
      WriteManifest(folder, manifest);
      ++result.taken;
      if (progress != nullptr) progress->Step(photo);
    } catch (const Error& e) {
      const int kept = static_cast<int>(manifest["shots"].size());
      throw Error(folder.string(), fmt::format("session stopped at shot {}/{}: {}", i + 1, total, e.what()),
                  fmt::format("the {} shot{} taken are in its manifest; fix the cause and rerun with --resume", kept,
                              kept == 1 ? "" : "s"));
    }
  }
  return result;
}

ImportResult ImportFolder(const fs::path& photos_folder, const fs::path& pattern_json, const fs::path& session_folder,
                          const std::string& command, Progress* progress) {
  RequireFolder(photos_folder, "give the folder that holds the photos (--photos)");
  CheckPatternJson(pattern_json, "--pattern");
  if (ClassifyPath(session_folder) == PathKind::kLinkLoop) RequireFolder(session_folder, "");
  const fs::path photos_abs = fs::weakly_canonical(photos_folder);
  const fs::path session_abs = fs::weakly_canonical(session_folder);
  if (photos_abs == session_abs) {
    throw Error(session_folder.string(), "is the photo folder", "write the session to another folder (-o)");
  }
  static const std::set<std::string> kImageExtensions = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp"};
  std::vector<fs::path> files;
  std::vector<fs::path> loops;  // entries named like photos that are symbolic link loops: rejected, with the reason
  for (const fs::directory_entry& e : fs::directory_iterator(photos_folder)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (kImageExtensions.count(ext) == 0) continue;
    const PathKind kind = ClassifyPath(e.path());  // not e.is_regular_file(), which throws on a loop
    if (kind == PathKind::kFile) files.push_back(e.path());
    if (kind == PathKind::kLinkLoop) loops.push_back(e.path());
  }
  std::sort(files.begin(), files.end(), [](const fs::path& a, const fs::path& b) {
    return a.filename().string() < b.filename().string();
  });
  std::sort(loops.begin(), loops.end());
  if (files.empty() && loops.empty()) {
    throw Error(photos_folder.string(), "holds no photos (.png .jpg .jpeg .tif .tiff .bmp)", "check the folder");
  }
  // Decode every photo before writing anything.
  ImportResult result;
  for (const fs::path& f : loops) result.rejected.emplace_back(f.filename().string(), PathProblem(PathKind::kLinkLoop, ""));
  std::vector<std::pair<fs::path, cv::Size>> readable;  // decoded size
  for (const fs::path& f : files) {
    std::string bytes;
    try {
      bytes = ReadFileToString(f);
    } catch (const Error& e) {
      result.rejected.emplace_back(f.filename().string(), e.problem());
      continue;
    }
    cv::Size size;
    try {
      const Image8 img = DecodeImage8(bytes, f.string());  // the header check and size cap of every reader
      size = cv::Size(img.width, img.height);
    } catch (const Error& e) {
      result.rejected.emplace_back(f.filename().string(), "not a readable image: " + e.problem());
      continue;
    }
    readable.emplace_back(f, size);
  }
  if (readable.empty()) {
    // Each photo's reason on the one line (the first three; the count of the rest), so that nothing is hidden.
    std::string reasons;
    for (size_t i = 0; i < result.rejected.size() && i < 3; ++i) {
      reasons += fmt::format("{}{}: {}", i ? ", " : "", result.rejected[i].first, result.rejected[i].second);
    }
    if (result.rejected.size() > 3) reasons += fmt::format(", and {} more", result.rejected.size() - 3);
    throw Error(photos_folder.string(),
                fmt::format("none of its {} photos is readable ({})", files.size() + loops.size(), reasons),
                "replace or remove the damaged files and import again");
  }
  PrepareNewFolder(session_folder, false);
  const fs::path pattern_png = fs::path(pattern_json).replace_extension(".png");
  const auto [png_name, json_name] =
      StorePattern(ClassifyPath(pattern_png) == PathKind::kFile ? pattern_png : fs::path(), pattern_json, session_folder);
  json manifest = {{"format", kSessionFormat},
                   {"command", command},
                   {"source", "import of " + photos_abs.string()},
                   {"shots_planned", readable.size()},
                   {"created_utc", NowUtcIso8601()},
                   {"shots", json::array()},
                   {"rejected", json::array()}};
  for (const auto& [file, reason] : result.rejected) manifest["rejected"].push_back({{"file", file}, {"reason", reason}});
  Progress* p = progress;
  int k = 0;
  for (const auto& [f, img] : readable) {
    ++k;
    std::string ext = f.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    const std::string photo = ShotName(k, ext);
    const std::string bytes = ReadFileToString(f);
    WriteFileAtomic(session_folder / photo, bytes);
    json metadata = {{"width", img.width}, {"height", img.height}, {"exif", ReadExif(bytes)}};
    json entry = {{"index", k},
                  {"photo", photo},
                  {"original", fs::absolute(f).string()},
                  {"pattern", png_name.empty() ? json(nullptr) : json(png_name)},
                  {"pattern_json", json_name},
                  {"pattern_source", fs::absolute(pattern_json).string()},
                  {"viewpoint_mm", nullptr},
                  {"time_utc", FileTimeUtc(f)},
                  {"time_source", "file modification time"},
                  {"source", manifest["source"]},
                  {"metadata", metadata}};
    if (metadata["exif"].contains("date_time_original")) {
      entry["date_time_original"] = metadata["exif"]["date_time_original"];  // camera local time, no zone
    }
    manifest["shots"].push_back(entry);
    WriteManifest(session_folder, manifest);
    if (p != nullptr) p->Step(photo);
  }
  result.imported = k;
  return result;
}

}  // namespace curvecheck
