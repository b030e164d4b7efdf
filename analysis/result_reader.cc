#include "analysis/result_reader.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <set>

#include "core/error.h"
#include "core/file_io.h"

namespace curvecheck {
namespace {

using json = nlohmann::json;

constexpr int kMaxDepth = 32;
constexpr char kFix[] =
    "the file was not written by this version of curvecheck analyze or was edited; re-run curvecheck analyze";

// What a JSON value is, for messages: "a string", "null", ...
std::string Kind(const json& v) {
  switch (v.type()) {
    case json::value_t::null: return "null";
    case json::value_t::object: return "an object";
    case json::value_t::array: return "a list";
    case json::value_t::string: return "a string";
    case json::value_t::boolean: return "a boolean";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: return "a number";
    default: return "not a JSON value";
  }
}

std::string Key(const std::string& at, const std::string& key) { return at.empty() ? key : at + "." + key; }
std::string Index(const std::string& at, size_t i) { return fmt::format("{}[{}]", at, i); }

// Checks one document; each failure names the source and the key path ("fit.candidates[2].radius_mm").
class Checker {
 public:
  explicit Checker(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void Fail(const std::string& at, const std::string& problem) const {
    throw Error(source_, fmt::format("key '{}' {}", at.empty() ? "(top level)" : at, problem), kFix);
  }

  const json& Object(const json& v, const std::string& at) const {
    if (!v.is_object()) Fail(at, fmt::format("is {}, not an object", Kind(v)));
    return v;
  }
  const json& List(const json& v, const std::string& at) const {
    if (!v.is_array()) Fail(at, fmt::format("is {}, not a list", Kind(v)));
    return v;
  }
  // The member `key` of object `o` (at `at`), which must exist.
  const json& Member(const json& o, const std::string& at, const std::string& key) const {
    const auto it = o.find(key);
    if (it == o.end()) Fail(Key(at, key), "is missing");
    return *it;
  }
  // The member, or nullptr when absent.
  static const json* Optional(const json& o, const std::string& key) {
    const auto it = o.find(key);
    return it == o.end() ? nullptr : &*it;
  }

  void String(const json& v, const std::string& at) const {
    if (!v.is_string()) Fail(at, fmt::format("is {}, not a string", Kind(v)));
  }
  void Bool(const json& v, const std::string& at) const {
    if (!v.is_boolean()) Fail(at, fmt::format("is {}, not true or false", Kind(v)));
  }
  void Number(const json& v, const std::string& at) const {
    if (!v.is_number()) Fail(at, fmt::format("is {}, not a number", Kind(v)));
    if (!std::isfinite(v.get<double>())) Fail(at, "is not a finite number");
  }
  void NumberOrNull(const json& v, const std::string& at) const {
    if (v.is_null()) return;
    if (!v.is_number()) Fail(at, fmt::format("is {}, not a number or null", Kind(v)));
    if (!std::isfinite(v.get<double>())) Fail(at, "is not a finite number");
  }
  void Int(const json& v, const std::string& at, long lo, long hi) const {
    if (!v.is_number_integer()) Fail(at, fmt::format("is {}, not a whole number", Kind(v)));
    bool in_range;
    if (v.is_number_unsigned()) {
      const auto u = v.get<std::uint64_t>();
      in_range = u <= static_cast<std::uint64_t>(hi) && (lo <= 0 || u >= static_cast<std::uint64_t>(lo));
    } else {
      const auto s = v.get<std::int64_t>();
      in_range = s >= lo && s <= hi;
    }
    if (!in_range) Fail(at, fmt::format("is {}, outside {} .. {}", v.dump(), lo, hi));
  }
  // A list of n numbers (or nulls when allow_null).
  void Vector(const json& v, const std::string& at, size_t n, bool allow_null) const {
    if (!v.is_array() || v.size() != n) {
      Fail(at, fmt::format("is {}, not a list of {} numbers", v.is_array() ? fmt::format("a list of {}", v.size())
                                                                           : Kind(v), n));
    }
    for (size_t i = 0; i < n; ++i) {
      if (allow_null) {
        NumberOrNull(v[i], Index(at, i));
      } else {
        Number(v[i], Index(at, i));
      }
    }
  }
  void Strings(const json& v, const std::string& at) const {
    List(v, at);
    for (size_t i = 0; i < v.size(); ++i) String(v[i], Index(at, i));
  }

  // Optional members: checked when present.
  template <typename F>
  void IfPresent(const json& o, const std::string& at, const std::string& key, F&& check) const {
    if (const json* v = Optional(o, key)) check(*v, Key(at, key));
  }

  // Depth bound and finiteness of every number (the parser refuses NaN, but 1e999 becomes inf).
  void Walk(const json& v, const std::string& at, int depth) const {
    if (depth > kMaxDepth) Fail(at, fmt::format("is nested more than {} levels deep", kMaxDepth));
    if (v.is_number_float() && !std::isfinite(v.get<double>())) Fail(at, "is not a finite number");
    if (v.is_object()) {
      for (const auto& [key, value] : v.items()) Walk(value, Key(at, key), depth + 1);
    } else if (v.is_array()) {
      for (size_t i = 0; i < v.size(); ++i) Walk(v[i], Index(at, i), depth + 1);
    }
  }

 private:
  std::string source_;
};

void CheckVerification(const Checker& c, const json& v, const std::string& at) {
  c.Object(v, at);
  for (const char* key : {"rms_px", "max_px", "rms_arcmin", "max_arcmin", "rms_display_px", "max_display_px",
                          "p95_display_px"}) {
    c.NumberOrNull(c.Member(v, at, key), Key(at, key));
  }
  c.Number(c.Member(v, at, "tolerance_display_px"), Key(at, "tolerance_display_px"));
  c.Bool(c.Member(v, at, "pass"), Key(at, "pass"));
  c.Int(c.Member(v, at, "features"), Key(at, "features"), 0, 1L << 40);
  c.IfPresent(v, at, "failure", [&](const json& x, const std::string& k) { c.String(x, k); });
  // The three-state verdict and its figures (absent in result.json written before them).
  c.IfPresent(v, at, "verdict", [&](const json& x, const std::string& k) {
    if (x.is_null()) return;
    c.String(x, k);
    if (x != "pass" && x != "fail" && x != "inconclusive") c.Fail(k, "is not pass, fail or inconclusive");
  });
  for (const char* key : {"error_p95_display_px", "expanded_uncertainty_display_px", "coverage_factor",
                          "tolerance_ratio", "noise_px", "display_px_per_camera_px"}) {
    c.IfPresent(v, at, key, [&](const json& x, const std::string& k) { c.NumberOrNull(x, k); });
  }
  for (const char* key : {"reason", "advice", "decision_rule"}) {
    c.IfPresent(v, at, key, [&](const json& x, const std::string& k) { c.String(x, k); });
  }
}

void CheckModelFit(const Checker& c, const json& f, const std::string& at) {
  c.Object(f, at);
  c.String(c.Member(f, at, "model"), Key(at, "model"));
  c.Int(c.Member(f, at, "parameters"), Key(at, "parameters"), 0, 1L << 30);
  for (const char* key : {"rms_px", "noise_px", "bic", "heldout_rms_px", "radius_mm", "radius_sigma_mm"}) {
    c.NumberOrNull(c.Member(f, at, key), Key(at, key));
  }
  c.Vector(c.Member(f, at, "radius_ci95_mm"), Key(at, "radius_ci95_mm"), 2, true);
  for (const char* key : {"radius_lower_bound_mm", "curvature_per_mm", "curvature_sigma_per_mm", "time_ms"}) {
    c.IfPresent(f, at, key, [&](const json& x, const std::string& k) { c.NumberOrNull(x, k); });
  }
  for (const char* key : {"converged", "ill_conditioned", "chosen"}) {
    c.IfPresent(f, at, key, [&](const json& x, const std::string& k) { c.Bool(x, k); });
  }
  c.IfPresent(f, at, "condition_note", [&](const json& x, const std::string& k) { c.String(x, k); });
  c.IfPresent(f, at, "warnings", [&](const json& x, const std::string& k) { c.Strings(x, k); });
  c.IfPresent(f, at, "extra", [&](const json& x, const std::string& k) {
    c.Object(x, k);
    for (const auto& [name, e] : x.items()) {
      const std::string ek = Key(k, name);
      c.Object(e, ek);
      c.NumberOrNull(c.Member(e, ek, "value"), Key(ek, "value"));
      c.NumberOrNull(c.Member(e, ek, "sigma"), Key(ek, "sigma"));
    }
  });
}

}  // namespace

void CheckResultJson(const json& root, const std::string& source) {
  const Checker c(source);
  c.Object(root, "");
  c.Walk(root, "", 0);

  const json& format = c.Member(root, "", "format");
  if (!format.is_string() || format.get<std::string>() != kResultFormat) {
    std::string shown = format.dump();
    if (shown.size() > 40) shown = shown.substr(0, 37) + "...";
    throw Error(source, fmt::format("key 'format' is {}, not \"{}\"", shown, kResultFormat),
                "this version reads curvecheck.result/1 files written by curvecheck analyze");
  }
  c.IfPresent(root, "", "command", [&](const json& x, const std::string& k) { c.String(x, k); });

  // inputs
  const json& inputs = c.Object(c.Member(root, "", "inputs"), "inputs");
  const json& camera = c.Object(c.Member(inputs, "inputs", "camera"), "inputs.camera");
  c.String(c.Member(camera, "inputs.camera", "path"), "inputs.camera.path");
  c.String(c.Member(camera, "inputs.camera", "lensmodel"), "inputs.camera.lensmodel");
  {
    const json& size = c.Member(camera, "inputs.camera", "imagersize");
    if (!size.is_array() || size.size() != 2) c.Fail("inputs.camera.imagersize", "is not a list of 2 whole numbers");
    for (size_t i = 0; i < 2; ++i) c.Int(size[i], Index("inputs.camera.imagersize", i), 1, 1000000);
  }
  const json& monitor = c.Object(c.Member(inputs, "inputs", "monitor"), "inputs.monitor");
  c.String(c.Member(monitor, "inputs.monitor", "name"), "inputs.monitor.name");
  {
    const json& res = c.Member(monitor, "inputs.monitor", "resolution");
    if (!res.is_array() || res.size() != 2) c.Fail("inputs.monitor.resolution", "is not a list of 2 whole numbers");
    for (size_t i = 0; i < 2; ++i) c.Int(res[i], Index("inputs.monitor.resolution", i), 1, 1000000);
  }
  c.Number(c.Member(monitor, "inputs.monitor", "width_mm"), "inputs.monitor.width_mm");
  c.Number(c.Member(monitor, "inputs.monitor", "height_mm"), "inputs.monitor.height_mm");
  {
    const json& r = c.Member(monitor, "inputs.monitor", "radius_mm");
    if (!(r.is_string() && r.get<std::string>() == "flat")) {
      if (!r.is_number()) c.Fail("inputs.monitor.radius_mm", fmt::format("is {}, not a number or \"flat\"", Kind(r)));
    }
  }
  c.IfPresent(monitor, "inputs.monitor", "pixel_pitch_mm", [&](const json& x, const std::string& k) { c.Number(x, k); });

  const json& photos = c.List(c.Member(inputs, "inputs", "photos"), "inputs.photos");
  std::set<std::string> names, used;
  for (size_t i = 0; i < photos.size(); ++i) {
    const std::string at = Index("inputs.photos", i);
    const json& p = c.Object(photos[i], at);
    const json& name = c.Member(p, at, "name");
    c.String(name, Key(at, "name"));
    const std::string n = name.get<std::string>();
    if (n.empty() || n.find('/') != std::string::npos || n.find('\0') != std::string::npos) {
      c.Fail(Key(at, "name"), "must be a file name (not empty, no '/')");
    }
    if (!names.insert(n).second) c.Fail(Key(at, "name"), fmt::format("'{}' appears twice", n));
    c.String(c.Member(p, at, "photo"), Key(at, "photo"));
    c.String(c.Member(p, at, "pattern"), Key(at, "pattern"));
    const json& status = c.Member(p, at, "status");
    if (!status.is_string() || (status != "used" && status != "rejected")) {
      c.Fail(Key(at, "status"), fmt::format("is {}, not \"used\" or \"rejected\"", status.is_string() ? status.dump()
                                                                                                       : Kind(status)));
    }
    if (status == "used") used.insert(n);
    c.IfPresent(p, at, "reason", [&](const json& x, const std::string& k) { c.String(x, k); });
    c.IfPresent(p, at, "detection", [&](const json& d, const std::string& k) {
      c.Object(d, k);
      c.String(c.Member(d, k, "detector"), Key(k, "detector"));
      c.Int(c.Member(d, k, "features"), Key(k, "features"), 0, 1L << 40);
      c.Int(c.Member(d, k, "flagged"), Key(k, "flagged"), 0, 1L << 40);
      c.Strings(c.Member(d, k, "notes"), Key(k, "notes"));
      c.Number(c.Member(d, k, "time_ms"), Key(k, "time_ms"));
    });
    c.IfPresent(p, at, "verification", [&](const json& x, const std::string& k) { CheckVerification(c, x, k); });
  }

  CheckVerification(c, c.Member(root, "", "verification"), "verification");

  // fit
  const json& fit = c.Object(c.Member(root, "", "fit"), "fit");
  const json& model = c.Member(fit, "fit", "model");
  if (model.is_null()) {
    c.String(c.Member(fit, "fit", "failure"), "fit.failure");
  } else {
    CheckModelFit(c, fit, "fit");
    c.String(c.Member(fit, "fit", "choice_reason"), "fit.choice_reason");
    c.Strings(c.Member(fit, "fit", "assumptions"), "fit.assumptions");
    const json& candidates = c.List(c.Member(fit, "fit", "candidates"), "fit.candidates");
    for (size_t i = 0; i < candidates.size(); ++i) CheckModelFit(c, candidates[i], Index("fit.candidates", i));
    const json& cameras = c.List(c.Member(fit, "fit", "cameras"), "fit.cameras");
    for (size_t i = 0; i < cameras.size(); ++i) {
      const std::string at = Index("fit.cameras", i);
      c.Object(cameras[i], at);
      c.String(c.Member(cameras[i], at, "photo"), Key(at, "photo"));
      for (const char* key : {"position_mm", "position_sigma_mm", "stated_viewpoint_mm"}) {
        c.Vector(c.Member(cameras[i], at, key), Key(at, key), 3, true);
      }
      c.IfPresent(cameras[i], at, "position_in_centre_mm",
                  [&](const json& x, const std::string& k) { c.Vector(x, k, 3, true); });
    }
    c.IfPresent(fit, "fit", "outliers", [&](const json& x, const std::string& k) {
      c.List(x, k);
      for (size_t i = 0; i < x.size(); ++i) {
        const std::string at = Index(k, i);
        c.Object(x[i], at);
        c.String(c.Member(x[i], at, "photo"), Key(at, "photo"));
        c.String(c.Member(x[i], at, "id"), Key(at, "id"));
        c.Vector(c.Member(x[i], at, "residual_px"), Key(at, "residual_px"), 2, true);
      }
    });
  }
  c.IfPresent(fit, "fit", "failure", [&](const json& x, const std::string& k) { c.String(x, k); });
  c.IfPresent(fit, "fit", "warnings", [&](const json& x, const std::string& k) { c.Strings(x, k); });

  // deviations
  c.IfPresent(root, "", "deviations", [&](const json& d, const std::string& k) {
    c.Object(d, k);
    c.IfPresent(d, k, "note", [&](const json& x, const std::string& kk) { c.String(x, kk); });
    const json& map = c.Object(c.Member(d, k, "map"), Key(k, "map"));
    const std::string mk = Key(k, "map");
    c.Int(c.Member(map, mk, "nu"), Key(mk, "nu"), 1, 1000000);
    c.Int(c.Member(map, mk, "nv"), Key(mk, "nv"), 1, 1000000);
    const long cells = map["nu"].get<long>() * map["nv"].get<long>();
    if (cells > 1000000) c.Fail(mk, fmt::format("has {} cells, more than 1000000", cells));
    for (const char* key : {"mm", "sigma_mm"}) {
      const json& values = c.List(c.Member(map, mk, key), Key(mk, key));
      if (static_cast<long>(values.size()) != cells) {
        c.Fail(Key(mk, key), fmt::format("has {} values, not nu x nv = {}", values.size(), cells));
      }
      for (size_t i = 0; i < values.size(); ++i) c.NumberOrNull(values[i], Index(Key(mk, key), i));
    }
  });

  // features
  const json& features = c.List(c.Member(root, "", "features"), "features");
  for (size_t i = 0; i < features.size(); ++i) {
    const std::string at = Index("features", i);
    const json& f = c.Object(features[i], at);
    c.String(c.Member(f, at, "id"), Key(at, "id"));
    const json& photo = c.Member(f, at, "photo");
    c.String(photo, Key(at, "photo"));
    if (!used.count(photo.get<std::string>())) {
      c.Fail(Key(at, "photo"), fmt::format("is '{}', not the name of a used photo in inputs.photos",
                                           photo.get<std::string>().substr(0, 60)));
    }
    c.Vector(c.Member(f, at, "detected_px"), Key(at, "detected_px"), 2, false);
    for (const char* key : {"display_px", "expected_px", "residual_px"}) {
      c.IfPresent(f, at, key, [&](const json& x, const std::string& k) { c.Vector(x, k, 2, false); });
    }
    for (const char* key : {"residual_display_px", "fit_residual_px"}) {
      c.IfPresent(f, at, key, [&](const json& x, const std::string& k) { c.Vector(x, k, 2, true); });
    }
    for (const char* key : {"quality", "residual_arcmin", "deviation_mm", "deviation_sigma_mm"}) {
      c.IfPresent(f, at, key, [&](const json& x, const std::string& k) { c.NumberOrNull(x, k); });
    }
    c.IfPresent(f, at, "flag", [&](const json& x, const std::string& k) { c.String(x, k); });
    c.IfPresent(f, at, "fit_outlier", [&](const json& x, const std::string& k) { c.Bool(x, k); });
  }

  c.IfPresent(root, "", "timing_ms", [&](const json& t, const std::string& k) {
    c.Object(t, k);
    c.IfPresent(t, k, "total", [&](const json& x, const std::string& kk) { c.Number(x, kk); });
    c.IfPresent(t, k, "fit", [&](const json& x, const std::string& kk) { c.Number(x, kk); });
  });
}

json ParseResultJson(std::string_view text, const std::string& source) {
  json root;
  try {
    // The depth bound is enforced while parsing, before a deep document is built (and later destroyed).
    root = json::parse(text.begin(), text.end(), [&](int depth, json::parse_event_t, json&) {
      if (depth > kMaxDepth) {
        throw Error(source, fmt::format("is nested more than {} levels deep", kMaxDepth), kFix);
      }
      return true;
    });
  } catch (const json::exception& e) {
    throw Error(source, fmt::format("is not valid JSON ({})", e.what()),
                "the file is damaged or truncated; re-run curvecheck analyze");
  }
  CheckResultJson(root, source);
  return root;
}

json ReadResultJson(const std::filesystem::path& path) { return ParseResultJson(ReadFileToString(path), path.string()); }

}  // namespace curvecheck
