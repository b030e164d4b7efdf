#include "experiments/trial_outcome.h"

#include <iterator>

namespace curvecheck::experiments {
namespace {

struct OutcomeInfo {
  TrialOutcome outcome;
  const char* name;
  char letter;
};

// The one table of names and letters.
constexpr OutcomeInfo kOutcomes[] = {
    {TrialOutcome::kOk, "", '.'},
    {TrialOutcome::kRenderRefused, "render_refused", 'R'},
    {TrialOutcome::kNotFound, "not_found", 'N'},
    {TrialOutcome::kAmbiguousOrientation, "ambiguous_orientation", 'A'},
    {TrialOutcome::kAmbiguousIds, "ambiguous_ids", 'A'},
    {TrialOutcome::kTooFewFeatures, "too_few_features", 'T'},
    {TrialOutcome::kRejected, "rejected", 'X'},
    {TrialOutcome::kVerificationFailed, "verification_failed", 'V'},
    {TrialOutcome::kVerificationInconclusive, "verification_inconclusive", 'U'},
    {TrialOutcome::kFitFailed, "fit_failed", 'F'},
    {TrialOutcome::kFitIllConditioned, "fit_ill_conditioned", 'I'},
    {TrialOutcome::kError, "error", 'E'},
};

const OutcomeInfo& Info(TrialOutcome outcome) {
  for (const OutcomeInfo& i : kOutcomes) {
    if (i.outcome == outcome) return i;
  }
  return kOutcomes[std::size(kOutcomes) - 1];
}

}  // namespace

const char* TrialOutcomeName(TrialOutcome outcome) { return Info(outcome).name; }

char TrialOutcomeLetter(TrialOutcome outcome) { return Info(outcome).letter; }

TrialOutcome ParseTrialOutcome(const std::string& name) {
  if (name.empty() || name == "ok") return TrialOutcome::kOk;
  for (const OutcomeInfo& i : kOutcomes) {
    if (name == i.name) return i.outcome;
  }
  return TrialOutcome::kError;
}

std::vector<TrialOutcome> FailureOutcomes() {
  std::vector<TrialOutcome> out;
  for (const OutcomeInfo& i : kOutcomes) {
    if (i.outcome != TrialOutcome::kOk) out.push_back(i.outcome);
  }
  return out;
}

TrialOutcome OutcomeOfRejection(const PhotoAnalysis& photo) {
  switch (photo.rejection) {
    case PhotoRejection::kNone:
      return TrialOutcome::kOk;
    case PhotoRejection::kDetection:
      switch (photo.detection.failure_kind) {
        case DetectionFailure::kPatternNotFound:
          return TrialOutcome::kNotFound;
        case DetectionFailure::kAmbiguousOrientation:
          return TrialOutcome::kAmbiguousOrientation;
        case DetectionFailure::kDifferentPattern:
          return TrialOutcome::kAmbiguousIds;
        case DetectionFailure::kMirrored:
          // The synthetic camera never mirrors: in a trial this is the orientation rule naming a board mirrored
          // (e.g. a 16 x 5 board photographed upside down, detect.h), an orientation outcome.
          return TrialOutcome::kAmbiguousOrientation;
        case DetectionFailure::kNone:
          break;
      }
      return TrialOutcome::kRejected;
    case PhotoRejection::kVerification:
      return photo.verification.failure_kind == VerificationFailure::kTooFewFeatures
                 ? TrialOutcome::kTooFewFeatures
                 : TrialOutcome::kRejected;
    case PhotoRejection::kUnreadable:
    case PhotoRejection::kWrongSize:
    case PhotoRejection::kDuplicate:
      return TrialOutcome::kRejected;
  }
  return TrialOutcome::kRejected;
}

TrialOutcome OutcomeOfFitFailure(FitFailure failure) {
  switch (failure) {
    case FitFailure::kNone:
      return TrialOutcome::kOk;
    case FitFailure::kTooFewFeatures:
      return TrialOutcome::kTooFewFeatures;
    case FitFailure::kNotRequested:
    case FitFailure::kNoUsablePhoto:
    case FitFailure::kSolver:
      return TrialOutcome::kFitFailed;
  }
  return TrialOutcome::kFitFailed;
}

}  // namespace curvecheck::experiments
