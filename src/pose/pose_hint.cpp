#include "relocalizer/pose/pose_hint.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <vector>

namespace relocalizer {

namespace {

// The axes with a positive variance.
std::vector<int> constrainedAxes(const Matrix6d& covariance) {
  std::vector<int> axes;
  for (int i = 0; i < 6; ++i)
    if (covariance(i, i) > 0) axes.push_back(i);
  return axes;
}

// The covariance's block on `axes`.
Eigen::MatrixXd blockOn(const Matrix6d& covariance, const std::vector<int>& axes) {
  const int n = static_cast<int>(axes.size());
  Eigen::MatrixXd block(n, n);
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) block(a, b) = covariance(axes[a], axes[b]);
  return block;
}

// Position difference, then the rotation vector of R_pose * R_hint^T.
Eigen::Matrix<double, 6, 1> errorOf(const Pose& pose, const Pose& hint) {
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() = pose.translation() - hint.translation();
  const Eigen::AngleAxisd rotation(pose.linear() * hint.linear().transpose());
  e.tail<3>() = rotation.angle() * rotation.axis();
  return e;
}

}  // namespace

std::string poseHintError(const PoseHint& hint) {
  if (!hint.pose.matrix().allFinite()) return "the hint's pose is not finite";
  const Eigen::Matrix3d r = hint.pose.linear();
  if ((r * r.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-3 ||
      std::abs(r.determinant() - 1.0) > 1e-3)
    return "the hint's orientation is not a rotation (a unit quaternion)";
  if (!hint.covariance.allFinite()) return "the hint's covariance is not finite";
  for (int i = 0; i < 6; ++i)
    if (hint.covariance(i, i) < 0) return "the hint's covariance has a negative variance";
  const std::vector<int> axes = constrainedAxes(hint.covariance);
  if (axes.empty())
    return "the hint's covariance is all zero, so it constrains nothing (give variances for x, "
           "y and yaw at least)";
  const Eigen::MatrixXd block = blockOn(hint.covariance, axes);
  if (!block.isApprox(block.transpose(), 1e-9) || block.llt().info() != Eigen::Success)
    return "the hint's covariance on the axes it constrains is not symmetric positive definite";
  return {};
}

Expected<HintPrior> HintPrior::make(const PoseHint& hint) {
  if (std::string why = poseHintError(hint); !why.empty()) return makeError(why);
  HintPrior prior;
  prior.pose_ = hint.pose;
  const std::vector<int> axes = constrainedAxes(hint.covariance);
  const int n = static_cast<int>(axes.size());
  const Eigen::MatrixXd information =
      blockOn(hint.covariance, axes).llt().solve(Eigen::MatrixXd::Identity(n, n));
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) prior.information_(axes[a], axes[b]) = information(a, b);
  prior.free_axes_ = 6 - n;
  return prior;
}

double HintPrior::distanceSquared(const Pose& pose) const {
  const Eigen::Matrix<double, 6, 1> e = errorOf(pose, pose_);
  return e.dot(information_ * e);
}

double HintPrior::factor(const Pose& pose, double weight) const {
  return 1.0 + weight * std::exp(-0.5 * distanceSquared(pose));
}

}  // namespace relocalizer
