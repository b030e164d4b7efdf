#include "capture/frame_source.h"

#include <fmt/format.h>

#include <chrono>
#include <ctime>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"

namespace curvecheck {
namespace fs = std::filesystem;

cv::Mat AverageFrames(const std::vector<cv::Mat>& frames) {
  if (frames.empty()) throw Error("frame averaging", "no frames to average", "grab at least one frame");
  const cv::Mat& first = frames.front();
  if (first.depth() != CV_8U) throw Error("frame averaging", "frames must be 8-bit", "");
  cv::Mat sum = cv::Mat::zeros(first.size(), CV_32FC(first.channels()));
  for (const cv::Mat& f : frames) {
    if (f.size() != first.size() || f.type() != first.type()) {
      throw Error("frame averaging",
                  fmt::format("frames differ in size or type ({}x{} vs {}x{})", f.cols, f.rows, first.cols, first.rows),
                  "the camera changed its mode while grabbing; grab again");
    }
    cv::accumulate(f, sum);
  }
  cv::Mat out;
  sum.convertTo(out, first.type(), 1.0 / static_cast<double>(frames.size()));  // rounds and saturates
  return out;
}

Capture GrabAveraged(FrameSource& source, int frames) {
  if (frames < 1) throw Error("--frames", fmt::format("is {}, must be at least 1", frames), "");
  Capture first = source.Grab();
  if (frames == 1) {
    first.metadata["frames_averaged"] = 1;
    return first;
  }
  std::vector<cv::Mat> all{first.image};
  for (int i = 1; i < frames; ++i) all.push_back(source.Grab().image);
  first.image = AverageFrames(all);
  first.metadata["frames_averaged"] = frames;
  first.original_bytes.clear();  // the average is not the camera's file any more
  first.original_extension.clear();
  return first;
}

std::string NowUtcIso8601() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  return fmt::format("{}.{:03d}Z", buf, static_cast<int>(ms));
}

// ---- OpenCV / V4L2 ----

void OpenCvCameraOptions::Check(const std::string& where) const {
  if (frames < 1) throw Error(where + " --frames", fmt::format("is {}, must be at least 1", frames), "");
  if (width.has_value() != height.has_value()) {
    throw Error(where + " --width/--height", "only one of them is given", "give both or neither");
  }
  if (width && (*width < 1 || *height < 1)) {
    throw Error(where + " --width/--height", fmt::format("{}x{} is not a size", *width, *height),
                "give positive pixel counts");
  }
  if (device.empty()) throw Error(where + " --device", "is empty", "give /dev/videoN or an index N");
}

struct OpenCvCameraSource::Impl {
  OpenCvCameraOptions options;
  std::string path;
  cv::VideoCapture cap;
  nlohmann::json settings = nlohmann::json::object();
};

OpenCvCameraSource::OpenCvCameraSource(const OpenCvCameraOptions& options) : impl_(std::make_unique<Impl>()) {
  options.Check("capture camera");
  impl_->options = options;
  const bool is_index = options.device.find_first_not_of("0123456789") == std::string::npos;
  impl_->path = is_index ? "/dev/video" + options.device : options.device;
  const std::string no_camera =
      fmt::format("no camera found: {} does not exist or cannot be opened", impl_->path);
  const std::string fix = "check the device (v4l2-ctl --list-devices) or use --device";
  // Checked before OpenCV sees it: OpenCV would only log a warning.
  if (!fs::exists(impl_->path)) throw Error("", no_camera, fix);
  const auto previous = cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  const bool opened = impl_->cap.open(impl_->path, cv::CAP_V4L2) && impl_->cap.isOpened();
  cv::utils::logging::setLogLevel(previous);
  if (!opened) throw Error("", no_camera, fix);

  cv::VideoCapture& cap = impl_->cap;
  if (options.width) {
    cap.set(cv::CAP_PROP_FRAME_WIDTH, *options.width);
    cap.set(cv::CAP_PROP_FRAME_HEIGHT, *options.height);
  }
  // V4L2 through OpenCV: CAP_PROP_AUTO_EXPOSURE 1 = manual, 3 = aperture priority (auto).
  if (options.exposure) {
    const bool manual = cap.set(cv::CAP_PROP_AUTO_EXPOSURE, 1);
    const bool set = cap.set(cv::CAP_PROP_EXPOSURE, *options.exposure);
    impl_->settings["exposure_requested"] = *options.exposure;
    impl_->settings["exposure_supported"] = manual && set;
  } else {
    cap.set(cv::CAP_PROP_AUTO_EXPOSURE, 3);
  }
  cv::Mat frame;
  for (int i = 0; i <= options.warmup_frames; ++i) {
    if (!cap.read(frame) || frame.empty()) {
      throw Error(impl_->path, "opened but delivers no frames", "check that no other program uses the camera");
    }
  }
  if (options.width && (frame.cols != *options.width || frame.rows != *options.height)) {
    throw Error(impl_->path,
                fmt::format("requested {}x{} but the device delivers {}x{}", *options.width, *options.height,
                            frame.cols, frame.rows),
                "choose a resolution the camera supports (v4l2-ctl --list-formats-ext)");
  }
  impl_->settings["width"] = frame.cols;
  impl_->settings["height"] = frame.rows;
  impl_->settings["auto_exposure"] = cap.get(cv::CAP_PROP_AUTO_EXPOSURE);
  impl_->settings["exposure"] = cap.get(cv::CAP_PROP_EXPOSURE);
  impl_->settings["backend"] = cap.getBackendName();
}

