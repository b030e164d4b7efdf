// `curvecheck plan` once its options are parsed (app/plan_command.cc): the camera (a model, or a pinhole from
// --sensor-px and --focal-px), the lens covariance as analyze finds it, the pattern (given, or render's default), the
// plan (plan.h), its table printed and DIR/plan.json, plan.png, plan.gp and plan.dat written as one set.
#pragma once

#include <iosfwd>
#include <optional>
#include <string>

#include "analysis/plan.h"

namespace curvecheck {

// The command's options; `options` holds those that bind to PlanOptions directly.
struct PlanRequest {
  std::string monitor = "default";
  std::string camera;
  std::string sensor_px;
  std::optional<double> focal_px;
  std::string pattern;
  std::string output;
  std::string lens_covariance;
  std::string distances_mm, yaws_deg, heights_mm;
  double pitch_tolerance_percent = 0.1;
  PlanOptions options;
};

// Plans into request.output (created if missing; nothing written unless the whole set is); the table and what was
// written on `log`. Throws Error naming the option at fault.
void PlanToFolder(PlanRequest request, const std::string& command_line, std::ostream& log);

}  // namespace curvecheck
