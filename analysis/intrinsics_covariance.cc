// The lens calibration's sidecar beside a camera model, CAM.intrinsics_covariance.json (analysis/screen_fit.h
// IntrinsicsCovariance; written by calibrate/calibrate.h IntrinsicsCovarianceJson): read, checked against the
// camera model, and stated into the fit's options (the lens calibration row and the lens-model-misfit row's stated
// field).
#include <fmt/format.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <string>

#include "analysis/screen_fit.h"
#include "core/error.h"
#include "core/file_io.h"

namespace curvecheck {

std::filesystem::path IntrinsicsCovariancePathFor(const std::filesystem::path& camera_path) {
  std::filesystem::path p = camera_path;
  p.replace_extension(".intrinsics_covariance.json");
  return p;
}

IntrinsicsCovariance ReadIntrinsicsCovariance(const std::filesystem::path& path, const CameraModel& camera) {
  const std::string where = path.string();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(ReadFileToString(path));
  } catch (const nlohmann::json::exception& e) {
    throw Error(where, std::string("not valid JSON: ") + e.what(),
                "write it with curvecheck calibrate (format curvecheck.intrinsics_covariance/1)");
  }
  const auto fix = "give the covariance written with this camera model by curvecheck calibrate";
  if (j.value("format", "") != "curvecheck.intrinsics_covariance/1") {
    throw Error(where, fmt::format("format is '{}', not curvecheck.intrinsics_covariance/1", j.value("format", "")),
                fix);
  }
  if (j.value("lensmodel", "") != camera.lensmodel) {
    throw Error(where,
                fmt::format("lens model {} does not match the camera model's {}", j.value("lensmodel", ""),
                            camera.lensmodel),
                fix);
  }
  const size_t n = camera.intrinsics.size();
  if (!j.contains("covariance") || !j["covariance"].is_array() || j["covariance"].size() != n) {
    throw Error(where, fmt::format("covariance must be {} rows of {} numbers", n, n), fix);
  }
  IntrinsicsCovariance out;
  out.source = where;
  out.covariance.resize(static_cast<long>(n), static_cast<long>(n));
  for (size_t r = 0; r < n; ++r) {
    const nlohmann::json& row = j["covariance"][r];
    if (!row.is_array() || row.size() != n) throw Error(where, fmt::format("covariance row {} is not {} numbers", r, n), fix);
    for (size_t c = 0; c < n; ++c) {
      if (!row[c].is_number()) throw Error(where, fmt::format("covariance[{}][{}] is not a number", r, c), fix);
      out.covariance(static_cast<long>(r), static_cast<long>(c)) = row[c].get<double>();
    }
  }
  if (!out.covariance.allFinite() || (out.covariance - out.covariance.transpose()).norm() >
                                         1e-9 * std::max(1e-300, out.covariance.norm())) {
    throw Error(where, "the covariance is not finite and symmetric", fix);
  }
  for (size_t i = 0; i < n; ++i) {
    if (out.covariance(static_cast<long>(i), static_cast<long>(i)) < 0) {
      throw Error(where, fmt::format("variance {} is negative", i), fix);
    }
  }
  if (j.contains("dof") && j["dof"].is_number() && j["dof"].get<double>() >= 1) out.dof = j["dof"].get<double>();
  if (j.contains("misfit")) {
    const nlohmann::json& m = j["misfit"];
    const auto number = [&](const char* key) {
      if (!m.is_object() || !m.contains(key) || !m[key].is_number()) {
        throw Error(where, fmt::format("misfit.{} is not a number", key), fix);
      }
      return m[key].get<double>();
    };
    out.misfit_rms_px = number("rms_px");
    out.misfit_length_px = number("length_px");
    if (!IsLensMisfitField(out.misfit_rms_px, out.misfit_length_px)) {
      throw Error(where,
                  fmt::format("misfit is {} px RMS at a length of {} px", out.misfit_rms_px, out.misfit_length_px),
                  "an RMS of 0 to 100 px and a positive length; " + std::string(fix));
    }
  }
  return out;
}

void IntrinsicsCovariance::ApplyTo(FitOptions* options) const {
  options->intrinsics_covariance = covariance;
  options->intrinsics_covariance_dof = dof;
  options->intrinsics_covariance_source = source;
  if (options->stated_lens_misfit_px == 0 && misfit_rms_px > 0) {
    options->stated_lens_misfit_px = misfit_rms_px;
    options->stated_lens_misfit_length_px = misfit_length_px;
    options->stated_lens_misfit_source = fmt::format("the calibration's measured misfit ({})", source);
  }
}

}  // namespace curvecheck