OpenCvCameraSource::~OpenCvCameraSource() = default;

Capture OpenCvCameraSource::Grab() {
  std::vector<cv::Mat> frames;
  const std::string time = NowUtcIso8601();
  for (int i = 0; i < impl_->options.frames; ++i) {
    cv::Mat f;
    if (!impl_->cap.read(f) || f.empty()) {
      throw Error(impl_->path, "stopped delivering frames", "check the cable and that no other program uses it");
    }
    frames.push_back(f.clone());
  }
  Capture c;
  c.image = AverageFrames(frames);
  c.metadata = impl_->settings;
  c.metadata["source"] = Describe();
  c.metadata["capture_time_utc"] = time;
  c.metadata["frames_averaged"] = impl_->options.frames;
  return c;
}

std::string OpenCvCameraSource::Describe() const {
  const auto& s = impl_->settings;
  return fmt::format("V4L2 {} {}x{}, exposure {}", impl_->path, s.value("width", 0), s.value("height", 0),
                     impl_->options.exposure ? fmt::format("{}", *impl_->options.exposure) : std::string("auto"));
}

cv::Mat DecodePhotoBgr(std::string_view bytes, const std::string& source) {
  Image8 img = DecodeImage8(bytes, source);
  const cv::Mat wrapped(img.height, img.width, CV_8UC(img.channels), img.pixels.data());
  cv::Mat bgr;
  if (img.channels == 1) {
    cv::cvtColor(wrapped, bgr, cv::COLOR_GRAY2BGR);
  } else if (img.channels == 4) {
    cv::cvtColor(wrapped, bgr, cv::COLOR_BGRA2BGR);
  } else if (img.channels == 3) {
    bgr = wrapped.clone();  // `img` owns the pixels and dies here
  } else {
    throw Error(source, fmt::format("has {} channels", img.channels), "give a gray or colour photo");
  }
  return bgr;
}

// ---- Fake ----

FakeSource::FakeSource(std::vector<fs::path> files) : files_(std::move(files)) {
  if (files_.empty()) throw Error("fake source", "no image files", "give at least one image");
}

FakeSource::FakeSource(std::function<cv::Mat(int)> generator) : generator_(std::move(generator)) {}

Capture FakeSource::Grab() {
  ++grabs_;
  if (auto it = failures_.find(grabs_); it != failures_.end()) throw Error("fake source", it->second, "");
  Capture c;
  if (generator_) {
    c.image = generator_(grabs_);
  } else {
    const fs::path& f = files_[static_cast<size_t>(grabs_ - 1) % files_.size()];
    c.image = DecodePhotoBgr(ReadFileToString(f), f.string());
    c.metadata["file"] = f.string();
  }
  c.metadata["source"] = Describe();
  c.metadata["capture_time_utc"] = NowUtcIso8601();
  c.metadata["grab"] = grabs_;
  return c;
}

std::string FakeSource::Describe() const {
  return generator_ ? std::string("fake (generated frames)")
                    : fmt::format("fake ({} files from {})", files_.size(), files_.front().parent_path().string());
}

}  // namespace curvecheck
