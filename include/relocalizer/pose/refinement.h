#pragma once
// Levenberg-Marquardt (Ceres) refinement of a camera pose on the paper's two
// energies: point-to-point (E_p, a camera point against its world mode) and
// point-on-line (E_l, a world mode against the sample's 3D line), both
// Mahalanobis under the mode's covariance, with a Cauchy loss. The residuals
// have hand-derived Jacobians; the autodiff functors stay as the reference a
// unit test compares them with.

#include <Eigen/Core>
#include <vector>

#include "relocalizer/core/pose.h"
#include "relocalizer/pose/pose_solver.h"

namespace relocalizer {

// One matched sample for refinement: the chosen mode of a sample.
struct RefinementTerm {
  Eigen::Vector3d camera_point;
  Eigen::Vector3d mode_mean;          // world
  Eigen::Matrix3d information;        // inverse mode covariance, world frame
  bool on_line = false;
  Eigen::Vector3d line_point = Eigen::Vector3d::Zero();          // camera frame
  Eigen::Vector3d line_direction = Eigen::Vector3d::UnitZ();     // camera frame, unit
};

// Levenberg-Marquardt (Ceres) on E_p + E_l from `initial`; returns the refined
// pose and, if asked, its covariance (see PoseSolution::covariance) from all
// terms. At most params.max_refinement_terms terms enter the solve;
// `max_iterations` <= 0 means params.lm_iterations.
Pose refinePose(const Pose& initial, const std::vector<RefinementTerm>& terms,
                const PoseSolverParams& params, Matrix6d* covariance = nullptr,
                int max_iterations = 0);

// The residual values of the two energies at a pose, whitened so that their
// squared norm is the Mahalanobis distance (exposed for tests).
Eigen::Vector3d pointResidual(const Pose& pose, const RefinementTerm& term);
Eigen::Vector3d lineResidual(const Pose& pose, const RefinementTerm& term);

// The refinement uses hand-derived Jacobians; this evaluates them beside the
// autodiff reference at perturbation `delta` (v, w) of `base` (for tests).
struct ResidualJacobians {
  Eigen::Vector3d residual;  // autodiff reference
  double residual_difference = 0.0;
  Eigen::Matrix<double, 3, 6, Eigen::RowMajor> analytic, autodiff;
};
ResidualJacobians residualJacobians(const Pose& base, const RefinementTerm& term, const double* delta);

}  // namespace relocalizer
