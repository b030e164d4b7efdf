// Where photos come from: the seam between capture sessions and cameras.
//
// A FrameSource delivers one photo per Grab() with its metadata. Implementations:
//   OpenCvCameraSource  V4L2/UVC webcams through OpenCV's videoio (CAP_V4L2)
//   Gphoto2Source       DSLR/mirrorless cameras through libgphoto2 (trigger, download, decode)
//   FakeSource          tests: images from files or a generator, with failures on chosen grabs
// Without a camera the constructors throw Error "no camera found: ..." with what to check.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace curvecheck {

// One photo: 8-bit gray or BGR, rows top to bottom, and what is known about how it was taken: at least
// "source" (Describe()), and where the source knows them "camera" (model), "width"/"height", "exposure",
// "frames_averaged", "capture_time_utc" (ISO-8601), "exif" {...}.
struct Capture {
  cv::Mat image;
  nlohmann::json metadata = nlohmann::json::object();
  // The camera's own encoded file (a DSLR's JPEG), kept so that its EXIF survives; empty when there is none.
  std::string original_bytes;
  std::string original_extension;  // ".jpg", ".png", ... of original_bytes
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // Takes one photo. Throws Error (naming the source) if the camera fails or disappears.
  virtual Capture Grab() = 0;
  // One line naming the source and its settings ("V4L2 /dev/video0 1920x1080, exposure auto").
  virtual std::string Describe() const = 0;
};

// Mean of same-size 8-bit frames, accumulated in float and rounded to 8 bit (noise std drops by sqrt(N) for
// independent noise). Throws Error if the list is empty or the frames differ in size or type.
cv::Mat AverageFrames(const std::vector<cv::Mat>& frames);

// Grabs `frames` (>= 1) photos from `source` and averages them; the metadata is the first grab's with
// "frames_averaged" set.
Capture GrabAveraged(FrameSource& source, int frames);

// Decodes an encoded photo (PNG, JPEG, TIFF or BMP) to 8-bit BGR through core's DecodeImage8, so that the
// header check and its size cap (kMaxImagePixels) apply to every photo a camera or a folder delivers. Throws
// Error naming `source` if the bytes are not such an image, are damaged or declare too many pixels.
cv::Mat DecodePhotoBgr(std::string_view bytes, const std::string& source);

// Current time as ISO-8601 UTC with milliseconds: "2024-05-01T12:34:56.789Z".
std::string NowUtcIso8601();

struct OpenCvCameraOptions {
  std::string device = "/dev/video0";  // "/dev/videoN" or an index "N"
  std::optional<int> width, height;    // requested resolution (px); checked against what the device delivers
  std::optional<double> exposure;      // manual exposure in the driver's units (V4L2: 100 us); unset: auto
  int frames = 1;                      // frames averaged per photo (>= 1)
  int warmup_frames = 5;               // frames read and dropped after opening (auto exposure settles)

  void Check(const std::string& where) const;
};

class OpenCvCameraSource : public FrameSource {
 public:
  // Opens the device. Throws Error "no camera found: ..." if it does not exist or cannot be opened, and Error
  // if the requested resolution is not what the device delivers.
  explicit OpenCvCameraSource(const OpenCvCameraOptions& options);
  ~OpenCvCameraSource() override;
  Capture Grab() override;
  std::string Describe() const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class Gphoto2Source : public FrameSource {
 public:
  // Connects to the first camera libgphoto2 detects. Throws Error "no camera found: ..." if there is none.
  Gphoto2Source();
  ~Gphoto2Source() override;
  Capture Grab() override;
  std::string Describe() const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// For tests. Serves images in order (cycling) from files or a generator; grab number k (1-based) can be made
// to throw Error with a given message.
class FakeSource : public FrameSource {
 public:
  explicit FakeSource(std::vector<std::filesystem::path> files);
  explicit FakeSource(std::function<cv::Mat(int grab)> generator);
  void FailAt(int grab, std::string message) { failures_[grab] = std::move(message); }
  int grabs() const { return grabs_; }
  Capture Grab() override;
  std::string Describe() const override;

 private:
  std::vector<std::filesystem::path> files_;
  std::function<cv::Mat(int)> generator_;
  std::map<int, std::string> failures_;
  int grabs_ = 0;
};

}  // namespace curvecheck
