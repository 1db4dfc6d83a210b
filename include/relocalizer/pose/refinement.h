#pragma once
// Levenberg-Marquardt (Ceres) refinement of a camera pose on the paper's two
// energies, point-to-point (E_p) and point-on-line (E_l), both Mahalanobis
// under the mode's covariance (refinement_costs.h), with a Cauchy loss; and the
// pose's covariance from the same Jacobians.

#include <string>
#include <vector>

#include "relocalizer/core/pose.h"
#include "relocalizer/pose/pose_solver.h"
#include "relocalizer/pose/refinement_costs.h"

namespace relocalizer {

struct Refinement {
  Pose pose = Pose::Identity();
  // Ceres' summary called the solution usable. When not (a failed evaluation,
  // a non-finite cost), `pose` is the start, unchanged, and `message` says why.
  bool solved = false;
  std::string message;
  int iterations = 0;
};

// Levenberg-Marquardt (Ceres) on E_p + E_l from `initial`. At most
// params.max_refinement_terms terms (an even subset) enter the solve;
// `max_iterations` <= 0 means params.lm_iterations. Fewer than 3 terms: no
// solve, the start is kept.
Refinement refinePose(const Pose& initial, const std::vector<RefinementTerm>& terms,
                      const PoseSolverParams& params, int max_iterations = 0);

// Covariance of `pose` (see PoseSolution::covariance): the Gauss-Newton
// information of every term at `pose`, robust weights included, inverted; no
// solve. Identity with fewer than 3 terms, 1e6 * identity when singular.
Matrix6d refinementCovariance(const Pose& pose, const std::vector<RefinementTerm>& terms,
                              const PoseSolverParams& params);

}  // namespace relocalizer
