// What `curvecheck capture camera|gphoto2|session|import` do once their options are parsed (capture_run.h).
#include "capture/capture_run.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <memory>
#include <nlohmann/json.hpp>
#include <ostream>
#include <set>

#include "capture/presenter_display.h"
#include "capture/session.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/path_check.h"
#include "core/progress.h"
#include "pattern/pattern_json.h"

namespace curvecheck {
namespace {
namespace fs = std::filesystem;

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

// The images of a fake-folder source, in name order.
std::vector<fs::path> ImagesIn(const fs::path& dir) {
  if (ClassifyPath(dir) == PathKind::kLinkLoop) RequireFolder(dir, "");
  if (!fs::is_directory(dir)) throw Error("--source fake-folder", fmt::format("'{}' is not a folder", dir.string()), "");
  static const std::set<std::string> kExt = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp"};
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (ClassifyPath(e.path()) == PathKind::kFile && kExt.count(Lower(e.path().extension().string())) != 0) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  if (files.empty()) throw Error("--source fake-folder", fmt::format("'{}' holds no images", dir.string()), "");
  return files;
}

}  // namespace

void WritePhoto(const Capture& c, const fs::path& out, const std::string& command, std::ostream& log) {
  const std::string ext = Lower(out.extension().string());
  if (ext == ".png") {
    const cv::Mat img = c.image.isContinuous() ? c.image : c.image.clone();
    WritePng8(out, img.cols, img.rows, img.channels(), img.data);
  } else if (ext == ".jpg" || ext == ".jpeg") {
    if (c.original_bytes.empty() || (c.original_extension != ".jpg" && c.original_extension != ".jpeg")) {
      throw Error("-o", fmt::format("'{}': this camera gave no JPEG file", out.string()), "write a .png");
    }
    WriteFileAtomic(out, c.original_bytes);
  }
  nlohmann::json meta = {{"format", "curvecheck.photo/1"}, {"command", command}, {"photo", out.filename().string()}};
  meta["metadata"] = c.metadata;
  WriteFileAtomic(fs::path(out).replace_extension(".json"), meta.dump(2) + "\n");
  log << "written " << out.string() << " (" << c.image.cols << "x" << c.image.rows << ") and "
      << fs::path(out).replace_extension(".json").string() << "\n";
}

void CheckPhotoOutput(const fs::path& out, bool jpeg_allowed) {
  const std::string ext = Lower(out.extension().string());
  if (ext != ".png" && !(jpeg_allowed && (ext == ".jpg" || ext == ".jpeg"))) {
    throw Error("-o", fmt::format("'{}' does not end in {}", out.string(), jpeg_allowed ? ".png or .jpg" : ".png"),
                "name the photo file accordingly");
  }
  const fs::path folder = out.parent_path().empty() ? fs::path(".") : out.parent_path();
  if (!fs::is_directory(folder)) {
    throw Error("-o", fmt::format("folder '{}' does not exist", folder.string()), "create it first");
  }
}

void RunCaptureSession(const CaptureSessionRequest& a, std::ostream& log) {
  const std::string kind = a.source.at(0);
  if ((kind == "fake-folder") != (a.source.size() == 2) ||
      (kind != "webcam" && kind != "gphoto2" && kind != "fake-folder")) {
    throw Error("--source", fmt::format("'{}' is not a source", fmt::join(a.source, " ")),
                "give webcam, gphoto2 or fake-folder DIR");
  }
  const SessionPlan plan = LoadSessionPlan(a.plan);
  std::set<fs::path> checked;
  for (const PlannedShot& s : plan.shots) {
    if (!checked.insert(s.pattern_json).second) continue;
    const PatternFile pattern = ReadPatternJson(s.pattern_json);  // full validation
    CheckPatternBelongsToImage(pattern, s.pattern_json, s.pattern_png, ReadImage8(s.pattern_png));
  }
  std::unique_ptr<FrameSource> source;
  if (kind == "webcam") {
    source = std::make_unique<OpenCvCameraSource>(a.camera);
  } else if (kind == "gphoto2") {
    source = std::make_unique<Gphoto2Source>();
  } else {
    source = std::make_unique<FakeSource>(ImagesIn(a.source[1]));
  }
  const fs::path self = fs::read_symlink("/proc/self/exe");
  PresenterProcess presenter(self, plan, a.display, a.windowed, a.settle_ms);
  Progress progress("capture", static_cast<int>(plan.shots.size()), log);
  const SessionResult r = RunSession(
      plan, *source, [&](size_t i, const PlannedShot& s) { presenter.Show(i, s); },
      {a.output, a.resume, "curvecheck capture session"}, &progress);
  log << fmt::format("session: {} shots taken{}, {} of {} in {}\n", r.taken,
                     r.resumed_after > 0 ? fmt::format(" after {} resumed", r.resumed_after) : "",
                     r.resumed_after + r.taken, r.total, (fs::path(a.output) / kManifestName).string());
}

void ImportCaptureFolder(const std::string& photos, const std::string& pattern_json, const std::string& output,
                         std::ostream& log) {
  const PatternFile pattern = ReadPatternJson(pattern_json);
  // The PNG beside it, if any, is stored with the session as the pattern shown: it must be the one.
  const fs::path png = fs::path(pattern_json).replace_extension(".png");
  if (ClassifyPath(png) == PathKind::kFile) CheckPatternBelongsToImage(pattern, pattern_json, png, ReadImage8(png));
  Progress progress("import", 0, log, false);
  const ImportResult r = ImportFolder(photos, pattern_json, output, "curvecheck capture import", &progress);
  for (const auto& [file, reason] : r.rejected) log << "rejected " << file << ": " << reason << "\n";
  log << fmt::format("import: {} photos imported, {} rejected, in {}\n", r.imported, r.rejected.size(),
                     (fs::path(output) / kManifestName).string());
}

}  // namespace curvecheck
