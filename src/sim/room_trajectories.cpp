// The synthetic room's camera paths: training and test loops around the room
// centre, and the poses a motion-blurred frame averages over.

#include "room_trajectories.h"

namespace relocalizer {

using namespace synthetic;

namespace {

struct LoopShape {
  double rx, ry;
  double height, height_amp, height_phase;
  int height_freq;
  double yaw_amp, yaw_phase;
  int yaw_freq;
  double pitch, pitch_amp, pitch_phase;
  int pitch_freq;
  double roll_amp, roll_phase;
  int roll_freq;
};

constexpr double kDegree = M_PI / 180.0;

Pose loopPose(const LoopShape& s, const Eigen::Vector2d& centre, double theta) {
  const Eigen::Vector3d position(
      centre.x() + s.rx * std::cos(theta), centre.y() + s.ry * std::sin(theta),
      s.height + s.height_amp * std::sin(s.height_freq * theta + s.height_phase));
  const double yaw = theta + s.yaw_amp * std::sin(s.yaw_freq * theta + s.yaw_phase);
  const double pitch = s.pitch + s.pitch_amp * std::sin(s.pitch_freq * theta + s.pitch_phase);
  const double roll = s.roll_amp * std::sin(s.roll_freq * theta + s.roll_phase);
  const Eigen::Vector3d forward(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw),
                                std::sin(pitch));
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d r;
  r.col(0) = std::cos(roll) * right + std::sin(roll) * down;
  r.col(1) = -std::sin(roll) * right + std::cos(roll) * down;
  r.col(2) = forward;
  Pose pose = Pose::Identity();
  pose.linear() = r;
  pose.translation() = position;
  return pose;
}

}  // namespace

SyntheticTrajectories synthetic::roomTrajectories(const SyntheticRoom::Impl& room, int train_frames,
                                                  int test_frames) {
  const Eigen::Vector2d centre((room.lo.x() + room.hi.x()) / 2, (room.lo.y() + room.hi.y()) / 2);
  const double half_w = (room.hi.x() - room.lo.x()) / 2, half_d = (room.hi.y() - room.lo.y()) / 2;
  // Radii keep the camera ~1.6-1.9 m from the walls, so furniture (up to
  // 0.65 m deep) is at least ~1 m away. Wobble frequencies are integers so
  // the loops close.
  const LoopShape train{half_w - 1.85,
                        half_d - 1.6,
                        1.45,
                        0.06,
                        room.phases[0],
                        3,
                        7 * kDegree,
                        room.phases[1],
                        2,
                        -8 * kDegree,
                        4 * kDegree,
                        room.phases[2],
                        5,
                        2 * kDegree,
                        room.phases[3],
                        3};
  // Inside and above the training loop, wobbling differently: new viewpoints
  // that are never more than ~0.25 m and ~15 degrees from a training view.
  const LoopShape test{train.rx - 0.12,
                       train.ry - 0.12,
                       1.55,
                       0.06,
                       room.phases[4],
                       2,
                       5 * kDegree,
                       room.phases[5],
                       3,
                       -9 * kDegree,
                       3 * kDegree,
                       room.phases[6],
                       4,
                       1.5 * kDegree,
                       room.phases[7],
                       2};
  // At most ~1.3 degrees of loop per frame keeps steps at ~1-3 cm and 1-2 degrees.
  const double train_step = 2 * M_PI / std::max(train_frames, kSyntheticLoopFrames);
  const double train_arc = train_step * std::max(train_frames, 0);
  const double theta0 = room.path_phase;
  double test_step = 2 * M_PI / std::max(test_frames, kSyntheticLoopFrames);
  double test_start;
  if (train_arc >= 2 * M_PI - 1e-9) {
    test_start = theta0 + 0.37 * 2 * M_PI;
  } else {
    // Keep the test arc inside the part of the loop training has seen.
    if (test_frames > 0) test_step = std::min(test_step, 0.8 * train_arc / test_frames);
    test_start = theta0 + (train_arc - test_step * std::max(test_frames - 1, 0)) / 2;
  }
  SyntheticTrajectories out;
  for (int i = 0; i < train_frames; ++i)
    out.train.push_back(loopPose(train, centre, theta0 + i * train_step));
  for (int i = 0; i < test_frames; ++i)
    out.test.push_back(loopPose(test, centre, test_start + i * test_step));
  return out;
}

std::vector<Pose> motionBlurPoses(const std::vector<Pose>& path, size_t index, int samples,
                                  double exposure) {
  std::vector<Pose> poses;
  if (index >= path.size() || samples < 1) return poses;
  const double last = static_cast<double>(path.size() - 1);
  for (int k = 0; k < samples; ++k) {
    const double s = std::clamp(index + exposure * ((k + 0.5) / samples - 0.5), 0.0, last);
    const size_t i0 = static_cast<size_t>(std::floor(s));
    const size_t i1 = std::min(i0 + 1, path.size() - 1);
    const double f = s - i0;
    Pose p = Pose::Identity();
    p.translation() = (1 - f) * path[i0].translation() + f * path[i1].translation();
    p.linear() = Eigen::Quaterniond(path[i0].linear())
                     .slerp(f, Eigen::Quaterniond(path[i1].linear()))
                     .toRotationMatrix();
    poses.push_back(p);
  }
  return poses;
}

}  // namespace relocalizer
