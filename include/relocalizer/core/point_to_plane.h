#pragma once
// Gauss-Newton for a rigid transform from point-to-plane residuals, shared by
// frame-to-frame depth alignment (core/frame_alignment.h) and frame-to-surface
// fitting (surface/surface_fit.h).
//
// Residual r = n . (p - q) for a moved point p = T * x, a target point q and its
// unit normal n. The increment is applied on the left, p -> p + w x p + t, so
// dr/dw = p x n and dr/dt = n, in the frame of p and q. Residuals beyond the
// Huber threshold get weight huber / |r|: depth noise and the odd wrong
// correspondence do not pull the solution.

#include <Eigen/Core>

#include "relocalizer/core/pose.h"

namespace relocalizer {

class PointToPlaneSystem {
 public:
  using Vector6d = Eigen::Matrix<double, 6, 1>;

  explicit PointToPlaneSystem(double huber) : huber_(huber) {}

  // One correspondence: the moved point, its target's unit normal and r.
  void add(const Eigen::Vector3d& moved_point, const Eigen::Vector3d& normal, double residual) {
    Vector6d jacobian;
    jacobian.head<3>() = moved_point.cross(normal);
    jacobian.tail<3>() = normal;
    const double magnitude = std::abs(residual);
    const double weight = magnitude <= huber_ ? 1.0 : huber_ / magnitude;
    hessian_.noalias() += weight * jacobian * jacobian.transpose();
    gradient_.noalias() += weight * residual * jacobian;
    squared_ += residual * residual;
    ++count_;
  }

  int count() const { return count_; }
  double rms() const { return count_ > 0 ? std::sqrt(squared_ / count_) : 0.0; }

  // Applies the Gauss-Newton step to `transform` (on the left, re-orthonormalised);
  // false when the system is singular (e.g. all points on one plane leave a
  // direction unconstrained) or the step is not finite.
  bool step(Pose& transform) const;

 private:
  double huber_;
  Matrix6d hessian_ = Matrix6d::Zero();
  Vector6d gradient_ = Vector6d::Zero();
  double squared_ = 0.0;
  int count_ = 0;
};

}  // namespace relocalizer
