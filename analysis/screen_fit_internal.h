// Internal to the screen fit (analysis/screen_fit*.cc; the interface is analysis/screen_fit.h): the observations,
// the parameters and the Ceres problem of one candidate model, the uncertainty budget's linearization, and the
// functions that the fit's files share. Not installed, not included outside analysis/screen_fit*.cc.
//   screen_fit.cc          FitScreen: the candidates' robust and final fits, radius, adequacy, deviations, warnings
//   screen_fit_problem.cc  the Ceres problem: cost functions, solve, residuals, initial poses, covariances
//   screen_fit_linearize.cc the final fit's linearization (the Jacobian, the normal matrix's pseudo-inverse, G)
//   screen_fit_budget.cc   the uncertainty budget: the propagation of each source through the linearization
//   screen_fit_misfit.cc   the lens-model-misfit row: the misfit field measured from the residuals' correlation
//   screen_fit_select.cc   model selection: held-out error, the lens-field adjustment, the choice
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <array>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "analysis/screen_fit.h"
#include "analysis/screen_fit_cost.h"
#include "analysis/screen_model.h"
#include "core/camera_model.h"
#include "core/monitor.h"

namespace curvecheck::screen_fit_internal {

inline constexpr double kZ95 = 1.959963984540054;
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr double kInf = std::numeric_limits<double>::infinity();

using PoseBlock = std::array<double, 7>;  // quaternion x y z w (centre_from_cam), camera position in the centre frame

struct Obs {
  int photo = 0, index = 0;  // photo and index in it
  int feature = 0;           // index of the feature id among all ids
  Eigen::Vector2d uv, detected;
  double s_mm = 0, y_mm = 0;
};

// All parameters of one model: poses and shape.
struct State {
  std::vector<PoseBlock> poses;
  std::vector<double> core;  // CoreParameterCount
  std::vector<double> dev;   // deviation coefficients (cylinder+deviation)
  std::vector<double> intr;  // the lens intrinsics when they are free (FitOptions::fit_intrinsics), else empty
};

struct SignatureLayout;  // below: the pixel-locking signature's columns

struct Setup {
  const Monitor* nominal = nullptr;
  const CameraModel* camera = nullptr;
  // camera's projector, shared by the cost functions; MakeCost uses it only while it belongs to `camera` (a copy
  // of the setup with another camera, as the lens-calibration row makes, gets a projector of its own).
  std::optional<PointProjector> projector;
  const FitOptions* options = nullptr;
  int photos = 0;
  std::vector<Obs> obs;
  std::vector<std::string> feature_ids;
  double half_width_mm = 0;
  // The photos' random detection error pooled (PhotoObservations::random_error_px, its square weighted by their
  // samples; 0 samples: no photo measured it), and the standard uncertainty of its square (px^2; the photos' own
  // through the same weights).
  double random_error_px = 0;
  double random_error_u_px2 = 0;
  long random_error_samples = 0;
  // What depends only on the observations, computed on first use and shared by copies of the setup (same
  // observations): the lens-model-misfit row's feature spacing (screen_fit_misfit.cc FeatureSpacing: the median
  // distance to the nearest neighbour in the same photo, the unit of its candidate lengths), and the smooth bound's
  // lattice triples (screen_fit_smooth_bound.cc WhiteScatterPx), one set per set of active observations (every
  // candidate model usually fits the same ones).
  struct LatticeTriples {
    std::vector<size_t> obs;                      // Setup::obs indices the triples were found among
    std::vector<std::array<size_t, 3>> triples;   // Setup::obs indices j, i, k: the stencil 1, -2, 1
    double overlap = 0;                           // Q = sum over pairs of triples of (a_t . a_t')^2
  };
  struct Cache {
    double spacing_px = 0;  // written outside the parallel loops (MeasureMisfitCorrelation), read within them
    std::mutex mutex;       // guards `triples` and `layouts` (the candidates' budgets run in parallel)
    std::vector<std::shared_ptr<const LatticeTriples>> triples;
    // The pixel-locking signature's layout (SignatureLayoutOf), per set of active observations (lin.obs).
    std::vector<std::pair<std::vector<size_t>, std::shared_ptr<const SignatureLayout>>> layouts;
  };
  std::shared_ptr<Cache> cache = std::make_shared<Cache>();
};

// The problem of one model over the active observations. Owns what Ceres does not.
struct BuiltProblem {
  std::unique_ptr<ceres::Problem> problem;
  std::unique_ptr<ceres::LossFunction> loss;
  std::unique_ptr<ceres::Manifold> pose_manifold;
  // The residual blocks in the order added: one per active observation (obs_index: its index in Setup::obs),
  // then the deviation prior (if any). The uncertainty budget's Jacobian rows follow this order.
  std::vector<ceres::ResidualBlockId> blocks;
  std::vector<size_t> obs_index;
};

// One candidate's residuals against the lens-model-misfit family (FitOptions::misfit_field_degree), after the
// linearized refit of its own parameters: B~ = (I - J (J^T J)^+ J^T) B over the inliers' stacked coordinates.
// gram = B~^T B~, projected = B~^T r, rss = r^T r, basis_trace = trace(B^T B) of the unprojected fields (per
// coordinate), observations = inliers. Empty (observations 0) when the misfit was not measured.
struct LensFieldProjection {
  Eigen::MatrixXd gram;
  Eigen::VectorXd projected;
  double rss = 0, basis_trace = 0;
  int observations = 0;
};

// ---- The uncertainty budget (metrology.md section 1; UncertaintyBudget in screen_fit.h). ----
//
// Every source is propagated to the same quantities of interest q = (k, c_1, ..., c_P): the curvature (the mean
// curvature for varying curvature, as reported) and each photo's camera position in the centre frame. A source
// that perturbs the residuals by dr moves the least-squares solution by d(theta) = -(J^T J)^+ J^T dr (the fit's
// linearization at its solution; J in Ceres's tangent space, deviation prior rows included and unperturbed), so
// dq = -G dr with G the rows of the pseudo-inverse of J that belong to q. Each source gives a covariance of q;
// what is kept of it is var(k) and, per photo, var(c) (diagonal) and cov(c, k): all that the radius, its interval
// and the axis-frame position (z - 1/k) need.
struct QuantityVariance {
  double var_k = 0;
  std::vector<Eigen::Vector3d> var_pos, cov_pos_k;
  // A sampled row's error distribution (RowDistribution::kSampled): StatedFieldDraws's, for k, the first camera's
  // centre-frame x, y, z and its axis-frame z. Not summed into the combined row.
  std::vector<std::vector<double>> draws;

