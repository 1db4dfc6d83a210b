#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "relocalizer/data/dataset.h"
#include "relocalizer/data/registration.h"
#include "relocalizer/sim/synthetic_scene.h"
#include "support.h"

using namespace relocalizer;

TEST(Registration, DepthCameraIntrinsicsWithoutOffsetIsTheIdentity) {
  cv::Mat colour(48, 64, CV_8UC3);
  cv::randu(colour, 0, 255);
  cv::Mat depth(48, 64, CV_32FC1, cv::Scalar(1.5f));
  const CameraIntrinsics camera{50, 50, 32, 24, 64, 48};
  ColourRegistration same;
  same.fx = same.fy = 50;
  same.cx = 32;
  same.cy = 24;
  const cv::Mat out = registerColourToDepth(colour, depth, camera, same);
  EXPECT_EQ(cv::norm(out, colour, cv::NORM_INF), 0.0);
}

TEST(Registration, ShiftsByTheParallaxOfTheBaseline) {
  // A colour camera 0.1 m to the depth camera's right sees a surface at 2 m
  // shifted by f * b / z = 50 * 0.1 / 2 = 2.5 pixels to the left.
  cv::Mat colour(48, 64, CV_8UC3, cv::Scalar(0, 0, 0));
  colour.col(30).setTo(cv::Scalar(255, 255, 255));
  cv::Mat depth(48, 64, CV_32FC1, cv::Scalar(2.0f));
  const CameraIntrinsics camera{50, 50, 32, 24, 64, 48};
  ColourRegistration offset;
  offset.fx = offset.fy = 50;
  offset.cx = 32;
  offset.cy = 24;
  offset.depth_to_colour = Eigen::Vector3d(0.1, 0, 0);
  const cv::Mat out = registerColourToDepth(colour, depth, camera, offset);
  // Depth pixel u maps to colour u - 2.5: column 30 of colour lands on 32.5.
  EXPECT_GT(out.at<cv::Vec3b>(10, 32)[0], 100);
  EXPECT_GT(out.at<cv::Vec3b>(10, 33)[0], 100);
  EXPECT_EQ(out.at<cv::Vec3b>(10, 30)[0], 0);
}

TEST(Registration, SevenScenesFolderReadsColourRegistrationFile) {
  relocalizer::testing::TempDir dir;
  cv::Mat colour(24, 32, CV_8UC3, cv::Scalar(10, 20, 30));
  cv::Mat depth(24, 32, CV_16UC1, cv::Scalar(1500));
  cv::imwrite(dir.str() + "/frame-000000.color.png", colour);
  cv::imwrite(dir.str() + "/frame-000000.depth.png", depth);
  std::ofstream(dir.str() + "/frame-000000.pose.txt") << "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
  {
    auto d = openDataset(dir.str());
    ASSERT_TRUE(d.ok()) << d.error();
    EXPECT_NE((*d)->summary().find("7-Scenes Kinect calibration"), std::string::npos);
  }
  std::ofstream(dir.str() + "/colour-registration.txt") << "# synthetic\nregistered\n";
  {
    auto d = openDataset(dir.str());
    ASSERT_TRUE(d.ok()) << d.error();
    EXPECT_NE((*d)->summary().find("says colour is registered"), std::string::npos);
  }
  std::ofstream(dir.str() + "/colour-registration.txt") << "527 527 nan 239 0 0 0\n";
  auto nan = openDataset(dir.str());
  ASSERT_FALSE(nan.ok());
  EXPECT_NE(nan.error().find("colour-registration.txt: line 1: every number must be finite"),
            std::string::npos)
      << nan.error();
  std::ofstream(dir.str() + "/colour-registration.txt") << "527 527 322\n";
  auto bad = openDataset(dir.str());
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("colour-registration.txt: line 1: expected 'registered' or 7 numbers"),
            std::string::npos)
      << bad.error();
}

TEST(Registration, PhotometricConsistencyPrefersTheTrueRegistration) {
  // A synthetic room seen by one camera: colour is registered, so the identity
  // registration is the truth and a shifted one must cost more.
  const SyntheticRoom room(4);
  const CameraIntrinsics camera = CameraIntrinsics::kinectDefault().scaledTo(320, 240);
  const std::vector<Pose> path = room.trajectories(60, 0).train;
  std::vector<PosedRgbd> frames;
  for (int i = 0; i < 60; i += 6) {
    const RgbdFrame f = room.render(path[i], camera, i);
    frames.push_back({f.colour, f.depth, *f.ground_truth});
  }
  const PhotometricConsistency consistency(frames, camera);
  ASSERT_GT(consistency.correspondences(), 1000u);
  ColourRegistration truth;
  truth.fx = camera.fx;
  truth.fy = camera.fy;
  truth.cx = camera.cx;
  truth.cy = camera.cy;
  ColourRegistration shifted = truth;
  shifted.cx += 5;
  ColourRegistration offset = truth;
  offset.depth_to_colour.x() = 0.03;
  EXPECT_LT(consistency.cost(truth), consistency.cost(shifted));
  EXPECT_LT(consistency.cost(truth), consistency.cost(offset));
  // And the search walks back to it from a wrong start.
  double cost = 0, initial_cost = 0;
  const ColourRegistration estimated =
      estimateColourRegistration(frames, camera, shifted, false, &cost, &initial_cost);
  EXPECT_LT(cost, initial_cost);
  EXPECT_NEAR(estimated.cx - camera.fx * estimated.depth_to_colour.x() / 2.0, camera.cx, 1.5)
      << "principal point and offset together should undo the shift at ~2 m";
}

TEST(Registration, EstimatedFromRealTrainingFramesMatchesTheShippedCalibration) {
  RELOCALIZER_REQUIRE_REDKITCHEN(dir);
  DatasetOptions options;
  options.frames = "0-99,200-299,400-499";
  options.register_colour = false;
  auto dataset = openDataset(dir, options);
  ASSERT_TRUE(dataset.ok()) << dataset.error();
  std::vector<PosedRgbd> frames;
  for (size_t i = 0; i < (*dataset)->size(); i += 3) {  // as the shipped calibration was made
    auto frame = (*dataset)->load(i);
    ASSERT_TRUE(frame.ok());
    frames.push_back({frame->colour, frame->depth, *frame->ground_truth});
  }
  ColourRegistration identity;
  identity.fx = identity.fy = 585;
  identity.cx = 320;
  identity.cy = 240;
  const ColourRegistration shipped = ColourRegistration::sevenScenesKinect();
  const PhotometricConsistency consistency(frames, (*dataset)->camera());
  EXPECT_LT(consistency.cost(shipped), 0.8 * consistency.cost(identity));
  double cost = 0, initial_cost = 0;
  const ColourRegistration r = estimateColourRegistration(frames, (*dataset)->camera(), shipped,
                                                          false, &cost, &initial_cost);
  EXPECT_LE(cost, initial_cost);
  // Near the shipped calibration: a Kinect v1 colour camera (~520 px focal
  // length), mapping a point at 1.5 m to within ~2 px of where it does.
  EXPECT_NEAR(r.fx, shipped.fx, 6);
  const auto columnAt = [](const ColourRegistration& c, double z) {
    return c.cx - c.fx * c.depth_to_colour.x() / z;
  };
  EXPECT_NEAR(columnAt(r, 1.5), columnAt(shipped, 1.5), 2.0);
  EXPECT_NEAR(r.cy - r.fy * r.depth_to_colour.y() / 1.5,
              shipped.cy - shipped.fy * shipped.depth_to_colour.y() / 1.5, 2.0);
}
