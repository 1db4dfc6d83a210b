#pragma once
// Camera pose from forest predictions: preemptive RANSAC over Kabsch
// hypotheses, refined by Levenberg-Marquardt (Ceres) on point-to-point and
// point-on-line Mahalanobis energies.
//
// Hypotheses come from minimal sets of three point-forest correspondences
// (a random candidate mode each), screened for degeneracy and rigidity before
// Kabsch. Each round scores the surviving hypotheses on a fresh batch of
// samples (points and lines): a sample is an inlier when the mode that best
// explains its transformed camera point is within `inlier_chi2` in Mahalanobis
// distance. The better half survives and is refined on its inliers: weighted
// Kabsch while many hypotheses remain, Ceres LM once at most
// `lm_hypotheses` remain (the paper refines inside the loop; refinement.h). The
// winner is refined twice more on all samples, its covariance taken at the pose
// it answers with, and it is rejected unless the evidence (inlier count and
// share) clears the configured thresholds.

#include <Eigen/Core>
#include <random>
#include <string>
#include <vector>

#include "relocalizer/core/pose.h"
#include "relocalizer/forest/forest.h"
#include "relocalizer/forest/sampling.h"
#include "relocalizer/pose/pose_hint.h"

namespace relocalizer {

struct PoseSolverParams {
  int hypotheses = 256;              // initial hypotheses
  int batch_size = 500;              // samples scored per preemptive round
  int max_sampling_attempts = 20;    // minimal sets tried per hypothesis before giving up
  float min_point_distance = 0.05f;  // metres between the three camera points
  float rigidity_tolerance = 0.05f;  // |camera distance - world distance|, metres, and
  float rigidity_ratio = 0.1f;       // as a share of the distance (the larger bound applies)
  float inlier_chi2 = 9.0f;          // Mahalanobis^2 below which a sample is an inlier
  // Refinement: half the cost of 0.1's 8 / 5 / 10 / 800, measured at the same
  // accuracy on redkitchen-dev (docs/benchmarks.md); the final LM had converged
  // within 5 iterations on every test frame.
  int lm_hypotheses = 4;           // refine with Ceres LM once this few remain
  int lm_loop_iterations = 3;      // LM iterations per hypothesis inside the loop
  int lm_iterations = 5;           // LM iterations of the final refinement
  int max_refinement_terms = 400;  // terms per LM solve (an even subset of the inliers)
  float robust_scale = 3.0f;       // Cauchy loss scale, in Mahalanobis units
  bool use_lines_in_refinement = true;
  // Evidence needed to answer with a pose (on all samples, after refinement).
  int min_inliers = 30;
  float min_inlier_ratio = 0.15f;
  // With a pose hint: the largest share by which a hypothesis at the hint
  // counts its inliers up when hypotheses are ranked (pose_hint.h).
  float hint_weight = 0.5f;
};

// One sample as the solver sees it: a camera point and its candidate modes.
// Line samples also carry their 3D line in camera coordinates.
struct SolverSample {
  Eigen::Vector3f camera_point;
  const Prediction* prediction = nullptr;
  const Line3D* line = nullptr;  // null for point samples
};

struct PoseSolution {
  bool success = false;
  std::string message;           // why not, when !success
  Pose pose = Pose::Identity();  // camera-to-world
  // Covariance of (x, y, z, rotation about world x, y, z), the order of
  // geometry_msgs/PoseWithCovariance, for perturbations applied on the left:
  // refinementCovariance of the final inliers at `pose`.
  Matrix6d covariance = Matrix6d::Identity();
  int point_inliers = 0;
  int line_inliers = 0;
  // The camera points of those inliers (point samples, then line samples), for
  // those who draw the answer; the counts are their sizes.
  std::vector<Eigen::Vector3f> point_inlier_cameras;
  std::vector<Eigen::Vector3f> line_inlier_cameras;
  int samples = 0;
  float score = 0.0f;  // inlier share of all samples
  int valid_hypotheses = 0;
  // LM solves whose Ceres summary was unusable (each kept the pose it started
  // from), and Ceres' reason for the last one in the final refinement.
  int failed_refinements = 0;
  std::string refinement_failure;
  double ransac_seconds = 0.0;
  double refinement_seconds = 0.0;
};

// `points` seed hypotheses and are scored; `lines` are scored and used in refinement.
// With a `hint`, hypotheses are ranked by their inliers times HintPrior::factor
// (pose_hint.h), and a hint that constrains all six axes is one more
// hypothesis; an unusable hint is the reason for no pose. Without one, nothing
// differs from a solve that never heard of hints.
PoseSolution solvePose(const std::vector<SolverSample>& points,
                       const std::vector<SolverSample>& lines, const PoseSolverParams& params,
                       std::mt19937& rng, const PoseHint* hint = nullptr);

// How well the point samples fit one rigid motion: the point inliers of the
// short RANSAC's winner and its pose (camera-to-world, Kabsch only, so coarse;
// identity when no hypothesis could be drawn, with 0 inliers).
struct ScreenResult {
  int inliers = 0;
  Pose pose = Pose::Identity();
};

// For ranking places at a small share of solvePose's cost: a short preemptive
// RANSAC of `hypotheses` Kabsch hypotheses, refitted by Kabsch only (no LM, no
// lines), drawn from at most `sampling_attempts` minimal sets per hypothesis
// (the screen's own budget, not params.max_sampling_attempts).
ScreenResult screenPose(const std::vector<SolverSample>& points, const PoseSolverParams& params,
                        int hypotheses, int sampling_attempts, std::mt19937& rng);

}  // namespace relocalizer
