#include "relocalizer/forest/leaf_mode.h"

#include <Eigen/LU>

namespace relocalizer {

Eigen::Matrix3f LeafMode::informationMatrix() const {
  const auto& s = information;
  Eigen::Matrix3f m;
  m << s[0], s[1], s[2], s[1], s[3], s[4], s[2], s[4], s[5];
  return m;
}

Eigen::Matrix3f LeafMode::covariance() const { return informationMatrix().inverse(); }

void LeafMode::setCovariance(const Eigen::Matrix3f& covariance) {
  const Eigen::Matrix3f inverse = covariance.inverse();
  information = {inverse(0, 0), inverse(0, 1), inverse(0, 2),
                 inverse(1, 1), inverse(1, 2), inverse(2, 2)};
}

}  // namespace relocalizer
