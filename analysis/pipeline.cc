#include "analysis/pipeline.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <tuple>
#include <set>
#include <sstream>

#include "analysis/overlay.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/image_hash.h"
#include "core/stopwatch.h"
#include "core/monitor_json.h"
#include "core/screen_geometry.h"

namespace curvecheck {
namespace {

bool SameMonitor(const Monitor& a, const Monitor& b) {
  const auto near = [](double x, double y) { return std::abs(x - y) <= 1e-9 * std::max(1.0, std::abs(x)); };
  return a.width_px == b.width_px && a.height_px == b.height_px && near(a.width_mm, b.width_mm) &&
         near(a.height_mm, b.height_mm) && near(a.curvature_per_mm, b.curvature_per_mm);
}

}  // namespace

std::vector<std::string> PhotoNames(const std::vector<PhotoInput>& inputs) {
  // Unique by stem, not only by name: the overlay is named after the stem (OverlayFileName), so a/photo.png and
  // b/photo.png, or photo.png and photo.jpg, would otherwise share one overlay. The second becomes photo-2.png.
  std::set<std::string> stems;
  std::vector<std::string> names;
  for (const PhotoInput& in : inputs) {
    std::string name = in.photo.filename().string();
    if (name.empty()) name = "photo";
    const std::string stem = std::filesystem::path(name).stem().string();
    const std::string ext = std::filesystem::path(name).extension().string();
    std::string candidate = name;
    for (int k = 2; stems.count(std::filesystem::path(candidate).stem().string()); ++k) {
      candidate = fmt::format("{}-{}{}", stem, k, ext);
    }
    stems.insert(std::filesystem::path(candidate).stem().string());
    names.push_back(candidate);
  }
  return names;
}

void AnalyzeOptions::Check(const std::string& where) const {
  detect.Check(where);
  verify.Check(where);
  fit.Check(where);
  if (overlay_max_px < 0) {
    throw Error(where, fmt::format("overlay_max_px is {}", overlay_max_px), "give 0 (keep none) or a size in px");
  }
}

int AnalysisResult::UsedPhotos() const {
  int n = 0;
  for (const PhotoAnalysis& p : photos) n += p.used ? 1 : 0;
  return n;
}

int AnalysisResult::OverlaySource(size_t index) const {
  const PhotoAnalysis& p = photos.at(index);
  if (p.used) return static_cast<int>(index);
  return p.duplicate_of >= 0 && photos.at(static_cast<size_t>(p.duplicate_of)).used ? p.duplicate_of : -1;
}

namespace {

// A camera far from the viewpoint its pattern.json states: the verification judges the rendering as seen from
// the camera, so a photo from elsewhere does not test the correction for the stated viewpoint; 700 mm off is
// the wrong pattern.json, not a hand-held camera. Compared in the screen's centre frame (the fit's, and the
// nominal screen centre for the stated viewpoint); the limit is 10% of the viewing distance, at least 100 mm.
void AddPlausibilityWarnings(AnalysisResult& r) {
  const ModelFit& chosen = r.fit->Chosen();
  const Eigen::Vector3d centre = ScreenCentreInScreen(r.monitor);
  for (const PhotoAnalysis& p : r.photos) {
    if (p.fit_index < 0 || static_cast<size_t>(p.fit_index) >= chosen.cameras.size()) continue;
    const PatternFile& pattern = r.patterns[static_cast<size_t>(&p - r.photos.data())];
    const Eigen::Vector3d stated = pattern.viewpoint_in_screen - centre;
    const Eigen::Vector3d fitted = chosen.cameras[static_cast<size_t>(p.fit_index)].position_in_centre_mm;
    const double off = (fitted - stated).norm(), limit = std::max(100.0, 0.1 * stated.norm());
    if (off > limit) {
      r.fit->warnings.push_back(fmt::format(
          "{}: the camera was {:.0f} mm from the viewpoint its pattern.json states ({:.0f} mm from the screen "
          "centre; limit {:.0f} mm): the verification of this photo does not test the correction for the stated "
          "viewpoint. Is {} the pattern.json of this photo?",
          p.name, off, stated.norm(), limit, p.input.pattern.string()));
    }
  }
}

// The analysis with photos from `load` (which throws Error for a bad photo).
AnalysisResult AnalyzeWith(const CameraModel& camera, const std::filesystem::path& camera_path,
                           const std::vector<PhotoInput>& inputs, const std::function<cv::Mat(size_t)>& load,
                           const AnalyzeOptions& options) {
  const Stopwatch total_watch;
  options.Check("analyze options");
  if (inputs.empty()) throw Error("analyze", "no photos given", "give one or more photos with their pattern.json");
  AnalysisResult r;
  r.camera_path = camera_path;
  r.camera = camera;

  // Each pattern.json once; all must describe the same monitor (one screen model is fitted to all photos).
  std::map<std::filesystem::path, size_t> pattern_index;
  std::vector<PatternFile> distinct;
  std::vector<size_t> pattern_of_photo;
  for (const PhotoInput& in : inputs) {
    auto it = pattern_index.find(in.pattern);
    if (it == pattern_index.end()) {
      distinct.push_back(ReadPatternJson(in.pattern));
      it = pattern_index.emplace(in.pattern, distinct.size() - 1).first;
      if (!SameMonitor(distinct.front().monitor, distinct.back().monitor)) {
        throw Error(in.pattern.string(),
                    fmt::format("describes monitor '{}', but {} describes '{}'; one analysis fits one monitor",
                                distinct.back().monitor.name, inputs.front().pattern.string(),
                                distinct.front().monitor.name),
                    "analyse the photos of each monitor separately");
      }
    }
    pattern_of_photo.push_back(it->second);
  }
  r.monitor = distinct.front().monitor;
  for (size_t k : pattern_of_photo) r.patterns.push_back(distinct[k]);

  const std::vector<std::string> names = PhotoNames(inputs);
  std::vector<PhotoObservations> observations;
  std::map<std::string, size_t> content;  // hash of the decoded image (core/image_hash.h) -> first photo with it
  for (size_t i = 0; i < inputs.size(); ++i) {
    PhotoAnalysis pa;
    pa.input = inputs[i];
    pa.name = names[i];
    const PatternFile& pattern = r.patterns[i];
    Stopwatch watch;
    cv::Mat gray;
    try {
      gray = load(i);
    } catch (const Error& e) {
      pa.rejected = e.what();
      pa.rejection = PhotoRejection::kUnreadable;
    }
    pa.read_ms = watch.Ms();
    if (pa.rejected.empty() && (gray.cols != r.camera.width || gray.rows != r.camera.height)) {
      pa.rejection = PhotoRejection::kWrongSize;
      pa.rejected = fmt::format("{}: the photo is {} x {} px but the camera model {} is for {} x {} px; use the model "
                                "calibrated for this camera at this resolution",
                                inputs[i].photo.string(), gray.cols, gray.rows, camera_path.string(), r.camera.width,
                                r.camera.height);
    }
    if (pa.rejected.empty()) {
      // The same content twice (the same file given twice, or a copy) would count its features twice and shrink
      // every sigma by sqrt(2): used once.
      const auto [first, inserted] = content.emplace(HashImageContent(gray).Hex(), i);
      if (!inserted) {
        pa.rejection = PhotoRejection::kDuplicate;
        pa.duplicate_of = static_cast<int>(first->second);
        pa.rejected = fmt::format("{}: the same image content as {}; it is used once", inputs[i].photo.string(),
                                  inputs[first->second].photo.string());
      }
    }
    if (pa.rejected.empty()) {
      pa.detection = DetectFeatures(gray, pattern, options.detect);
      if (pa.detection.failure_kind != DetectionFailure::kNone) {
        pa.rejection = PhotoRejection::kDetection;
        pa.rejected = fmt::format("{}: {} ({} detector, pattern {})", inputs[i].photo.string(),
                                  pa.detection.failure, pa.detection.detector, inputs[i].pattern.string());
      }
    }
    if (pa.rejected.empty()) {
      std::vector<std::string> ids;
      std::vector<Eigen::Vector2d> px;
      for (const DetectedFeature& f : pa.detection.features) {
        if (!f.flag.empty()) continue;
        ids.push_back(f.id);
        px.push_back(f.px);
      }
      watch.Restart();
      pa.verification = VerifyCorrection(pattern, r.camera, ids, px, options.verify);
      pa.verify_ms = watch.Ms();
      if (pa.verification.failure_kind != VerificationFailure::kNone) {
        pa.rejection = PhotoRejection::kVerification;
        pa.rejected = fmt::format("{}: {}", inputs[i].photo.string(), pa.verification.failure);
      } else {
        pa.used = true;
        PhotoObservations obs = FitObservationsOf(pa, options);
        if (options.overlay_max_px > 0) {
          const auto [small, scale] = OverlayBase(gray, options.overlay_max_px);
          pa.overlay_gray = small;
          pa.overlay_scale = scale;
          pa.overlay_max_px = options.overlay_max_px;
        }
        pa.fit_ids = obs.ids;
        pa.fit_index = static_cast<int>(observations.size());
        observations.push_back(std::move(obs));
      }
    }
    r.photos.push_back(std::move(pa));
  }

  std::vector<Verification> verdicts;
  for (const PhotoAnalysis& p : r.photos) {
    if (p.used) verdicts.push_back(p.verification);
  }
  if (!verdicts.empty()) r.verification = CombineVerifications(verdicts, options.verify);

  if (!options.fit_screen) {
    r.fit_failure = "the screen fit was not requested";
    r.fit_failure_kind = FitFailure::kNotRequested;
  } else if (observations.empty()) {
    r.fit_failure = "no usable photo";
    r.fit_failure_kind = FitFailure::kNoUsablePhoto;
  } else {
    const Stopwatch fit_watch;
    // The fit's adequacy is tested against the detection noise the verification measured (the scatter about
    // a smooth field beyond each photo's homography: independent of any screen model), pooled over the photos
    // by their features.
    FitOptions fit_options = options.fit;
    // The lens calibration's covariance: given, or beside the camera model (read outside the fit's try: a bad
    // file is an input error, not a fit failure).
    const std::filesystem::path beside = camera_path.empty() ? std::filesystem::path() : IntrinsicsCovariancePathFor(camera_path);
    const std::filesystem::path cov_path = !options.lens_covariance.empty() ? options.lens_covariance : beside;
    if (!options.lens_covariance.empty() || (!beside.empty() && std::filesystem::exists(beside))) {
      ReadIntrinsicsCovariance(cov_path, r.camera).ApplyTo(&fit_options);
    } else if (!camera_path.empty()) {
      fit_options.lens_exact_note = fmt::format(
          "lens model taken as exact: no covariance beside {} ({} not found); calibrate with curvecheck calibrate "
          "to get one (for a synthetic photo rendered through this very model the lens is exact, and 0 is the truth)",
          camera_path.filename().string(), beside.filename().string());
    }
    if (fit_options.detection_noise_px == 0) {
      double sum = 0, weight = 0;
      for (const PhotoAnalysis& p : r.photos) {
        // The fit sees detections less their pixel-locking: its noise is the scatter without that term.
        const double noise = options.correct_pixel_locking && p.verification.pixel_locking.estimated
                                 ? p.verification.pixel_locking.noise_px
                                 : p.verification.noise_px;
        if (!p.used || !(noise > 0)) continue;
        sum += noise * noise * static_cast<double>(p.verification.features.size());
        weight += static_cast<double>(p.verification.features.size());
      }
      if (weight > 0) fit_options.detection_noise_px = std::sqrt(sum / weight);
    }
    try {
      r.fit = FitScreen(r.monitor, r.camera, observations, fit_options);
    } catch (const TooFewObservationsError& e) {
      r.fit_failure = e.what();
      r.fit_failure_kind = FitFailure::kTooFewFeatures;
      for (PhotoAnalysis& p : r.photos) p.fit_index = -1;
    } catch (const Error& e) {
      r.fit_failure = e.what();
      const bool too_few = std::any_of(observations.begin(), observations.end(), [&](const PhotoObservations& o) {
        return static_cast<int>(o.ids.size()) < options.fit.min_features_per_photo;
      });
      r.fit_failure_kind = too_few ? FitFailure::kTooFewFeatures : FitFailure::kSolver;
      for (PhotoAnalysis& p : r.photos) p.fit_index = -1;
    }
    r.fit_ms = fit_watch.Ms();
  }
  if (r.fit) AddPlausibilityWarnings(r);
  // An inadequate fit means the data do not fit what they claim to be (the wrong pattern.json, camera model or
  // screen model): no pass is stated on them.
  if (r.fit && r.fit->status == "inadequate" && r.verification.verdict == Verdict::kPass) {
    r.verification.verdict = Verdict::kInconclusive;
    r.verification.pass = false;
    r.verification.verdict_reason +=
        "; but the screen fit is inadequate (fit.warnings): the photos do not fit what their inputs claim, so no "
        "pass is stated";
  }
  r.total_ms = total_watch.Ms();
  return r;
}

}  // namespace

AnalysisResult Analyze(const std::filesystem::path& camera_path, const std::vector<PhotoInput>& inputs,
                       const AnalyzeOptions& options) {
  std::vector<GrayConversion> conversions(inputs.size());
  AnalysisResult r = AnalyzeWith(ReadCameraModel(camera_path), camera_path, inputs,
                                 [&](size_t i) { return ReadPhotoGray(inputs[i].photo, &conversions[i]); }, options);
  for (size_t i = 0; i < r.photos.size() && i < conversions.size(); ++i) {
    r.photos[i].gray_conversion = conversions[i];
    const std::string note = GrayConversionNote(conversions[i]);
    if (!note.empty()) r.photos[i].detection.notes.insert(r.photos[i].detection.notes.begin(), note);
  }
  return r;
}

PhotoObservations FitObservationsOf(const PhotoAnalysis& photo, const AnalyzeOptions& options) {
  PhotoObservations obs;
  obs.photo = photo.name;
  const RefinementNoise& random = photo.detection.refinement_noise;  // detect.h
  if (random.measured && random.corners > 0) {
    obs.random_error_px = random.response_px;
    obs.random_error_u_px = random.response_u_px;
    obs.random_error_samples = 2L * random.corners * random.draws;
  }
  for (const FeatureCheck& c : photo.verification.features) {
    obs.ids.push_back(c.id);
    obs.display_px.push_back(c.display_px);
    // Less the detector's pixel-locking bias the verification estimated, when asked to (AnalyzeOptions).
    obs.detected_px.push_back(options.correct_pixel_locking ? c.detected_px - c.pixel_locking_px : c.detected_px);
  }
  return obs;
}

AnalysisResult AnalyzeImages(const CameraModel& camera, const std::filesystem::path& camera_path,
                             const std::vector<PhotoInput>& inputs, const std::vector<cv::Mat>& images,
                             const AnalyzeOptions& options) {
  if (images.size() != inputs.size()) {
    throw Error("analyze", fmt::format("{} images for {} inputs", images.size(), inputs.size()));
  }
  return AnalyzeWith(camera, camera_path, inputs, [&](size_t i) { return images[i]; }, options);
}

std::string SummaryText(const AnalysisResult& r) {
  std::ostringstream s;
  const Verification& v = r.verification;
  if (r.UsedPhotos() == 0) {
    s << "verification: no usable photo\n";
  } else {
    s << fmt::format("verification: {} (e = {:.3f} display px, the 95th percentile of the correction error; U = "
                     "{:.3f} (95%); tolerance T = {:g}; T/U = {:.1f})\n",
                     v.failure.empty() ? std::string(VerdictLabel(v.verdict)) : std::string("NO VERDICT"),
                     v.error_p95_display_px, v.expanded_uncertainty_display_px, v.tolerance_display_px,
                     v.tolerance_ratio);
    if (!v.verdict_reason.empty()) s << "  " << v.verdict_reason << "\n";
    if (!v.advice.empty()) s << "  to decide: " << v.advice << "\n";
    s << fmt::format("  residuals: 95% within {:.3f} display px (noise and error together); RMS {:.3f} camera px, "
                     "{:.3f} display px, {:.3f} arcmin; noise {:.3f} camera px per coordinate; over {} photo(s)\n",
                     v.p95_display_px, v.rms_px, v.rms_display_px, v.rms_arcmin, v.noise_px, r.UsedPhotos());
  }
  if (r.fit) {
    const ModelFit& f = r.fit->Chosen();
    if (f.radius_mm) {
      s << fmt::format("radius: {:.1f} +- {:.1f} mm (1 sigma; 95% interval {:.1f} .. {:.1f} mm), model {}\n",
                       *f.radius_mm, f.radius_sigma_mm.value_or(0), f.radius_ci95_mm[0], f.radius_ci95_mm[1], f.model);
      if (f.budget.computed) {
        std::string rows;
        for (const BudgetComponent& c : f.budget.components) {
          rows += fmt::format("{}{} {:.2f}", rows.empty() ? "" : ", ", c.name, c.radius_mm);
        }
        s << fmt::format("  uncertainty budget: combined sigma {:.2f} mm, dominated by {} ({} mm; coverage factor "
                         "{:.3f})\n",
                         f.budget.combined.radius_mm, f.budget.dominant, rows, f.budget.coverage_factor);
      }
    } else {
      s << (f.ill_conditioned
                ? fmt::format("radius: not determined by these photos (ill-conditioned fit; |R| is above {:.0f} mm "
                              "with 95% confidence, no upper bound), model {}; take more photos from other positions "
                              "(closer, and from the sides)\n",
                              f.radius_lower_bound_mm, f.model)
                : fmt::format("radius: not measurable as a number; flat is consistent (95% lower bound {:.0f} mm), "
                              "model {}\n",
                              f.radius_lower_bound_mm, f.model));
    }
    for (const std::string& w : r.fit->warnings) s << "warning: " << w << "\n";
    s << "model choice: " << r.fit->choice_reason << "\n";
    for (const auto& [name, value] : f.extra) {
      s << fmt::format("  {} = {:.4g} +- {:.2g}\n", name, value.first, value.second);
    }
    s << fmt::format("fit: RMS {:.3f} px, noise {:.3f} px per coordinate; status {}\n", f.rms_px, r.fit->noise_px,
                     r.fit->status);
    s << fmt::format("adequacy (against the detection noise {:.3f} px{}; inadequate beyond {:.3f} px with p < 1e-3):",
                     r.fit->detection_noise_px, r.fit->detection_noise_assumed ? ", assumed" : ", measured",
                     r.fit->adequacy_limit_px);
    for (const ModelFit& c : r.fit->candidates) {
      s << fmt::format(" {} {} (noise {:.3f} px, chi2/dof {:.2f}, p {:.2g});", c.model,
                       c.adequate ? "adequate" : "INADEQUATE", c.noise_px, c.dof > 0 ? c.chi2 / c.dof : 0.0,
                       c.chi2_p_value);
    }
    s << "\n";
  } else {
    s << "fit: none (" << r.fit_failure << ")\n";
  }
  for (const PhotoAnalysis& p : r.photos) {
    if (!p.used) s << "rejected: " << p.rejected << "\n";
  }
  return s.str();
}

}  // namespace curvecheck
