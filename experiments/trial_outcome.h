// The outcome of one synthetic trial (render -> photograph -> analyse) as a closed set of categories, derived
// from the typed outcomes of the libraries (DetectionFailure, VerificationFailure, PhotoRejection,
// FitFailure), never from their prose. The names are sweep.csv's `reason` column: tests and users read them,
// so they do not change.
#pragma once

#include <string>
#include <vector>

#include "analysis/pipeline.h"

namespace curvecheck::experiments {

// In pipeline order; a trial gets the first that applies.
enum class TrialOutcome {
  kOk,
  kRenderRefused,  // render_refused: the correction method refused this view, or the pattern does not fit
  kNotFound,       // not_found: the detector found no pattern in the photo
  kAmbiguousOrientation,  // ambiguous_orientation: the board was found but its orientation is ambiguous
  kAmbiguousIds,          // ambiguous_ids: tags/ids that are not in pattern.json
  kTooFewFeatures,        // too_few_features: too few features for a verdict or a fit
  kRejected,              // rejected: the photo was rejected for another reason
  kVerificationFailed,    // verification_failed: the verdict is fail (e - U beyond the tolerance, display px)
  kVerificationInconclusive,  // verification_inconclusive: e within U of the tolerance, or a pass the guards refused
  kFitFailed,             // fit_failed: the screen fit threw or did not converge
  kFitIllConditioned,     // fit_ill_conditioned: the cylinder fit ran but the radius is not observable
  kError,                 // error: anything else
};

// The category's name in sweep.csv: "" for kOk, else e.g. "not_found" (the comments above).
const char* TrialOutcomeName(TrialOutcome outcome);
// One letter for maps: render_refused R, not_found N, ambiguous_* A, too_few_features T, rejected X,
// verification_failed V, verification_inconclusive U, fit_failed F, fit_ill_conditioned I, error E; '.' for kOk.
char TrialOutcomeLetter(TrialOutcome outcome);
// The category of a name read back from sweep.csv: "" and "ok" give kOk, an unknown name kError.
TrialOutcome ParseTrialOutcome(const std::string& name);
// Every category but kOk, in pipeline order.
std::vector<TrialOutcome> FailureOutcomes();

// Why a photo was not used (photo.used false): from PhotoAnalysis::rejection and the detection's or the
// verification's own kind.
TrialOutcome OutcomeOfRejection(const PhotoAnalysis& photo);
// Why there is no screen fit of a used photo (AnalysisResult::fit_failure_kind).
TrialOutcome OutcomeOfFitFailure(FitFailure failure);

}  // namespace curvecheck::experiments
