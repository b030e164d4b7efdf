#include "core/camera_model.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

#include "core/error.h"
#include "core/file_io.h"

extern "C" {
#include <mrcal/mrcal.h>  // mrcal 2.2's header has no extern "C" of its own
}

namespace curvecheck {
namespace {

struct FreeModel {
  void operator()(mrcal_cameramodel_t* m) const { mrcal_free_cameramodel(&m); }
};
using ModelPtr = std::unique_ptr<mrcal_cameramodel_t, FreeModel>;

mrcal_lensmodel_t LensModel(const std::string& name, const std::string& where) {
  mrcal_lensmodel_t lens;
  if (!mrcal_lensmodel_from_name(&lens, name.c_str())) {
    throw Error(where, fmt::format("'{}' is not a mrcal lens model", name),
                "use e.g. LENSMODEL_OPENCV8 or LENSMODEL_PINHOLE (see mrcal-show-distortion-off-pinhole --help)");
  }
  return lens;
}

CameraModel FromMrcal(const mrcal_cameramodel_t& m, const std::string& source) {
  CameraModel out;
  char name[1024];
  if (!mrcal_lensmodel_name(name, sizeof(name), &m.lensmodel)) {
    throw Error(source, "the lens model's name does not fit in 1024 characters", "check the file");
  }
  out.lensmodel = name;
  const int n = mrcal_lensmodel_num_params(&m.lensmodel);
  out.intrinsics.assign(m.intrinsics, m.intrinsics + n);
  out.width = static_cast<int>(m.imagersize[0]);
  out.height = static_cast<int>(m.imagersize[1]);
  for (int i = 0; i < 6; ++i) out.rt_cam_ref[i] = m.rt_cam_ref[i];
  out.Check(source);
  return out;
}

}  // namespace

bool IsMrcalLensModel(const std::string& name) {
  mrcal_lensmodel_t lens;
  return mrcal_lensmodel_from_name(&lens, name.c_str());
}

int LensModelParameterCount(const std::string& name) {
  const mrcal_lensmodel_t lens = LensModel(name, "lens model");
  return mrcal_lensmodel_num_params(&lens);
}

namespace {
constexpr double kMaxDistortionParameter = 1e4;
}  // namespace

void CameraModel::Check(const std::string& where) const {
  const mrcal_lensmodel_t lens = LensModel(lensmodel, where);
  const int n = mrcal_lensmodel_num_params(&lens);
  if (static_cast<int>(intrinsics.size()) != n) {
    throw Error(where, fmt::format("{} takes {} intrinsics, got {}", lensmodel, n, intrinsics.size()),
                "give fx, fy, cx, cy and the model's distortion parameters");
  }
  // libmrcal 2.2 asserts (aborts the process) on a splined model whose spline it cannot evaluate: an order other
  // than 2 or 3, or fewer than order + 1 knots along an axis (fuzz/fuzz_cameramodel:
  // LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=4_Ny=3 aborted in mrcal_project; order=2 Nx=Ny=3 and order=3
  // Nx=Ny=4 project). Refused here instead. A field of view of 0 deg puts every knot at one point: mrcal then
  // projects every point to NaN (checked with mrcal.project, fov_x_deg=0; the field is an unsigned integer).
  if (lens.type == MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC) {
    const auto& c = lens.LENSMODEL_SPLINED_STEREOGRAPHIC__config;
    if ((c.order != 2 && c.order != 3) || c.Nx < c.order + 1 || c.Ny < c.order + 1) {
      throw Error(where,
                  fmt::format("{}: a splined model of order {} with {} x {} knots cannot be evaluated (order 2 or 3, "
                              "at least order + 1 knots per axis)",
                              lensmodel, c.order, c.Nx, c.Ny),
                  "check the model's name");
    }
    if (c.fov_x_deg <= 0) {
      throw Error(where,
                  fmt::format("{}: a splined model's field of view fov_x_deg is {}, not positive: it cannot project",
                              lensmodel, c.fov_x_deg),
                  "check the model's name (the spline's horizontal field of view, deg)");
    }
  }
  for (double v : intrinsics) {
    if (!std::isfinite(v)) throw Error(where, "an intrinsic is not finite", "check the model");
  }
  if (!(intrinsics[0] > 0 && intrinsics[1] > 0)) {
    throw Error(where, "focal lengths must be positive", "check fx, fy");
  }
  // Distortion parameters of real lenses are of order 1 (OpenCV's rational terms reach tens). Far beyond that,
  // libmrcal's iterative unprojection runs for minutes without converging (fuzz/fuzz_cameramodel: k2 = 1e34 held
  // mrcal_unproject for over 2 minutes), so such a model is refused here, before anything projects with it.
  for (size_t i = 4; i < intrinsics.size(); ++i) {
    if (std::abs(intrinsics[i]) > kMaxDistortionParameter) {
      throw Error(where, fmt::format("distortion parameter {} is {:g}, beyond +-{:g}", i - 4, intrinsics[i],
                                     kMaxDistortionParameter),
                  "check the model: a real lens has distortion parameters of order 1");
    }
  }
  if (width < 1 || height < 1) {
    throw Error(where, fmt::format("imager size {}x{} is not positive", width, height), "give the image size in px");
  }
}

namespace {

// libmrcal 2.2's parser (re2c, sentinel 0) scans an unterminated '#' comment for its '\n' and an unterminated
// quoted string for its closing quote past the end of the buffer, until it faults (found by
// fuzz/fuzz_cameramodel: "{ 'a" and "# x" crash with SEGV inside mrcal_read_cameramodel_string). So mrcal only
// gets text in which both scans end inside it: the text plus a '\n' (which ends a last comment, and which mrcal
// accepts after the closing brace), after checking, with the same left-to-right reading as mrcal's (a comment runs
// from '#' outside a string to the end of the line; a string from ' or " to the next ' or "), that every string
// closes. Returns the problem, or "" if the text is safe to hand to mrcal.
std::string UnsafeForMrcal(const std::string& text) {
  constexpr size_t kMaxBytes = 64 << 20;  // a splined model with thousands of parameters is ~100 kB
  if (text.size() > kMaxBytes) return fmt::format("is {} bytes, too large for a camera model", text.size());
  if (text.find('\0') != std::string::npos) return "contains a NUL byte, so it is not a text file";
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '#') {
      i = text.find('\n', i);
      if (i == std::string::npos) break;  // ended by the '\n' we append
    } else if (text[i] == '\'' || text[i] == '"') {
      const size_t close = text.find_first_of("'\"", i + 1);
      if (close == std::string::npos) return fmt::format("has a quoted string at byte {} that never closes", i);
      i = close;
    }
  }
  return "";
}

