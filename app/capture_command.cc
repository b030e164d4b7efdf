#include "app/capture_command.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "app/cli.h"
#include "capture/frame_source.h"
#include "capture/presenter_display.h"
#include "capture/session.h"
#include "core/error.h"
#include "core/path_check.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/progress.h"
#include "pattern/pattern_json.h"

namespace curvecheck::app {
namespace {
namespace fs = std::filesystem;

struct CameraArgs {
  std::string device = "/dev/video0";
  std::optional<int> width, height;
  std::optional<double> exposure;
  int frames = 1;

  OpenCvCameraOptions Options() const {
    OpenCvCameraOptions o;
    o.device = device;
    o.width = width;
    o.height = height;
    o.exposure = exposure;
    o.frames = frames;
    return o;
  }
};

void AddCameraOptions(CLI::App* cmd, CameraArgs& a) {
  cmd->add_option("--device", a.device, "V4L2 device: /dev/videoN or an index N")->capture_default_str();
  cmd->add_option("--width", a.width, "Requested width (px); the device must deliver exactly this")
      ->check(InRange(1, 65535, "px", "a frame size a V4L2 device can deliver"));
  cmd->add_option("--height", a.height, "Requested height (px)")
      ->check(InRange(1, 65535, "px", "a frame size a V4L2 device can deliver"));
  cmd->add_option("--exposure", a.exposure,
                  "Manual exposure in the driver's units (V4L2: 100 us); without it: auto exposure");
  cmd->add_option("--frames", a.frames, "Frames averaged per photo (noise falls as 1/sqrt(N))")
      ->capture_default_str()
      ->check(InRange(1, 1000, "", "at least one frame; 1000 frames average the noise down by 30x"));
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string CommandLine(const std::string& sub) { return "curvecheck capture " + sub; }

// Writes the photo (PNG, or the camera's own JPEG when -o is .jpg and the camera gave one) and photo.json.
void WritePhoto(const Capture& c, const fs::path& out, const std::string& command) {
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
  std::cout << "written " << out.string() << " (" << c.image.cols << "x" << c.image.rows << ") and "
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

struct SessionArgs {
  std::string plan, output;
  std::vector<std::string> source = {"webcam"};
  CameraArgs camera;
  int display = 0;
  int settle_ms = 50;
  bool windowed = false;
  bool resume = false;
};

int RunSessionCommand(const SessionArgs& a) {
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
    source = std::make_unique<OpenCvCameraSource>(a.camera.Options());
  } else if (kind == "gphoto2") {
    source = std::make_unique<Gphoto2Source>();
  } else {
    source = std::make_unique<FakeSource>(ImagesIn(a.source[1]));
  }
  const fs::path self = fs::read_symlink("/proc/self/exe");
  PresenterProcess presenter(self, plan, a.display, a.windowed, a.settle_ms);
  Progress progress("capture", static_cast<int>(plan.shots.size()), std::cout);
  const SessionResult r = RunSession(
      plan, *source, [&](size_t i, const PlannedShot& s) { presenter.Show(i, s); },
      {a.output, a.resume, CommandLine("session")}, &progress);
  std::cout << fmt::format("session: {} shots taken{}, {} of {} in {}\n", r.taken,
                           r.resumed_after > 0 ? fmt::format(" after {} resumed", r.resumed_after) : "",
                           r.resumed_after + r.taken, r.total, (fs::path(a.output) / kManifestName).string());
  return 0;
}

}  // namespace

CLI::App* AddCaptureCommand(CLI::App& app, std::function<int()>& run) {
  CLI::App* capture = app.add_subcommand(
      "capture", "Photograph the pattern: webcam (V4L2), DSLR (libgphoto2), planned sessions, or import a folder");
  capture->require_subcommand(1);

  auto cam = std::make_shared<CameraArgs>();
  auto cam_out = std::make_shared<std::string>();
  CLI::App* camera = capture->add_subcommand(
      "camera", "Grab one photo from a V4L2/UVC camera through OpenCV; writes photo.png and photo.json (settings)");
  AddCameraOptions(camera, *cam);
  camera->add_option("-o,--output", *cam_out, "Photo file (.png); its metadata goes to the same name .json")
      ->required();
  camera->callback([cam, cam_out, &run] {
    run = [cam, cam_out] {
      CheckPhotoOutput(*cam_out, false);
      OpenCvCameraSource source(cam->Options());
      WritePhoto(source.Grab(), *cam_out, CommandLine("camera"));
      return 0;
    };
  });

  auto gp_out = std::make_shared<std::string>();
  CLI::App* gphoto2 = capture->add_subcommand(
      "gphoto2", "Trigger a DSLR/mirrorless camera through libgphoto2 and download the photo (.jpg kept as the "
                 "camera wrote it, or .png); metadata with EXIF to the same name .json");
  gphoto2->add_option("-o,--output", *gp_out, "Photo file (.jpg or .png)")->required();
  gphoto2->callback([gp_out, &run] {
    run = [gp_out] {
      CheckPhotoOutput(*gp_out, true);
      Gphoto2Source source;
      WritePhoto(source.Grab(), *gp_out, CommandLine("gphoto2"));
      return 0;
    };
  });

  auto ses = std::make_shared<SessionArgs>();
  CLI::App* session = capture->add_subcommand(
      "session", "Run a planned list of shots: show each pattern fullscreen (curvecheck present), wait for the panel "
                 "to settle, photograph, and store photo + pattern + metadata in one folder with manifest.json");
  session->add_option("--plan", ses->plan, "Plan (YAML): shots: [{pattern: p.png, viewpoint_mm: [x,y,z], repeat: N}]")
      ->required()
      ->check(CLI::ExistingFile);
  session->add_option("--source", ses->source, "webcam | gphoto2 | fake-folder DIR (photos from a folder, tests)")
      ->expected(1, 2)
      ->capture_default_str();
  AddCameraOptions(session, ses->camera);
  session->add_option("--display", ses->display, "Output (monitor) that shows the patterns, as GLFW lists them")
      ->capture_default_str()
      ->check(InRange(0, 255, "", "an output number: 0 is the primary"));
  session->add_option("--settle-ms", ses->settle_ms, "Wait after each pattern is on screen before the photo (>= 50)")
      ->capture_default_str()
      ->check(CLI::Range(50, 600000));
  session->add_flag("--windowed", ses->windowed, "Show patterns in an undecorated window (tests, Xvfb)");
  session->add_option("-o,--output", ses->output, "Session folder (new or empty; with --resume: an existing session)")
      ->required();
  session->add_flag("--resume", ses->resume, "Continue after the last shot in the folder's manifest");
  session->callback([ses, &run] { run = [ses] { return RunSessionCommand(*ses); }; });

  struct ImportArgs {
    std::string photos, pattern, output;
  };
  auto imp = std::make_shared<ImportArgs>();
  CLI::App* import = capture->add_subcommand(
      "import", "Build a session folder from existing photos (copied, never moved) with the same manifest");
  import->add_option("--photos", imp->photos, "Folder of photos (.png .jpg .tif .bmp), taken in name order")
      ->required();
  import->add_option("--pattern", imp->pattern, "The pattern.json of the pattern shown in the photos")->required();
  import->add_option("-o,--output", imp->output, "Session folder (new or empty)")->required();
  import->callback([imp, &run] {
    run = [imp] {
      const PatternFile pattern = ReadPatternJson(imp->pattern);
      // The PNG beside it, if any, is stored with the session as the pattern shown: it must be the one.
      const fs::path png = fs::path(imp->pattern).replace_extension(".png");
      if (ClassifyPath(png) == PathKind::kFile) CheckPatternBelongsToImage(pattern, imp->pattern, png, ReadImage8(png));
      Progress progress("import", 0, std::cout, false);
      const ImportResult r = ImportFolder(imp->photos, imp->pattern, imp->output, CommandLine("import"), &progress);
      for (const auto& [file, reason] : r.rejected) std::cout << "rejected " << file << ": " << reason << "\n";
      std::cout << fmt::format("import: {} photos imported, {} rejected, in {}\n", r.imported, r.rejected.size(),
                               (fs::path(imp->output) / kManifestName).string());
      return 0;
    };
  });
  return capture;
}

}  // namespace curvecheck::app
