// Gphoto2Source: libgphoto2 stays inside this file.
#include <fmt/format.h>
#include <gphoto2/gphoto2-camera.h>
#include <gphoto2/gphoto2-context.h>
#include <gphoto2/gphoto2-list.h>
#include <gphoto2/gphoto2-result.h>

#include <opencv2/imgcodecs.hpp>

#include "capture/exif.h"
#include "capture/frame_source.h"
#include "core/error.h"

namespace curvecheck {
namespace {

constexpr const char* kNoCameraFix = "connect and switch it on, or check `gphoto2 --auto-detect`";

void Check(int result, const std::string& call) {
  if (result < GP_OK) {
    throw Error("libgphoto2", fmt::format("{} failed: {} ({})", call, gp_result_as_string(result), result),
                "check the camera connection and that no other program (gvfs, a file manager) holds it");
  }
}

}  // namespace

struct Gphoto2Source::Impl {
  GPContext* context = nullptr;
  Camera* camera = nullptr;
  std::string model, port;
  ~Impl() {
    if (camera != nullptr) {
      gp_camera_exit(camera, context);
      gp_camera_unref(camera);
    }
    if (context != nullptr) gp_context_unref(context);
  }
};

Gphoto2Source::Gphoto2Source() : impl_(std::make_unique<Impl>()) {
  impl_->context = gp_context_new();
  if (impl_->context == nullptr) throw Error("libgphoto2", "gp_context_new failed", "");
  CameraList* list = nullptr;
  Check(gp_list_new(&list), "gp_list_new");
  const int count = gp_camera_autodetect(list, impl_->context);
  if (count > 0) {
    const char* name = nullptr;
    const char* port = nullptr;
    gp_list_get_name(list, 0, &name);
    gp_list_get_value(list, 0, &port);
    impl_->model = name != nullptr ? name : "";
    impl_->port = port != nullptr ? port : "";
  }
  gp_list_free(list);
  if (count < GP_OK) {
    throw Error("", fmt::format("no camera found: libgphoto2 camera detection failed: {}", gp_result_as_string(count)),
                kNoCameraFix);
  }
  if (count == 0) throw Error("", "no camera found: libgphoto2 detected no camera", kNoCameraFix);
  Check(gp_camera_new(&impl_->camera), "gp_camera_new");
  const int init = gp_camera_init(impl_->camera, impl_->context);
  if (init == GP_ERROR_MODEL_NOT_FOUND || init == GP_ERROR_IO_USB_FIND) {
    throw Error("", fmt::format("no camera found: libgphoto2 could not open {}: {}", impl_->model,
                                gp_result_as_string(init)),
                kNoCameraFix);
  }
  Check(init, "gp_camera_init");
}

Gphoto2Source::~Gphoto2Source() = default;

Capture Gphoto2Source::Grab() {
  const std::string time = NowUtcIso8601();
  CameraFilePath path{};
  Check(gp_camera_capture(impl_->camera, GP_CAPTURE_IMAGE, &path, impl_->context), "gp_camera_capture");
  CameraFile* file = nullptr;
  Check(gp_file_new(&file), "gp_file_new");
  std::string bytes;
  const int got = gp_camera_file_get(impl_->camera, path.folder, path.name, GP_FILE_TYPE_NORMAL, file, impl_->context);
  if (got >= GP_OK) {
    const char* data = nullptr;
    unsigned long size = 0;
    if (gp_file_get_data_and_size(file, &data, &size) >= GP_OK && data != nullptr) bytes.assign(data, size);
  }
  gp_file_unref(file);
  Check(got, fmt::format("gp_camera_file_get {}/{}", path.folder, path.name));
  Capture c;
  try {
    c.image = DecodePhotoBgr(bytes, fmt::format("camera file {}", path.name));
  } catch (const Error& e) {
    throw Error(fmt::format("camera file {}", path.name), e.problem() + " (a RAW file?)",
                "set the camera to JPEG (or RAW+JPEG with JPEG delivered)");
  }
  const std::string name = path.name;
  const size_t dot = name.rfind('.');
  c.original_extension = dot == std::string::npos ? ".jpg" : name.substr(dot);
  for (char& ch : c.original_extension) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  c.original_bytes = std::move(bytes);
  c.metadata["source"] = Describe();
  c.metadata["camera"] = impl_->model;
  c.metadata["capture_time_utc"] = time;
  c.metadata["camera_file"] = fmt::format("{}/{}", path.folder, path.name);
  c.metadata["width"] = c.image.cols;
  c.metadata["height"] = c.image.rows;
  c.metadata["exif"] = ReadExif(c.original_bytes);
  return c;
}

std::string Gphoto2Source::Describe() const { return fmt::format("gphoto2 {} on {}", impl_->model, impl_->port); }

}  // namespace curvecheck