// Calls f() with file descriptor 2 sent to a temporary file and returns what was written there, on one line.
// mrcal's parser prints its diagnostics on stderr; they go into the error message instead, so that a bad model
// gives the one line every command promises. Not for use while other threads print.
template <typename F>
std::string CaptureStderr(F&& f) {
  std::fflush(stderr);
  std::FILE* tmp = std::tmpfile();
  const int saved = tmp ? ::dup(2) : -1;
  if (saved < 0 || ::dup2(::fileno(tmp), 2) < 0) {
    if (saved >= 0) ::close(saved);
    if (tmp) std::fclose(tmp);
    f();
    return "";
  }
  f();
  std::fflush(stderr);
  ::dup2(saved, 2);
  ::close(saved);
  std::string text;
  std::rewind(tmp);
  char buf[512];
  for (size_t n; (n = std::fread(buf, 1, sizeof buf, tmp)) > 0 && text.size() < 4096;) text.append(buf, n);
  std::fclose(tmp);
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  std::replace(text.begin(), text.end(), '\n', ' ');
  return text;
}

}  // namespace

CameraModel ParseCameraModel(const std::string& text, const std::string& source) {
  if (const std::string problem = UnsafeForMrcal(text); !problem.empty()) {
    throw Error(source, problem + " (truncated or not a mrcal .cameramodel)",
                "check it with mrcal-show-projection-diff or regenerate it with `curvecheck calibrate`");
  }
  const std::string terminated = text + "\n";
  ModelPtr m;
  const std::string said = CaptureStderr(
      [&] { m.reset(mrcal_read_cameramodel_string(terminated.c_str(), static_cast<int>(terminated.size()))); });
  if (!m) {
    throw Error(source,
                "is not a readable mrcal .cameramodel (mrcal's parser rejected it" +
                    (said.empty() ? std::string(")") : ": " + said + ")"),
                "check it with mrcal-show-projection-diff or regenerate it with `curvecheck calibrate`");
  }
  return FromMrcal(*m, source);
}

CameraModel ReadCameraModel(const std::filesystem::path& path) {
  return ParseCameraModel(ReadFileToString(path), path.string());
}

void WriteCameraModel(const std::filesystem::path& path, const CameraModel& model) {
  model.Check(path.string());
  const size_t n = model.intrinsics.size();
  std::unique_ptr<uint8_t[]> storage(new uint8_t[sizeof(mrcal_cameramodel_t) + n * sizeof(double)]());
  auto* m = reinterpret_cast<mrcal_cameramodel_t*>(storage.get());
  for (int i = 0; i < 6; ++i) m->rt_cam_ref[i] = model.rt_cam_ref[i];
  m->imagersize[0] = static_cast<unsigned>(model.width);
  m->imagersize[1] = static_cast<unsigned>(model.height);
  m->lensmodel = LensModel(model.lensmodel, path.string());
  std::memcpy(m->intrinsics, model.intrinsics.data(), n * sizeof(double));
  // mrcal writes the file itself: write a temporary beside the target, then read it back and rename.
  const std::filesystem::path folder = path.has_parent_path() ? path.parent_path() : ".";
  const std::filesystem::path tmp = folder / fmt::format(".{}.tmp{}", path.filename().string(), ::getpid());
  if (!mrcal_write_cameramodel_file(tmp.c_str(), m)) {
    std::filesystem::remove(tmp);
    throw Error(path.string(), "mrcal could not write the camera model", "check that the folder is writable");
  }
  const std::string text = ReadFileToString(tmp);
  std::filesystem::remove(tmp);
  WriteFileAtomic(path, text);
}

