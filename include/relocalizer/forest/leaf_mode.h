#pragma once
// One mean-shift mode of the world coordinates that reached a leaf, at full
// precision: what training makes, and what RANSAC and refinement read. The
// model keeps it packed (packed_mode.h); prediction unpacks the mode it
// chooses.

#include <Eigen/Core>
#include <array>

namespace relocalizer {

struct LeafMode {
  Eigen::Vector3f mean = Eigen::Vector3f::Zero();  // world, metres
  // Inverse covariance, upper triangle (xx xy xz yy yz zz), 1/m^2: what the
  // Mahalanobis distances in RANSAC and refinement need.
  std::array<float, 6> information{};

  Eigen::Matrix3f informationMatrix() const;
  Eigen::Matrix3f covariance() const;
  void setCovariance(const Eigen::Matrix3f& covariance);
  // (x - mean)^T Sigma^-1 (x - mean)
  float mahalanobisSquared(const Eigen::Vector3f& x) const {
    const Eigen::Vector3f d = x - mean;
    const auto& s = information;
    return s[0] * d.x() * d.x() + s[3] * d.y() * d.y() + s[5] * d.z() * d.z() +
           2.0f * (s[1] * d.x() * d.y() + s[2] * d.x() * d.z() + s[4] * d.y() * d.z());
  }
};
// Model formats 3 and 4 stored this layout.
static_assert(sizeof(LeafMode) == 36, "LeafMode layout is part of the model format");

}  // namespace relocalizer
