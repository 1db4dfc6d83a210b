#pragma once
// A pose hint: where someone (an operator, another localizer) believes the
// camera is, with how sure they are. The next relocalization favours
// hypotheses near it, but only within a bounded bonus, so that strong evidence
// elsewhere still wins and every evidence gate still applies.
//
// The rule (one home, HintPrior::factor): when the preemptive rounds rank
// hypotheses, and when PlaceSet weighs one place's answer against another's,
// an answer counts its inliers times
//   1 + hint_weight * exp(-d^2 / 2),
// d^2 its Mahalanobis distance to the hint. With the default hint_weight 0.5
// an answer far from the hint still wins when it explains more than 1.5 times
// the samples of the best one near it. The answer's own inlier counts, the
// evidence thresholds and the surface check never see the factor, so a frame
// that fits nowhere still gets no pose.

#include <string>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/pose.h"

namespace relocalizer {

struct PoseHint {
  // The map frame the pose is in: with many places (place_set.h) only the
  // places in this frame are favoured. Empty: a single place's own frame.
  std::string frame;
  Pose pose = Pose::Identity();  // camera-to-world
  // Of (x, y, z, rotation about x, y, z), the order of
  // geometry_msgs/PoseWithCovariance. A variance of 0 on the diagonal leaves
  // that axis free (RViz's 2D Pose Estimate gives x, y and yaw only); the
  // axes it constrains must hold a positive definite block.
  Matrix6d covariance = Matrix6d::Zero();
};

// Empty when the hint can be used, else why not.
std::string poseHintError(const PoseHint& hint);

// A usable hint, ready to weigh poses.
class HintPrior {
 public:
  static Expected<HintPrior> make(const PoseHint& hint);

  // Squared Mahalanobis distance of `pose` to the hint over the constrained
  // axes: the camera position's difference in the map frame and the rotation
  // from the hint's orientation to the pose's, about the map's axes.
  double distanceSquared(const Pose& pose) const;
  // What a pose's evidence counts for when ranked: 1 + weight * exp(-d^2 / 2).
  double factor(const Pose& pose, double weight) const;
  // The hint constrains all six axes: its pose is worth trying as a hypothesis.
  bool complete() const { return free_axes_ == 0; }
  const Pose& pose() const { return pose_; }

 private:
  Pose pose_ = Pose::Identity();
  Matrix6d information_ = Matrix6d::Zero();  // zero rows and columns on free axes
  int free_axes_ = 6;
};

}  // namespace relocalizer