std::vector<Eigen::Vector2d> ProjectPoints(const CameraModel& model, const std::vector<Eigen::Vector3d>& points,
                                           std::vector<Eigen::Matrix<double, 2, 3>>* dq_dp,
                                           std::vector<Eigen::Matrix<double, 2, Eigen::Dynamic>>* dq_dintrinsics) {
  const mrcal_lensmodel_t lens = LensModel(model.lensmodel, "camera model");
  std::vector<mrcal_point3_t> p(points.size());
  for (size_t i = 0; i < points.size(); ++i) p[i] = {{points[i].x(), points[i].y(), points[i].z()}};
  std::vector<mrcal_point2_t> q(points.size());
  std::vector<mrcal_point3_t> grad(dq_dp ? 2 * points.size() : 0);
  const size_t ni = model.intrinsics.size();
  std::vector<double> grad_i(dq_dintrinsics ? 2 * ni * points.size() : 0);  // (N, 2, Nintrinsics), dense
  if (!mrcal_project(q.data(), dq_dp ? grad.data() : nullptr, dq_dintrinsics ? grad_i.data() : nullptr, p.data(),
                     static_cast<int>(p.size()), &lens, model.intrinsics.data())) {
    throw Error("camera model", "mrcal_project failed for " + model.lensmodel, "check the model");
  }
  std::vector<Eigen::Vector2d> out(points.size());
  for (size_t i = 0; i < points.size(); ++i) out[i] = {q[i].x, q[i].y};
  if (dq_dp) {
    dq_dp->resize(points.size());
    for (size_t i = 0; i < points.size(); ++i) {
      for (int r = 0; r < 2; ++r) {
        for (int c = 0; c < 3; ++c) (*dq_dp)[i](r, c) = grad[2 * i + static_cast<size_t>(r)].xyz[c];
      }
    }
  }
  if (dq_dintrinsics) {
    dq_dintrinsics->assign(points.size(), Eigen::Matrix<double, 2, Eigen::Dynamic>(2, static_cast<long>(ni)));
    for (size_t i = 0; i < points.size(); ++i) {
      for (size_t r = 0; r < 2; ++r) {
        for (size_t c = 0; c < ni; ++c) {
          (*dq_dintrinsics)[i](static_cast<long>(r), static_cast<long>(c)) = grad_i[(2 * i + r) * ni + c];
        }
      }
    }
  }
  return out;
}

struct PointProjector::Lens {
  mrcal_lensmodel_t lens;
};

PointProjector::PointProjector(const CameraModel& model)
    : model_(&model), lens_(std::make_shared<const Lens>(Lens{LensModel(model.lensmodel, "camera model")})) {}

Eigen::Vector2d PointProjector::Project(const Eigen::Vector3d& point, Eigen::Matrix<double, 2, 3>* dq_dp,
                                        const double* intrinsics, double* dq_dintrinsics) const {
  const mrcal_point3_t p = {{point.x(), point.y(), point.z()}};
  mrcal_point2_t q;
  mrcal_point3_t grad[2];
  // mrcal's dq_dintrinsics of one point is (2, Nintrinsics), row-major: the layout asked for.
  if (!mrcal_project(&q, dq_dp ? grad : nullptr, dq_dintrinsics, &p, 1, &lens_->lens,
                     intrinsics ? intrinsics : model_->intrinsics.data())) {
    throw Error("camera model", "mrcal_project failed for " + model_->lensmodel, "check the model");
  }
  if (dq_dp) {
    for (int r = 0; r < 2; ++r) {
      for (int c = 0; c < 3; ++c) (*dq_dp)(r, c) = grad[r].xyz[c];
    }
  }
  return {q.x, q.y};
}

Eigen::Vector2d ProjectPoint(const CameraModel& model, const Eigen::Vector3d& point) {
  return ProjectPoints(model, {point}).front();
}

std::vector<Eigen::Vector3d> UnprojectPixels(const CameraModel& model, const std::vector<Eigen::Vector2d>& pixels) {
  const mrcal_lensmodel_t lens = LensModel(model.lensmodel, "camera model");
  std::vector<mrcal_point2_t> q(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) q[i] = {{pixels[i].x(), pixels[i].y()}};
  std::vector<mrcal_point3_t> v(pixels.size());
  if (!mrcal_unproject(v.data(), q.data(), static_cast<int>(q.size()), &lens, model.intrinsics.data())) {
    throw Error("camera model", "mrcal_unproject failed for " + model.lensmodel, "check the model");
  }
  std::vector<Eigen::Vector3d> out(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) out[i] = Eigen::Vector3d(v[i].x, v[i].y, v[i].z).normalized();
  return out;
}

CameraModel PinholeModel(int width, int height, double focal_px) {
  CameraModel m;
  m.lensmodel = "LENSMODEL_PINHOLE";
  m.intrinsics = {focal_px, focal_px, 0.5 * (width - 1), 0.5 * (height - 1)};
  m.width = width;
  m.height = height;
  return m;
}

}  // namespace curvecheck
