#include "relocalizer/data/depth_alignment.h"

#include <Eigen/Cholesky>
#include <cmath>

namespace relocalizer {

namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

bool validDepth(float z) { return z > 0.0f; }  // false for NaN too

Eigen::Vector3d backProject(const CameraIntrinsics& camera, int u, int v, float z) {
  return camera.backProject(static_cast<float>(u), static_cast<float>(v), z).cast<double>();
}

// Rigid transform exp([w, t]) to first order in rotation (axis-angle w).
Pose increment(const Vector6d& x) {
  Pose d = Pose::Identity();
  const Eigen::Vector3d w = x.head<3>();
  const double angle = w.norm();
  if (angle > 0.0) d.linear() = Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  d.translation() = x.tail<3>();
  return d;
}

struct Accumulated {
  Matrix6d hessian = Matrix6d::Zero();
  Vector6d gradient = Vector6d::Zero();
  double squared = 0.0;
  int count = 0;
};

// One Gauss-Newton linearisation of the point-to-plane energy at `motion`.
Accumulated linearise(const cv::Mat& fixed, const cv::Mat& moving, const CameraIntrinsics& camera,
                      const Pose& motion, const DepthAlignmentParams& params) {
  Accumulated acc;
  const int step = std::max(1, params.normal_step);
  for (int v = 0; v < moving.rows; v += params.stride) {
    const float* row = moving.ptr<float>(v);
    for (int u = 0; u < moving.cols; u += params.stride) {
      if (!validDepth(row[u])) continue;
      const Eigen::Vector3d p = motion * backProject(camera, u, v, row[u]);
      if (p.z() <= 0.0) continue;
      const int uf = static_cast<int>(std::lround(camera.fx * p.x() / p.z() + camera.cx));
      const int vf = static_cast<int>(std::lround(camera.fy * p.y() / p.z() + camera.cy));
      if (uf < step || vf < step || uf + step >= fixed.cols || vf + step >= fixed.rows) continue;
      const float zc = fixed.at<float>(vf, uf), zl = fixed.at<float>(vf, uf - step),
                  zr = fixed.at<float>(vf, uf + step), zu = fixed.at<float>(vf - step, uf),
                  zd = fixed.at<float>(vf + step, uf);
      if (!(validDepth(zc) && validDepth(zl) && validDepth(zr) && validDepth(zu) && validDepth(zd)))
        continue;
      const Eigen::Vector3d q = backProject(camera, uf, vf, zc);
      Eigen::Vector3d normal =
          (backProject(camera, uf + step, vf, zr) - backProject(camera, uf - step, vf, zl))
              .cross(backProject(camera, uf, vf + step, zd) -
                     backProject(camera, uf, vf - step, zu));
      const double length = normal.norm();
      if (!(length > 0.0)) continue;
      normal /= length;
      const double r = normal.dot(p - q);
      if (std::abs(r) > params.max_residual) continue;
      // d r / d(w, t) for p -> p + w x p + t.
      Vector6d jacobian;
      jacobian.head<3>() = p.cross(normal);
      jacobian.tail<3>() = normal;
      const double weight = std::abs(r) <= params.huber ? 1.0 : params.huber / std::abs(r);
      acc.hessian.noalias() += weight * jacobian * jacobian.transpose();
      acc.gradient.noalias() += weight * r * jacobian;
      acc.squared += r * r;
      ++acc.count;
    }
  }
  return acc;
}

}  // namespace

DepthAlignment alignDepth(const cv::Mat& fixed_depth, const cv::Mat& moving_depth,
                          const CameraIntrinsics& camera, const Pose& initial,
                          const DepthAlignmentParams& params) {
  CV_Assert(fixed_depth.type() == CV_32FC1 && moving_depth.type() == CV_32FC1 &&
            fixed_depth.size() == moving_depth.size());
  DepthAlignment result;
  Pose motion = initial;
  for (int it = 0; it <= params.iterations; ++it) {
    const Accumulated acc = linearise(fixed_depth, moving_depth, camera, motion, params);
    if (acc.count < params.min_correspondences) return result;
    const double rms = std::sqrt(acc.squared / acc.count);
    if (it == 0) result.initial_rms = rms;
    result.final_rms = rms;
    result.correspondences = acc.count;
    if (it == params.iterations) break;  // the last pass only measures
    const Eigen::LDLT<Matrix6d> solver(acc.hessian);
    if (solver.info() != Eigen::Success) return result;
    const Vector6d x = solver.solve(-acc.gradient);
    if (!x.allFinite()) return result;
    motion = increment(x) * motion;
    motion.linear() = nearestRotation(motion.linear());
  }
  result.valid = true;
  result.motion = motion;
  return result;
}

PoseDifference poseDifference(const Pose& a, const Pose& b) {
  Pose ra = a, rb = b;
  ra.linear() = nearestRotation(a.linear());
  rb.linear() = nearestRotation(b.linear());
  const Pose d = ra.inverse() * rb;
  return {d.translation().norm(), Eigen::AngleAxisd(d.linear()).angle() * 180.0 / M_PI};
}

MotionCheck checkMotion(const cv::Mat& from_depth, const Pose& from_pose, const cv::Mat& to_depth,
                        const Pose& to_pose, const CameraIntrinsics& camera,
                        const DepthAlignmentParams& params) {
  MotionCheck check;
  Pose from = from_pose, to = to_pose;
  from.linear() = nearestRotation(from.linear());
  to.linear() = nearestRotation(to.linear());
  const Pose ground_truth = from.inverse() * to;  // `to` camera -> `from` camera
  check.ground_truth_motion = poseDifference(Pose::Identity(), ground_truth);
  const DepthAlignment alignment = alignDepth(from_depth, to_depth, camera, ground_truth, params);
  check.aligned = alignment.valid;
  check.rms_at_ground_truth = alignment.initial_rms;
  if (!alignment.valid) return check;
  check.rms_aligned = alignment.final_rms;
  check.depth_motion = poseDifference(Pose::Identity(), alignment.motion);
  check.disagreement = poseDifference(ground_truth, alignment.motion);
  return check;
}

}  // namespace relocalizer
