#include "relocalizer/core/frame_alignment.h"

#include <cmath>

#include "relocalizer/core/point_to_plane.h"

namespace relocalizer {

namespace {

bool validDepth(float z) { return z > 0.0f; }  // false for NaN too

Eigen::Vector3d backProject(const CameraIntrinsics& camera, int u, int v, float z) {
  return camera.backProject(static_cast<float>(u), static_cast<float>(v), z).cast<double>();
}

// One Gauss-Newton linearisation of the point-to-plane energy at `motion`.
PointToPlaneSystem linearise(const cv::Mat& fixed, const cv::Mat& moving,
                             const CameraIntrinsics& camera, const Pose& motion,
                             const DepthAlignmentParams& params) {
  PointToPlaneSystem system(params.huber);
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
      system.add(p, normal, r);
    }
  }
  return system;
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
    const PointToPlaneSystem system = linearise(fixed_depth, moving_depth, camera, motion, params);
    if (system.count() < params.min_correspondences) return result;
    if (it == 0) result.initial_rms = system.rms();
    result.final_rms = system.rms();
    result.correspondences = system.count();
    if (it == params.iterations) break;  // the last pass only measures
    if (!system.step(motion)) return result;
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

}  // namespace relocalizer
