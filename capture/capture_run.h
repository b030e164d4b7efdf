// What `curvecheck capture camera|gphoto2|session|import` do once their options are parsed
// (app/capture_command.cc): check and write a photo with its metadata, run a planned session with the presenter,
// import a folder of photos. Errors name the option at fault.
#pragma once

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "capture/frame_source.h"

namespace curvecheck {

// -o of a single photo: .png (or, when jpeg_allowed, .jpg/.jpeg) in an existing folder; throws Error otherwise.
void CheckPhotoOutput(const std::filesystem::path& out, bool jpeg_allowed);

// Writes the photo (PNG, or the camera's own JPEG when `out` is .jpg and the camera gave one) and photo.json beside
// it (format curvecheck.photo/1, `command` and the camera's metadata); says so on `log`.
void WritePhoto(const Capture& capture, const std::filesystem::path& out, const std::string& command,
                std::ostream& log);

struct CaptureSessionRequest {
  std::string plan, output;                   // the plan (YAML) and the session folder
  std::vector<std::string> source = {"webcam"};  // webcam | gphoto2 | fake-folder DIR
  OpenCvCameraOptions camera;                 // the webcam's settings
  int display = 0;                            // the output that shows the patterns
  int settle_ms = 50;                         // wait after each pattern is on screen
  bool windowed = false;
  bool resume = false;
};

// Checks every pattern of the plan against its PNG, shows each shot with the presenter (this executable's
// `present`), photographs it and records it in the session folder (session.h RunSession); progress on `log`.
void RunCaptureSession(const CaptureSessionRequest& request, std::ostream& log);

// A session folder from a folder of existing photos (session.h ImportFolder), the pattern's PNG beside
// pattern_json checked against it when present; the rejected photos and the count on `log`.
void ImportCaptureFolder(const std::string& photos, const std::string& pattern_json, const std::string& output,
                         std::ostream& log);

}  // namespace curvecheck
