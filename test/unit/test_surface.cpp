// The scene surface and the fit of a frame's depth to it, on a synthetic room
// whose geometry is known exactly (SyntheticRoom::surfaceDistance).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "relocalizer/core/statistics.h"
#include "relocalizer/sim/synthetic_scene.h"
#include "relocalizer/surface/surface_fit.h"
#include "relocalizer/surface/surface_model.h"

namespace relocalizer {
namespace {

const CameraIntrinsics kCamera = CameraIntrinsics::kinectDefault().scaledTo(320, 240);

struct Room {
  SyntheticRoom room{1};
  SyntheticTrajectories paths = room.trajectories(120, 30);
  SurfaceModel surface;
  Room() {
    SurfaceBuilder builder;
    for (size_t i = 0; i < paths.train.size(); i += 2) {
      const RgbdFrame frame = room.render(paths.train[i], kCamera, static_cast<int>(i));
      builder.addFrame(frame.depth, frame.camera, paths.train[i]);
    }
    surface = builder.build();
  }
};

const Room& room() {
  static const Room instance;
  return instance;
}

// truth moved by `metres` along a random direction and turned by `degrees`
// about a random axis.
Pose perturbed(const Pose& truth, double metres, double degrees, std::mt19937& rng) {
  std::normal_distribution<double> gauss;
  const Eigen::Vector3d axis = Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
  const Eigen::Vector3d shift = Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
  Pose pose = truth;
  pose.linear() =
      Eigen::AngleAxisd(degrees * M_PI / 180.0, axis).toRotationMatrix() * truth.linear();
  pose.translation() += metres * shift;
  return pose;
}

TEST(SurfaceModel, ElementsLieOnTheRoomsSurfaces) {
  const Room& r = room();
  ASSERT_GT(r.surface.elements().size(), 10000u);
  std::vector<double> distances;
  for (const SurfaceElement& e : r.surface.elements()) {
    distances.push_back(r.room.surfaceDistance(e.point.cast<double>()));
    ASSERT_NEAR(e.normal.norm(), 1.0f, 1e-5f);
  }
  // Kinect noise at 1-2.5 m is 2-10 mm per pixel; a voxel averages many.
  std::printf("%zu elements; distance to the true surface: median %.2f mm, 95th %.2f mm\n",
              r.surface.elements().size(), 1000 * percentile(distances, 50),
              1000 * percentile(distances, 95));
  EXPECT_LT(percentile(distances, 50), 0.004);
  EXPECT_LT(percentile(distances, 95), 0.015);
}

TEST(SurfaceModel, NormalsAreThoseOfTheSurfaces) {
  const Room& r = room();
  // The normal of the exact surface by finite differences of its distance field,
  // from a point a little in front of the element along the element's normal.
  int checked = 0, agreeing = 0;
  for (size_t i = 0; i < r.surface.elements().size(); i += 97) {
    const SurfaceElement& e = r.surface.elements()[i];
    const Eigen::Vector3d p = (e.point + 0.03f * e.normal).cast<double>();
    if (r.room.surfaceDistance(p) < 0.02) continue;  // a corner: the field bends
    Eigen::Vector3d gradient;
    for (int axis = 0; axis < 3; ++axis) {
      Eigen::Vector3d d = Eigen::Vector3d::Zero();
      d[axis] = 1e-3;
      gradient[axis] = (r.room.surfaceDistance(p + d) - r.room.surfaceDistance(p - d)) / 2e-3;
    }
    ++checked;
    agreeing += gradient.normalized().dot(e.normal.cast<double>()) > 0.95 ? 1 : 0;
  }
  ASSERT_GT(checked, 50);
  EXPECT_GT(static_cast<double>(agreeing) / checked, 0.9);
}

TEST(SurfaceModel, NearFindsTheSurfaceWithinAVoxelAndNothingInFreeSpace) {
  const Room& r = room();
  const float voxel = r.surface.voxelSize();
  int found_on = 0, found_off = 0, found_free = 0, total = 0;
  for (size_t i = 0; i < r.surface.elements().size(); i += 53) {
    const SurfaceElement& e = r.surface.elements()[i];
    ++total;
    found_on += r.surface.near(e.point) != nullptr;
    found_off += r.surface.near(e.point + 0.9f * voxel * e.normal) != nullptr;
    // Half a metre into the room from a wall is free space (or another surface,
    // which the distance field tells).
    const Eigen::Vector3f far = e.point + 0.5f * e.normal;
    if (r.room.surfaceDistance(far.cast<double>()) > 3 * voxel)
      found_free += r.surface.near(far) != nullptr;
  }
  EXPECT_EQ(found_on, total);
  EXPECT_GT(found_off, 0.95 * total);
  EXPECT_EQ(found_free, 0);
}

TEST(SurfaceModel, SameFramesGiveTheSameModel) {
  const Room& r = room();
  SurfaceBuilder builder;
  for (size_t i = 0; i < r.paths.train.size(); i += 2) {
    const RgbdFrame frame = r.room.render(r.paths.train[i], kCamera, static_cast<int>(i));
    builder.addFrame(frame.depth, frame.camera, r.paths.train[i]);
  }
  const SurfaceModel again = builder.build();
  ASSERT_EQ(again.elements().size(), r.surface.elements().size());
  for (size_t i = 0; i < again.elements().size(); ++i) {
    ASSERT_EQ(again.elements()[i].point, r.surface.elements()[i].point);
    ASSERT_EQ(again.elements()[i].normal, r.surface.elements()[i].normal);
  }
}

TEST(SurfaceFit, IcpRecoversPosesCentimetresOff) {
  const Room& r = room();
  std::mt19937 rng(7);
  SurfaceFitParams params;
  std::vector<double> before_t, after_t, after_r, agreement;
  for (size_t i = 0; i < r.paths.test.size(); ++i) {
    const Pose& truth = r.paths.test[i];
    const RgbdFrame frame = r.room.render(truth, kCamera, 1000 + static_cast<int>(i));
    const Pose start = perturbed(truth, 0.02, 1.5, rng);
    const SurfaceFit fit =
        fitToSurface(r.surface, surfaceFitPoints(frame, params.points), start, params);
    before_t.push_back(translationError(start, truth));
    after_t.push_back(translationError(fit.pose, truth));
    after_r.push_back(rotationErrorDegrees(fit.pose, truth));
    agreement.push_back(fit.agreement);
  }
  std::printf(
      "ICP from 2 cm / 1.5 deg: median %.2f mm / %.3f deg, 90th %.2f mm, agreement 10th pct %.2f\n",
      1000 * percentile(after_t, 50), percentile(after_r, 50), 1000 * percentile(after_t, 90),
      percentile(agreement, 10));
  EXPECT_LT(percentile(after_t, 50), 0.004);
  EXPECT_LT(percentile(after_r, 50), 0.2);
  EXPECT_LT(percentile(after_t, 90), 0.01);
  EXPECT_GT(percentile(agreement, 10), 0.8);
}

TEST(SurfaceFit, AgreementSeparatesRightPosesFromWrongOnesAndOtherRooms) {
  const Room& r = room();
  const SyntheticRoom other(2);
  const SyntheticTrajectories other_paths = other.trajectories(60, 20);
  SurfaceFitParams params;
  std::mt19937 rng(11);
  float lowest_right = 1.0f, highest_wrong = 0.0f;
  int right_refused = 0, wrong_answered = 0;
  const auto check = [&](const std::vector<Eigen::Vector3f>& points, const Pose& pose, bool right) {
    const SurfaceFit fit = fitToSurface(r.surface, points, pose, params);
    float& extreme = right ? lowest_right : highest_wrong;
    extreme = right ? std::min(extreme, fit.agreement) : std::max(extreme, fit.agreement);
    const bool refused = !surfaceRefusal(fit.view, params).empty();
    (right ? right_refused : wrong_answered) += right == refused;
  };
  for (size_t i = 0; i < r.paths.test.size(); i += 3) {
    const Pose& truth = r.paths.test[i];
    const RgbdFrame frame = r.room.render(truth, kCamera, 2000 + static_cast<int>(i));
    const auto points = surfaceFitPoints(frame, params.points);
    check(points, truth, true);
    check(points, perturbed(truth, 0.5, 30.0, rng), false);
  }
  for (size_t i = 0; i < other_paths.test.size(); i += 2) {
    // Another room's frame placed where it was taken, in this room's world.
    const RgbdFrame frame = other.render(other_paths.test[i], kCamera, static_cast<int>(i));
    check(surfaceFitPoints(frame, params.points), other_paths.test[i], false);
  }
  std::printf("agreement: lowest right pose %.3f, highest wrong pose or other room %.3f\n",
              lowest_right, highest_wrong);
  EXPECT_GT(lowest_right, params.min_agreement);
  EXPECT_LT(highest_wrong, params.min_agreement);
  EXPECT_EQ(right_refused, 0);
  EXPECT_EQ(wrong_answered, 0);
}

// Share of the valid depth of `frame` nearer than the unchanged room's exact
// depth by more than 5 cm: what the people cover.
double occludedShare(const SyntheticRoom& room, const RgbdFrame& frame, const Pose& pose) {
  const cv::Mat exact = room.exactDepth(pose, frame.camera);
  int valid = 0, nearer = 0;
  for (int v = 0; v < exact.rows; ++v)
    for (int u = 0; u < exact.cols; ++u) {
      const float z = frame.depth.at<float>(v, u);
      if (!(z > 0.0f)) continue;
      ++valid;
      nearer += z < exact.at<float>(v, u) - 0.05f;
    }
  return valid > 0 ? static_cast<double>(nearer) / valid : 0.0;
}

TEST(SurfaceFit, PeopleInFrontOfTheSurfaceDoNotRefuseARightPoseNorPassAWrongOne) {
  const Room& r = room();
  const SyntheticRoom crowded = r.room.changed({3, 0, 0, 0, LampChange::kNone});
  const SurfaceFitParams params;
  std::mt19937 rng(13);
  int with_people = 0, beyond_the_old_gate = 0;
  for (size_t i = 0; i < r.paths.test.size(); ++i) {
    const Pose& truth = r.paths.test[i];
    const RgbdFrame frame = crowded.render(truth, kCamera, 3000 + static_cast<int>(i));
    const double occluded = occludedShare(r.room, frame, truth);
    if (occluded < 0.1) continue;
    ++with_people;
    const auto points = surfaceFitPoints(frame, params.points);
    const SurfaceView right = viewSurface(r.surface, points, truth, params);
    // Without the occluders, too little of the depth lies on the surface.
    beyond_the_old_gate += static_cast<float>(right.on) / right.points < params.min_agreement;
    EXPECT_EQ(surfaceRefusal(right, params), "")
        << "frame " << i << ": " << 100 * occluded << "% of the depth on people";
    EXPECT_GT(right.in_front, 0.5 * occluded * right.points) << "frame " << i;
    // 15 cm along the view: nearer, the walls are seen through; farther, the
    // whole view floats in front of them.
    const Eigen::Vector3d view = truth.linear().col(2);
    for (const double metres : {-0.15, 0.15}) {
      Pose wrong = truth;
      wrong.translation() += metres * view;
      EXPECT_NE(surfaceRefusal(viewSurface(r.surface, points, wrong, params), params), "")
          << "frame " << i << " moved " << metres << " m along the view";
    }
    const Pose wrong = perturbed(truth, 0.5, 30.0, rng);
    EXPECT_NE(surfaceRefusal(viewSurface(r.surface, points, wrong, params), params), "")
        << "frame " << i << " 0.5 m / 30 deg off";
  }
  std::printf(
      "%d test frames with people over 10%% of the depth, %d of them below the agreement "
      "gate when occluders count against it\n",
      with_people, beyond_the_old_gate);
  EXPECT_GE(with_people, 5);
  EXPECT_GE(beyond_the_old_gate, 1) << "no frame tests the occluders";
}

TEST(SurfaceFit, EmptySurfaceAndNoPointsLeaveThePoseAlone) {
  const Pose pose = Pose(Eigen::Translation3d(1, 2, 3));
  const SurfaceFit nothing = fitToSurface(SurfaceModel(), {Eigen::Vector3f(0, 0, 1)}, pose, {});
  EXPECT_FALSE(nothing.refined);
  EXPECT_TRUE(nothing.pose.isApprox(pose));
  EXPECT_EQ(nothing.agreement, 0.0f);
  const SurfaceFit no_points = fitToSurface(room().surface, {}, pose, {});
  EXPECT_EQ(no_points.agreement, 0.0f);
  EXPECT_TRUE(no_points.pose.isApprox(pose));
}

}  // namespace
}  // namespace relocalizer
