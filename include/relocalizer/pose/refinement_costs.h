#pragma once
// The residuals of pose refinement, one Ceres cost function per kind, as in
// Ceres' own examples: E_p (a camera point against its world mode) and E_l (a
// world mode against the sample's 3D line), both whitened by the mode's
// covariance so that a residual's squared norm is its Mahalanobis distance.
// The robust loss is not theirs: it is chosen where the problem is built.
//
// Every cost function is parameterised by one block, a left perturbation
// delta = (v, w) of a fixed base pose: R = Exp(w) R0, t = t0 + v. A solve
// starts at delta = 0, and the same form at the solution gives the covariance
// in ROS's fixed-axis order. Their Jacobians are hand-derived: refinement runs
// thousands of evaluations per frame, and these are several times cheaper than
// dual numbers (test_pose_solver.cpp checks them against autodiff).

#include <ceres/cost_function.h>
#include <ceres/rotation.h>
#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <vector>

#include "relocalizer/core/pose.h"

namespace relocalizer {

// One matched sample for refinement: the chosen mode of a sample.
struct RefinementTerm {
  Eigen::Vector3d camera_point;
  Eigen::Vector3d mode_mean;    // world
  Eigen::Matrix3d information;  // inverse mode covariance, world frame
  bool on_line = false;
  Eigen::Vector3d line_point = Eigen::Vector3d::Zero();       // camera frame
  Eigen::Vector3d line_direction = Eigen::Vector3d::UnitZ();  // camera frame, unit
};

// The perturbed pose (r, t) at `delta`; templated for autodiff references.
template <typename T>
void perturbedPose(const T* delta, const Eigen::Matrix3d& r0, const Eigen::Vector3d& t0,
                   Eigen::Matrix<T, 3, 3>& r, Eigen::Matrix<T, 3, 1>& t) {
  T rotation[9];
  ceres::AngleAxisToRotationMatrix(delta + 3, ceres::ColumnMajorAdapter3x3(rotation));
  const Eigen::Map<const Eigen::Matrix<T, 3, 3>> exp_w(rotation);
  r = exp_w * r0.cast<T>();
  t = t0.cast<T>() + Eigen::Matrix<T, 3, 1>(delta[0], delta[1], delta[2]);
}

// R, t and the left Jacobian of SO(3) at the parameters being evaluated,
// shared by every cost function of one problem. All have the one parameter
// block, and Ceres evaluates them one after another at the same values
// (num_threads = 1), so the exponential map and J_l, once two thirds of each
// term's cost, are computed once per evaluation point, bit for bit what each
// term would compute for itself.
class SharedPerturbation {
 public:
  explicit SharedPerturbation(const Pose& base);
  void update(const double* delta);
  const Eigen::Matrix3d& rotation() const { return r_; }
  const Eigen::Vector3d& translation() const { return t_; }
  const Eigen::Matrix3d& leftJacobian() const { return jl_; }

 private:
  Eigen::Matrix3d r0_;
  Eigen::Vector3d t0_;
  double delta_[6] = {0, 0, 0, 0, 0, 0};
  bool valid_ = false;
  Eigen::Matrix3d r_, jl_;
  Eigen::Vector3d t_;
};

// E_p = S (R c + t - mu), S^T S the mode's information.
class PointToPointCost : public ceres::SizedCostFunction<3, 6> {
 public:
  PointToPointCost(const RefinementTerm& term, SharedPerturbation& pose);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d camera_, mean_;
  Eigen::Matrix3d sqrt_information_;
  SharedPerturbation& pose_;
};

// E_l: the mode moved into the camera frame, its offset from the sample's 3D
// line, weighted by the mode covariance rotated into the camera frame:
// r^T (R^T Sigma R)^-1 r = |S R r|^2. Computed in world coordinates:
// S (I - D D^T)(mu - A) with D = R d, A = R a + t.
class PointOnLineCost : public ceres::SizedCostFunction<3, 6> {
 public:
  PointOnLineCost(const RefinementTerm& term, SharedPerturbation& pose);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d mean_, line_point_, line_direction_;
  Eigen::Matrix3d sqrt_information_;
  SharedPerturbation& pose_;
};

// The cost functions of a set of terms, each of its term's kind (the one place
// that tells them apart), evaluated at `pose`, which must outlive them. A solve
// has hundreds of terms: they live in one array per kind, so building and
// dropping them is a few allocations, not one per term.
class TermCosts {
 public:
  TermCosts(const std::vector<RefinementTerm>& terms, SharedPerturbation& pose);
  size_t size() const { return costs_.size(); }
  // The cost of terms[i].
  ceres::SizedCostFunction<3, 6>& operator[](size_t i) const { return *costs_[i]; }

 private:
  // Cost functions can be neither copied nor moved: each is built in place in
  // an empty slot.
  std::unique_ptr<std::optional<PointToPointCost>[]> points_;
  std::unique_ptr<std::optional<PointOnLineCost>[]> lines_;
  std::vector<ceres::SizedCostFunction<3, 6>*> costs_;
};

}  // namespace relocalizer
