#include "relocalizer/core/point_to_plane.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

namespace relocalizer {

bool PointToPlaneSystem::step(Pose& transform) const {
  const Eigen::LDLT<Matrix6d> solver(hessian_);
  if (solver.info() != Eigen::Success) return false;
  const Vector6d x = solver.solve(-gradient_);
  if (!x.allFinite()) return false;
  // exp([w, t]) with the rotation exact and the translation to first order: the
  // steps are millimetres and fractions of a degree near convergence.
  Pose increment = Pose::Identity();
  const Eigen::Vector3d w = x.head<3>();
  const double angle = w.norm();
  if (angle > 0.0) increment.linear() = Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  increment.translation() = x.tail<3>();
  transform = increment * transform;
  transform.linear() = nearestRotation(transform.linear());
  return true;
}

}  // namespace relocalizer
