// Reading result.json (format curvecheck.result/1, written by `curvecheck analyze`; architecture.md "File
// contracts") back, for `curvecheck report` and anything else that consumes it.
//
// The reader checks the type of every field the report uses, so that code downstream can read a checked document
// without further checks: a key that is wrong fails here with one line naming the file and the key, e.g.
//   "out/result.json: key 'fit.candidates[2].radius_mm' is a string, not a number or null; ..."
// Keys it does not know are allowed (later versions may add some); keys it knows must have their type.
//
// What is checked (every number finite; "?" = optional, "|null" = may be null):
//   format == "curvecheck.result/1"; command? string
//   inputs.camera {path string, lensmodel string, imagersize [int, int]}
//   inputs.monitor {name string, resolution [int, int], width_mm, height_mm number, radius_mm number|"flat",
//                   pixel_pitch_mm? number}
//   inputs.photos[] {name (non-empty, unique, no '/'), photo, pattern string, status "used"|"rejected",
//                    reason? string, detection? {detector string, features int, flagged int, notes [string],
//                    time_ms number}, verification? <verification>}
//   verification: {rms_px, max_px, rms_arcmin, max_arcmin, rms_display_px, max_display_px, p95_display_px:
//                  number|null; tolerance_display_px number; pass bool; features int; failure? string}
//   fit: {model: null, failure string} or {model string, <model fit>, choice_reason string, assumptions [string],
//         warnings? [string], candidates [<model fit> + chosen bool], cameras [{photo string, position_mm,
//         position_in_centre_mm?, position_sigma_mm, stated_viewpoint_mm: [3 x number|null]}], outliers?
//         [{photo, id string, residual_px [2 x number|null]}]}
//     <model fit>: model string, parameters int, rms_px, noise_px, bic, heldout_rms_px: number|null,
//                  radius_mm, radius_sigma_mm: number|null, radius_ci95_mm [2 x number|null],
//                  radius_lower_bound_mm? number|null, curvature_per_mm?, curvature_sigma_per_mm? number|null,
//                  converged? bool, ill_conditioned? bool, condition_note? string, warnings? [string],
//                  extra? {name: {value, sigma: number|null}}, time_ms? number
//   deviations? {note? string, map {nu, nv int >= 1, nu nv <= 1e6, mm and sigma_mm [nu nv x number|null]}}
//   features[] {id string, photo (a used photo's name), detected_px [2], flag? string,
//               display_px?, expected_px?, residual_px? [2], residual_display_px? [2 x number|null],
//               fit_residual_px? [2 x number|null], fit_outlier? bool,
//               quality?, residual_arcmin?, deviation_mm?, deviation_sigma_mm? number|null}
//   timing_ms? {total?, fit? number}
// Nothing may be nested deeper than 32 levels (a result.json nests 5).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace curvecheck {

inline constexpr char kResultFormat[] = "curvecheck.result/1";

// Parses `text` (the contents of `source`, which names it in messages) and checks it (CheckResultJson). Throws
// Error on invalid JSON or a document that breaks the contract above.
nlohmann::json ParseResultJson(std::string_view text, const std::string& source);

// ParseResultJson of the file's contents. Throws Error if it cannot be read.
nlohmann::json ReadResultJson(const std::filesystem::path& path);

// Checks an in-memory document (e.g. the one ResultJson made) against the contract above; throws Error naming
// `source` and the first offending key.
void CheckResultJson(const nlohmann::json& result, const std::string& source);

}  // namespace curvecheck
