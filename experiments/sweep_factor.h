// The factors a stability sweep (`curvecheck sweep`) can vary, each declared once with its range, its meaning
// and the function that applies a value of it to a grid point.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "pattern/pattern.h"
#include "synth/synthetic_camera.h"

namespace curvecheck::experiments {

// A sweep factor on its grid: count values from start to stop, evenly spaced (count 1: start only).
struct SweepFactor {
  std::string name;  // canonical, with its unit: "yaw_deg", "noise_x", ...
  double start = 0, stop = 0;
  int count = 1;
  double Value(int i) const { return count == 1 ? start : start + (stop - start) * i / (count - 1); }
};

// One grid point while its factors are applied: the scene photographed and the pattern rendered. The camera
// placement is collected here and made by PlaceCamera(), so that it does not depend on the order of the
// factors.
struct SweepPoint {
  SyntheticScene scene;
  PatternSpec spec;
  Eigen::Vector3d offset_from_centre_mm =
      Eigen::Vector3d::Zero();        // camera - screen centre, before the rotations
  double yaw_deg = 0, pitch_deg = 0;  // camera moved around the screen centre (positive: right, up)
  double sideways_mm = 0;             // camera moved along x from the viewpoint the pattern is rendered for
  bool camera_moved = false;          // a geometry factor was applied: the camera is placed anew
  Eigen::Vector3d viewpoint_in_screen =
      Eigen::Vector3d::Zero();  // the pattern is rendered for this (PlaceCamera)
};

struct FactorInfo {
  const char* name;   // canonical, with the unit
  const char* alias;  // accepted on the command line
  double lo, hi;      // allowed values (inclusive)
  const char* meaning;
  void (*apply)(double value, SweepPoint& point);  // sets what the factor varies
};

// Every factor, in the order of `--help`.
const std::vector<FactorInfo>& SweepFactors();

// The factor of a canonical name or alias; throws Error naming --factor (listing the factors) for another
// name.
const FactorInfo& FindFactor(const std::string& name);

// "NAME=start:stop:count" or "NAME=value" -> the factor on its grid; throws Error naming --factor for a
// malformed text, an unknown name, a count outside 1..1000 or a value outside the factor's range.
SweepFactor ParseFactor(const std::string& text);

// The point of the grid with these factor values (in the order of `factors`) on `base`, a pattern of `spec`:
// every factor applied, then the camera placed: pitch about x, then yaw about y, around the screen centre at
// the (possibly new) distance, looking at the centre; the viewpoint is that position, the camera then moved
// sideways.
SweepPoint MakeSweepPoint(const SyntheticScene& base, const PatternSpec& spec,
                          const std::vector<SweepFactor>& factors, const std::vector<double>& values);

}  // namespace curvecheck::experiments
