// The outcome categories: the names and letters that sweep.csv and its maps carry (unchanged since issue 7),
// and the mapping from the libraries' typed outcomes. Proves the mapping case by case; does not run a trial.
#include "experiments/trial_outcome.h"

#include <gtest/gtest.h>

namespace curvecheck::experiments {
namespace {

TEST(TrialOutcome, NamesAndLettersAreSweepCsvs) {
  std::vector<std::string> names;
  std::string letters;
  for (TrialOutcome o : FailureOutcomes()) {
    names.emplace_back(TrialOutcomeName(o));
    letters += TrialOutcomeLetter(o);
    EXPECT_EQ(ParseTrialOutcome(TrialOutcomeName(o)), o);
  }
  EXPECT_EQ(names,
            (std::vector<std::string>{"render_refused", "not_found", "ambiguous_orientation", "ambiguous_ids",
                                      "too_few_features", "rejected", "verification_failed", "verification_inconclusive", "fit_failed",
                                      "fit_ill_conditioned", "error"}));
  EXPECT_EQ(letters, "RNAATXVUFIE");
  EXPECT_STREQ(TrialOutcomeName(TrialOutcome::kOk), "");
  EXPECT_EQ(TrialOutcomeLetter(TrialOutcome::kOk), '.');
  EXPECT_EQ(ParseTrialOutcome("ok"), TrialOutcome::kOk);
  EXPECT_EQ(ParseTrialOutcome(""), TrialOutcome::kOk);
  EXPECT_EQ(ParseTrialOutcome("something else"), TrialOutcome::kError);
}

PhotoAnalysis Rejected(PhotoRejection why) {
  PhotoAnalysis p;
  p.rejection = why;
  p.rejected = "prose that the mapping must not read: pattern not found, only 3 usable features";
  return p;
}

TEST(TrialOutcome, RejectionsMapFromTheTypedKinds) {
  PhotoAnalysis p = Rejected(PhotoRejection::kDetection);
  p.detection.failure_kind = DetectionFailure::kPatternNotFound;
  EXPECT_EQ(OutcomeOfRejection(p), TrialOutcome::kNotFound);
  p.detection.failure_kind = DetectionFailure::kAmbiguousOrientation;
  EXPECT_EQ(OutcomeOfRejection(p), TrialOutcome::kAmbiguousOrientation);
  p.detection.failure_kind = DetectionFailure::kDifferentPattern;
  EXPECT_EQ(OutcomeOfRejection(p), TrialOutcome::kAmbiguousIds);
  p.detection.failure_kind = DetectionFailure::kMirrored;
  EXPECT_EQ(OutcomeOfRejection(p), TrialOutcome::kAmbiguousOrientation);
  p = Rejected(PhotoRejection::kVerification);
  p.verification.failure_kind = VerificationFailure::kTooFewFeatures;
  EXPECT_EQ(OutcomeOfRejection(p), TrialOutcome::kTooFewFeatures);
  for (VerificationFailure v : {VerificationFailure::kLensMismatch, VerificationFailure::kDegenerate}) {
    p.verification.failure_kind = v;
    EXPECT_EQ(OutcomeOfRejection(p), TrialOutcome::kRejected);
  }
  EXPECT_EQ(OutcomeOfRejection(Rejected(PhotoRejection::kUnreadable)), TrialOutcome::kRejected);
  EXPECT_EQ(OutcomeOfRejection(Rejected(PhotoRejection::kWrongSize)), TrialOutcome::kRejected);
}

TEST(TrialOutcome, FitFailuresMapFromTheTypedKind) {
  EXPECT_EQ(OutcomeOfFitFailure(FitFailure::kTooFewFeatures), TrialOutcome::kTooFewFeatures);
  EXPECT_EQ(OutcomeOfFitFailure(FitFailure::kSolver), TrialOutcome::kFitFailed);
  EXPECT_EQ(OutcomeOfFitFailure(FitFailure::kNone), TrialOutcome::kOk);
}

}  // namespace
}  // namespace curvecheck::experiments
