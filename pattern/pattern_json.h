// pattern.json, the ground truth of a rendering (architecture.md, "File contracts"), format
// "curvecheck.pattern/1":
//   { "format": "curvecheck.pattern/1",
//     "monitor": MonitorToJson (core/monitor_json.h),
//     "viewpoint_mm": [x, y, z],                       screen frame
//     "method": "exact", "method_parameters": { "name": "exact", ... },
//     "pattern": { "kind", the resolved sizes and counts of that kind, "tag_ids" (tag kinds), "margin",
//                  "centre_mm", "plane": { "origin_mm", "x_axis", "y_axis" } (screen frame),
//                  "cells": { "cell_mm", "top_left_mm", "width", "height" } (the grid's geometry, not its
//                  values) },
//     "features": [ { "id", "kind", "pattern_mm": [a, b], "point_mm": [x, y, z],
//                     "display_px": [x, y] or null, "visible": bool } ],
//     "render": { "image": the PNG's file name, "image_content_hash": DisplayImageHash of it, ... } }
//     ("render" is written by `curvecheck render`; the other writers, e.g. the experiments, omit it)
// Numbers are written with full double precision, so a written file reads back bit for bit.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/image_io.h"
#include "core/monitor.h"
#include "pattern/pattern.h"

namespace curvecheck {

// The pattern.json document of a built pattern. `method` is the correction method with all its parameters,
// an object whose "name" is a text ({"name": "exact", ...}); it is written as "method_parameters", and its
// name as "method". Throws Error if `method` has no text "name".
nlohmann::json PatternToJson(const Pattern& p, const Monitor& m, const Eigen::Vector3d& viewpoint_in_screen,
                             const nlohmann::json& method);

// What later stages read back from a pattern.json.
struct PatternFile {
  nlohmann::json raw;  // the whole document, as read
  Monitor monitor;
  Eigen::Vector3d viewpoint_in_screen = Eigen::Vector3d::Zero();
  std::string method;  // the method name
  std::vector<Feature> features;
};

// Reads and validates a pattern.json: readable, valid JSON, the format string, a valid monitor and viewpoint,
// a method name, a pattern object, finite numbers everywhere in the document, and a non-empty list of
// features with well-formed, unique ids ("c<k>" of kind "corner", "t<id>.<0..3>" of kind "tag_corner" with
// id < 587). Throws Error naming the file, the offending entry and what to do.
PatternFile ReadPatternJson(const std::filesystem::path& path);
// The same from the text of a pattern.json; `source` names it in errors (the file path, as ReadPatternJson
// does). The entry point for the fuzzer (fuzz/fuzz_pattern_json.cc) and for text already in memory.
PatternFile ParsePatternJson(const std::string& text, const std::string& source);

// The content hash `render` records of the PNG it wrote (render.image_content_hash): core/image_hash.h's hash of
// the gray pixels, as 32 hex digits. A colour image whose channels are all equal hashes as its gray image (a
// lossless re-save as RGB is the same display image); any other colour image has a hash no render wrote.
std::string DisplayImageHash(const Image8& image);

// A display image and a pattern.json are read as a pair (the .json beside the .png): refuses a pair that
// `render` did not write together, because the features would then describe another picture. Checks, when the
// pattern.json records them: render.image_content_hash against `image` (a renamed copy of the pair passes);
// without a hash, render.image against `image_path`'s file name. A pattern.json without a "render" object (not
// from `render`) passes. Throws Error naming both files, what each says and the fix.
void CheckPatternBelongsToImage(const PatternFile& pattern, const std::filesystem::path& pattern_json,
                                const std::filesystem::path& image_path, const Image8& image);

}  // namespace curvecheck