  explicit QuantityVariance(int photos)
      : var_pos(static_cast<size_t>(photos), Eigen::Vector3d::Zero()),
        cov_pos_k(static_cast<size_t>(photos), Eigen::Vector3d::Zero()) {}
  // From a full covariance of q (1 + 3 P rows, as above).
  static QuantityVariance FromCovariance(const Eigen::MatrixXd& c, int photos) {
    QuantityVariance v(photos);
    v.var_k = c(0, 0);
    for (int p = 0; p < photos; ++p) {
      for (int a = 0; a < 3; ++a) {
        v.var_pos[static_cast<size_t>(p)][a] = c(1 + 3 * p + a, 1 + 3 * p + a);
        v.cov_pos_k[static_cast<size_t>(p)][a] = c(1 + 3 * p + a, 0);
      }
    }
    return v;
  }
};

// The linearization of the final fit: G (rows of q, columns the residuals of the active observations, two per
// observation in BuiltProblem order) and the active observations' indices.
struct Linearization {
  Eigen::MatrixXd g;             // (1 + 3 P) x (2 n_obs)
  std::vector<size_t> obs;       // Setup::obs index of each column pair
  Eigen::MatrixXd j_obs;         // (2 n_obs) x t: the observations' rows of J (tangent space)
  // The structure of j_obs: runs of consecutive rows of one photo, whose non-zeros lie in that photo's pose columns
  // (6 from `pose_col`) and the shared columns (from `shared_col`: the shape, the deviation field, free intrinsics).
  // Products with J go run by run on these dense blocks (JTimes, JtTimes): at ten photos J is ~85% zeros.
  struct Run { long row, rows, pose_col; };
  std::vector<Run> runs;
  long shared_col = 0;
  Eigen::MatrixXd normal_pinv;   // (J^T J)^+, t x t
  Eigen::MatrixXd sel_pinv;      // sel (J^T J)^+, (1 + 3 P) x t: G = sel_pinv J^T
  Eigen::MatrixXd normal;        // J^T J over every row (deviation prior included), t x t
  Eigen::VectorXd gradient;      // J^T e at the solution (e: Ceres's residuals, all rows), t
  // Where each parameter block's tangent columns start (-1: a pose not in the problem, or a block that is empty).
  std::vector<int> pose_offset;  // per photo: rotation (3), then the position (3)
  int core_offset = -1, dev_offset = -1, intr_offset = -1;
  int dropped_directions = 0;  // directions of the equilibrated J^T J cut from the pseudo-inverse (rank deficiency)
};

// The tags whose four corners were all fitted: per tag (photo, tag id) the positions in lin.obs of its corners 0-3
// ("t<id>.<k>", pattern.h: the corners of a tag36h11 tag's black border); none when fewer than kMinBorderTags such
// tags (the border shift's two columns are then not fitted).
inline constexpr int kMinBorderTags = 4;
using TagCorners = std::vector<std::array<int, 4>>;
// The checkerboard corners' polarity, per position in lin.obs: +1 or -1 by the parity of the corner's row + column
// on the board, 0 for features that are not checkerboard corners; empty when the board's layout could not be read
// (fewer than kMinPolarityCorners checkerboard corners, or no consistent row stride). A checkerboard's inner corners
// alternate between two mirror-image saddles (the dark squares top-left and bottom-right, or top-right and
// bottom-left), and a detector's error on a corner that is not symmetric under that mirror (a demosaicing's
// response to the colour filter array, a sensor's tone curve) changes sign with the polarity. The ids ("c<k>", k =
// row x stride + column, pattern.h) do not carry the stride (the board's columns - 1): it is the Delta k to each
// corner's nearest neighbour on the screen other than its row neighbours (|Delta k| = 1), the most common such value
// over the corners of every photo, kept when it is at least half of them.
inline constexpr int kMinPolarityCorners = 16;
// The signature's columns (PixelLockingShapes, S, 2n rows interleaved x, y), in this order:
//   own phase    4 kPixelLockingTerms: per coordinate c and period T (kPixelLockingPeriods) sin and cos of 2 pi x the
//                phase of c in T (PixelLockingColumn), on c's rows
//   tag border   kTagBorderColumns where there are tags (CompleteTags): the border shift in x and y (kTagBorderX)
//   cell         kCellColumns: per coordinate c (6 each, from CellColumn(c)), on c's rows, the 2 px period's
//                phases' cross terms: sin, cos of the other coordinate's phase, then sx sy, sx cy, cx sy, cx cy
//                (s, c the sin and cos of the x and y phases): with the own-phase ones, every function of the
//                position within a colour filter array's 2 x 2 cell to first order in each coordinate
//   polarity     kPolarityColumns where the polarity is known (CheckerboardPolarity): per coordinate c (5 each, from
//                PolarityColumn(c)), on c's rows, the polarity p times 1, sx, cx, sy, cy
// Every coefficient but the border shift's has the prior N(0, FitOptions::pixel_locking_prior_px^2).
struct SignatureLayout {
  TagCorners tags;
  std::vector<int> polarity;
  long CellBegin() const { return kTagBorderX + (tags.empty() ? 0 : kTagBorderColumns); }
  long CellColumn(int c) const { return CellBegin() + 6L * c; }
  long PolarityBegin() const { return CellBegin() + kCellColumns; }
  long PolarityColumn(int c) const { return PolarityBegin() + 5L * c; }
  long Columns() const { return PolarityBegin() + (polarity.empty() ? 0 : kPolarityColumns); }
  static inline constexpr long kTagBorderX = 4 * kPixelLockingTerms;
  static inline constexpr long kTagBorderColumns = 2;
  static inline constexpr long kCellColumns = 12;
  static inline constexpr long kPolarityColumns = 10;
};

// The pixel-locking signature fitted once per candidate (Budget; ModelWork::signature): the coefficients b of the
// shapes S (PixelLockingShapes) fitted to the residuals on the shapes' refit projections P S
// (P = I - J (J^T J)^+ J^T) with the prior N(0, sigma_b^2 I) (FitOptions::pixel_locking_prior_px): the posterior
// b = (A + lambda I)^-1 (P S)^T r and covariance C = s^2 (A + lambda I)^-1, A = S^T P S, lambda = s^2 / sigma_b^2,
// s^2 the regression's residual variance over dof = 2n - parameters - S's columns (noise_px = s: the
// independent noise); and the residuals less the fitted P S b (the misfit statistics take these). Without a
// prior (pixel_locking_prior_px = 0) lambda = 0. ok = false (and residual_without the residuals) when the
// residuals are not finite, dof < 2, or, without a prior, a shape is absorbed whole (its projection below 1e-9 n)
// or two are nearly collinear.
// Regressing on the unprojected shapes (until 2026-12-05) recovered only the part the fit left: 0.043 px where the
// projected fit gives 0.053 px (median over both coordinates of 180 frontal trials from 3 m at quarter resolution;
// period 1 alone).
struct PixelLockingSignature {
  bool ok = false;
  int observations = 0, dof = 0;
  SignatureLayout layout;        // S's columns
  Eigen::MatrixXd shapes;        // S, 2n x layout.Columns()
  Eigen::MatrixXd projected;     // P S
  Eigen::MatrixXd normal;        // A = (P S)^T P S
  Eigen::VectorXd coefficients;  // b, in S's column order
  Eigen::MatrixXd covariance;    // C
  Eigen::MatrixXd solve;         // M = (A + lambda I)^-1 (P S)^T, layout.Columns() x 2n: b = M r
  double noise_px = std::numeric_limits<double>::quiet_NaN();
  std::vector<Eigen::Vector2d> residual_without;
};

// The correction of q = (k, c_1, ..., c_P) for the fitted signature, dq = -G S b, and its covariance
// (G S) C (G S)^T (QuantityVariance's q and G). The corrected q answers a perturbation dr of the detections by
// (G - G S M) dr, not G dr: b moves by M dr. Every row that propagates a perturbation through G takes that part
// off (Response). Measured small for smooth fields: on a frontal board from near 3 m at quarter resolution, where
// the shapes' projections are smoothest, degree-3 Legendre fields move the corrected radius by 3.17 mm RMS and the
// uncorrected one by 3.21 mm (UncertaintyBudgetTest.SmoothRowFollowsTheCorrectedEstimateWhereTheSignatureIsSmooth).
struct PixelLockingCorrection {
  bool ok = false;
  Eigen::VectorXd dq;
  Eigen::MatrixXd covariance;
  Eigen::MatrixXd gs;     // G S, (1 + 3 P) x the signature's columns
  Eigen::MatrixXd solve;  // M (PixelLockingSignature::solve)
  // G x - G S M x for perturbations x (2n x m, interleaved x, y), given gx = G x.
  Eigen::MatrixXd Response(const Eigen::MatrixXd& gx, const Eigen::MatrixXd& x) const;
  // The same for a field on coordinate c's rows only: x's rows 2i + c = field's row i, the others 0.
  Eigen::MatrixXd Response(const Eigen::MatrixXd& gx, const Eigen::MatrixXd& field, int c) const;
  // M's columns of coordinate c (the signature's columns x n): M x for such a field is SolveColumns(c) field.
  Eigen::MatrixXd SolveColumns(int c) const;
};

// Everything about one model's fit that the selection and the deviations need beyond ModelFit.
struct ModelWork {
  ScreenModelKind kind;
  State state;
  std::unique_ptr<DeviationBasis> basis;
  double basis_curvature_per_mm = 0;  // what `basis` was built around
  std::vector<Eigen::Vector2d> robust_residuals;
  Eigen::MatrixXd dev_covariance;  // of the deviation coefficients, scaled by the noise
  // Per photo: the covariance of the camera position (centre frame) with the curvature k (the mean curvature for
  // varying curvature), scaled by the noise; NaN where it could not be computed.
  std::vector<Eigen::Vector3d> position_curvature_cov;
  bool robust_ok = false;
  int robust_iterations = 0;
  LensFieldProjection lens_field;
  // The final fit's linearization and its budget's rows (Budget), the lens-model-misfit row's variance added and
  // the rows combined by CompleteBudget once the model is chosen.
  std::optional<Linearization> lin;
  std::vector<QuantityVariance> budget_vars;
  PixelLockingSignature signature;    // Budget's, on the final fit's residuals
  PixelLockingCorrection correction;  // Budget's, from `signature`
};

// screen_fit_problem.cc: one candidate's Ceres problem.
std::unique_ptr<ReprojectionCost> MakeCost(const Setup& setup, ScreenModelKind kind, const DeviationBasis* basis,
                                           const Obs& o);
std::vector<const double*> Blocks(const State& st, int photo);
BuiltProblem Build(const Setup& setup, ScreenModelKind kind, const DeviationBasis* basis,
                   const std::vector<bool>& active, bool robust, State* st);
ceres::Solver::Summary Solve(const Setup& setup, BuiltProblem& b, State* st);
std::vector<Eigen::Vector2d> Residuals(const Setup& setup, ScreenModelKind kind, const DeviationBasis* basis,
                                       const State& st);
double MadSigma(const std::vector<Eigen::Vector2d>& r);
PoseBlock InitialPose(const Setup& setup, int photo);
void Covariances(const Setup& setup, ModelWork& w, ModelFit* fit);

// screen_fit_linearize.cc: the final fit's linearization.
std::optional<Linearization> Linearize(const Setup& setup, const ModelWork& w, BuiltProblem& b, std::string* note);
Eigen::MatrixXd JTimes(const Linearization& lin, const Eigen::MatrixXd& y);   // j_obs y
Eigen::MatrixXd JtTimes(const Linearization& lin, const Eigen::MatrixXd& x);  // j_obs^T x
// screen_fit_budget.cc: the uncertainty budget.
std::vector<Eigen::Vector2d> DetectedPoints(const Setup& setup, const Linearization& lin);
TagCorners CompleteTags(const Setup& setup, const Linearization& lin);
std::vector<int> CheckerboardPolarity(const Setup& setup, const Linearization& lin);
// Found once per set of active observations (Setup::Cache::layouts): it depends on nothing else.
SignatureLayout SignatureLayoutOf(const Setup& setup, const Linearization& lin);
// residual: the fit's (2n, interleaved x, y; detected - predicted), the phases taken at the prediction.
Eigen::MatrixXd PixelLockingShapes(const Setup& setup, const Linearization& lin, const Eigen::VectorXd& residual,
                                   const SignatureLayout& layout);
// The column of the sin shape of coordinate c in period kPixelLockingPeriods[t] (the cos shape is the next).
inline long PixelLockingColumn(int c, int t) { return 2 * (kPixelLockingTerms * c + t); }
// The tag border shift's columns (SignatureLayout::kTagBorderX, after the own-phase ones): x, then y. Their
// coefficients' prior is N(0, kTagBorderPriorPx^2) each (type B: a tag's border one cell wide, blurred by the
// camera, is placed within about a pixel); the photos determine them far more tightly wherever there are tags.
inline constexpr double kTagBorderPriorPx = 1.0;
// Residuals (one Vector2d per observation) as one vector, interleaved x, y.
Eigen::VectorXd Stacked(const std::vector<Eigen::Vector2d>& residual);
PixelLockingSignature FitPixelLocking(const Setup& setup, const Linearization& lin,
                                      const std::vector<Eigen::Vector2d>& residual_px, int parameters);
// Per coordinate and period the amplitude sqrt(a^2 + b^2) and its standard uncertainty (delta method along the
// estimate's direction; near zero amplitude the coefficients' RMS sigma); NaN when !ok.
ResidualPixelLocking PixelLockingAmplitudes(const PixelLockingSignature& signature);
PixelLockingCorrection CorrectionFor(const Linearization& lin, const PixelLockingSignature& signature);
// The fit's independent detection noise per coordinate: its residual noise without the pixel-locking signature
// (budget.pixel_locking.noise_px) once Budget has measured it, else noise_px.
double IndependentNoisePx(const ModelFit& fit);
// The detector-systematic row's smooth bound b from the scatter s (its dof) and the detections' random part r
// (the standard uncertainty of r^2 given: random_u_px2): random errors move each corner alone and leave no smooth
// error, so b^2 = max(0, s^2 - r^2) + 1.645 u, u^2 = 2 s^4 / dof + random_u_px2^2 (the two mean squares'
// variances; s^2's for normal errors), a one-sided 95% upper bound on the deterministic part's mean square; b at
// most s.
struct SmoothBound {
  double bound_px = 0;
  double difference_px2 = 0;  // max(0, s^2 - r^2)
  double margin_px2 = 0;      // 1.645 u
};
SmoothBound SmoothBoundPx(double scatter_px, double scatter_dof, double random_px, double random_u_px2);
// The same from a non-smooth part and the standard uncertainty of s^2 less its square (px^2):
// b^2 = max(0, s^2 - part^2) + 1.645 u, at most s.
SmoothBound SmoothBoundFromPart(double scatter_px, double part_px, double u_difference_px2);
// The part of the residuals' scatter that neighbouring features do not share, from second differences along the
// pattern's lattice: in each photo, every feature i and two of its kWhiteNeighbours nearest on the screen (mm), j and
// k on either side (x_j + x_k = 2 x_i within a tenth of the step), the shortest such step in each direction and
// none over 1.5 times i's shortest, gives d = r_j - 2 r_i + r_k per coordinate (along a checkerboard's rows,
// columns and diagonals; between the same corners of neighbouring tags), and
// white^2 = sum d^2 / (6 x their count): an error independent from feature to feature contributes 6 x its variance to
// each d, a smooth one (a field over many features: a bias field, the lens's misfit, a moire's beat longer than the
// lattice step) almost nothing (its second difference). u_difference_px2 is the standard uncertainty of
// s^2 - white^2 were every error white (s^2 = sum r^2 / dof over all residuals): e^T M e with M = I / dof -
// sum_d a_d a_d^T / (12 T) (T triples, both coordinates), var = 2 s^4 tr(M^2), s^2's own term taken as exact
// (2 s^4 / dof) and the overlapping stencils counted exactly. The fit absorbs next to nothing of a second
// difference (its columns are smooth), but the fitted signature `removed` (when given and ok) does: its shapes
// change from corner to corner (phases, polarity). white^2 is divided by the share of a white error's second
// differences that survives its removal, 1 - (2 tr X K X^T - tr X K A K X^T) / (12 T), X = D P S the projected
// shapes' second differences, K = C / s^2, A = (P S)^T P S (with 8 shapes of 558 residuals, a share of 8 / 558 took
// the mean of s^2 - white^2 over 24 seeds of white noise from +1.4% of s^2 to -0.007%; UncertaintyBudgetTest.
// SmoothBiasBoundsWhatNeighboursShare). triples = 0 when fewer than kMinWhiteTriples were found.
struct NeighbourScatter {
  double white_px = std::numeric_limits<double>::quiet_NaN();
  double u_difference_px2 = std::numeric_limits<double>::quiet_NaN();
  int triples = 0;
};
inline constexpr int kMinWhiteTriples = 24;
inline constexpr size_t kWhiteNeighbours = 24;
NeighbourScatter WhiteScatterPx(const Setup& setup, const Linearization& lin,
                                const std::vector<Eigen::Vector2d>& residuals, double scatter_px, double scatter_dof,
                                const PixelLockingSignature* removed);
// UncertaintyBudget::NoiseIndependence from the residuals of lin.obs (without the signature, as the detection-noise
// row's scatter), on the white scatter's lattice triples (found once per set of observations). Under independent
// errors of equal variance the residuals are e = (I - H) eps, H = J (J^T J)^+ J^T, so E[e_a e_b] = -sigma^2 H_ab and
// E[e_i^2] = sigma^2 (1 - H_ii): r0 = -mean H_ab / mean (1 - H_ii) over the pairs and the features, per
// coordinate. Under independence r - r0 has the standard error 1 / sqrt(pairs) (the products of distinct pairs are
// uncorrelated); z = (r - r0) sqrt(pairs). A neighbour pair: a triple's step within 14 deg (sine 0.25) of the
// screen's rows (s) or columns (y); diagonal steps are not used. Entries with fewer than kMinWhiteTriples pairs stay
// NaN.
UncertaintyBudget::NoiseIndependence NoiseIndependenceCheck(const Setup& setup, const Linearization& lin,
                                                            const std::vector<Eigen::Vector2d>& residuals);
inline constexpr size_t kMisfitRow = 3;  // the lens-model-misfit row's index in UncertaintyBudget::components
std::vector<Eigen::Vector2d> LinearizedResiduals(const Setup& setup, const Linearization& lin, const ModelFit& fit);
void Budget(const Setup& setup, ModelWork& w, int n_residuals, ModelFit* fit);
// stated_field: FitOptions::stated_lens_misfit's field, drawn once per fit (StatedField), or null.
std::vector<QuantityVariance> CompleteBudget(const Setup& setup, ModelWork& w, const ModelFit& reference,
                                             const NormalisedField* stated_field, ModelFit* fit);
// The stated lens misfit's field of RMS 1 (NormalisedField::Draw at its length, over the camera's imager,
// kStatedFieldDraws draws seeded from FitOptions::systematic_field_seed); not ok without a stated misfit.
NormalisedField StatedField(const Setup& setup);
void FinishBudget(const std::vector<QuantityVariance>& vars, ModelFit* fit);

// screen_fit_misfit.cc: the lens-model-misfit row. FieldVariance is exact (the family's covariance between
// every two detections) up to this many detections, and samples the field's random-feature basis above: a
// Gaussian field's covariance costs an exponential (6 ns here), a ring's a Bessel function J0
// (std::cyl_bessel_j, 315 ns), so n^2 of them stay below about 0.1 s.
constexpr int kExactFieldPoints = 3000;
constexpr int kExactRingFieldPoints = 600;
QuantityVariance FieldVariance(const Setup& setup, const Linearization& lin, const PixelLockingCorrection& correction,
                               const UncertaintyBudget::FieldComponent& component);
// A stated misfit's error distribution (RowDistribution::kSampled): the stated field (NormalisedField of RMS 1,
// drawn once per fit) through the estimate's response (as FieldVariance's, pixel-locking correction included),
// for k, the first camera's centre-frame x, y, z and its axis-frame z (c_z - 1/k at curvature_per_mm); per
// quantity the draws' magnitudes over the unscaled field's standard deviation, sorted, in kStatedFieldGroups
// means of consecutive ones. Empty when the field could not be drawn (NormalisedField::ok).
constexpr long kStatedFieldQuantities = 5;
constexpr int kStatedFieldDraws = 4000;
constexpr size_t kStatedFieldGroups = 250;
std::vector<std::vector<double>> StatedFieldDraws(const Setup& setup, const Linearization& lin,
                                                  const PixelLockingCorrection& correction,
                                                  const NormalisedField& field, double curvature_per_mm);
// The generalized-least-squares weight for statistics whose covariance is estimated (the misfit's lag statistics,
// StatisticsCovariance): V diag(1 / max(lambda, floor)) V^T over the eigenpairs of `covariance`, the floor the
// larger of 1e-6 of the largest eigenvalue and the magnitude of the most negative one. An estimate whose true
// value is positive semi-definite and that has an eigenvalue -mu is off by at least mu in norm (Weyl's
// inequality), so eigenvalues below mu are not known to be smaller than mu: weighting such a direction by 1 /
// (1e-6 lambda_max) let the estimate's sampling error pick the field (2026-12-06: in webcam trials the lag
// statistics' covariance held eigenvalues down to -1.6% of the largest; the selection then left a 0.2 px lens
// field of 364 px for a 0.02 px short one, chi^2 485 on 9 statistics). Empty when the decomposition fails or
// the largest eigenvalue is not positive.
std::optional<Eigen::MatrixXd> EstimatedCovarianceWeight(const Eigen::MatrixXd& covariance);
void EstimateMisfit(const Setup& setup, const Linearization& lin, const std::vector<Eigen::Vector2d>& residual,
                    double sigma_px, UncertaintyBudget* bud, LensFieldProjection* projection);
void MeasureMisfitCorrelation(const Setup& setup, const Linearization& lin,
                              const std::vector<Eigen::Vector2d>& residual, double sigma_px, UncertaintyBudget* bud);

// screen_fit_select.cc: model selection.
// The held-out RMS over heldout_folds folds of the features: shuffled, or (strips) contiguous strips across u.
double HeldOut(const Setup& setup, const ModelWork& w, const std::vector<bool>& inlier, const ModelFit& fit,
               bool strips);
void AdjustForLensField(const FitOptions& o, int width_px, const std::vector<ModelWork>& work,
                        ScreenFitResult* result);
void Choose(const FitOptions& options, ScreenFitResult* result);

// screen_fit.cc: the adequacy test.
double DetectionSigma(const FitOptions& o);
double AdequacyLimit(const FitOptions& o);
void Adequacy(const FitOptions& o, double rss, int n, ModelFit* fit, const std::string& what = "");

}  // namespace curvecheck::screen_fit_internal
