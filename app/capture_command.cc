#include "app/capture_command.h"

#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "app/cli.h"
#include "capture/capture_run.h"
#include "capture/frame_source.h"

namespace curvecheck::app {
namespace {

void AddCameraOptions(CLI::App* cmd, OpenCvCameraOptions& a) {
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

std::string CommandLine(const std::string& sub) { return "curvecheck capture " + sub; }

}  // namespace

CLI::App* AddCaptureCommand(CLI::App& app, std::function<int()>& run) {
  CLI::App* capture = app.add_subcommand(
      "capture", "Photograph the pattern: webcam (V4L2), DSLR (libgphoto2), planned sessions, or import a folder");
  capture->require_subcommand(1);

  auto cam = std::make_shared<OpenCvCameraOptions>();
  auto cam_out = std::make_shared<std::string>();
  CLI::App* camera = capture->add_subcommand(
      "camera", "Grab one photo from a V4L2/UVC camera through OpenCV; writes photo.png and photo.json (settings)");
  AddCameraOptions(camera, *cam);
  camera->add_option("-o,--output", *cam_out, "Photo file (.png); its metadata goes to the same name .json")
      ->required();
  camera->callback([cam, cam_out, &run] {
    run = [cam, cam_out] {
      CheckPhotoOutput(*cam_out, false);
      OpenCvCameraSource source(*cam);
      WritePhoto(source.Grab(), *cam_out, CommandLine("camera"), std::cout);
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
      WritePhoto(source.Grab(), *gp_out, CommandLine("gphoto2"), std::cout);
      return 0;
    };
  });

  auto ses = std::make_shared<CaptureSessionRequest>();
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
  session->callback([ses, &run] {
    run = [ses] {
      RunCaptureSession(*ses, std::cout);
      return 0;
    };
  });

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
      ImportCaptureFolder(imp->photos, imp->pattern, imp->output, std::cout);
      return 0;
    };
  });
  return capture;
}

}  // namespace curvecheck::app
