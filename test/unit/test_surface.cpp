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
  for (size_t i = 0; i < r.paths.test.size(); i += 3) {
    const Pose& truth = r.paths.test[i];
    const RgbdFrame frame = r.room.render(truth, kCamera, 2000 + static_cast<int>(i));
    const auto points = surfaceFitPoints(frame, params.points);
    lowest_right = std::min(lowest_right, fitToSurface(r.surface, points, truth, params).agreement);
    const Pose wrong = perturbed(truth, 0.5, 30.0, rng);
    highest_wrong =
        std::max(highest_wrong, fitToSurface(r.surface, points, wrong, params).agreement);
  }
  for (size_t i = 0; i < other_paths.test.size(); i += 2) {
    // Another room's frame placed where it was taken, in this room's world.
    const RgbdFrame frame = other.render(other_paths.test[i], kCamera, static_cast<int>(i));
    const auto points = surfaceFitPoints(frame, params.points);
    highest_wrong = std::max(
        highest_wrong, fitToSurface(r.surface, points, other_paths.test[i], params).agreement);
  }
  std::printf("agreement: lowest right pose %.3f, highest wrong pose or other room %.3f\n",
              lowest_right, highest_wrong);
  EXPECT_GT(lowest_right, params.min_agreement);
  EXPECT_LT(highest_wrong, params.min_agreement);
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
