#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "relocalizer/dataset.h"
#include "relocalizer/registration.h"
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
  std::ofstream(dir.str() + "/colour-registration.txt") << "527 527 322\n";
  auto bad = openDataset(dir.str());
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("colour-registration.txt: line 1: expected 'registered' or 7 numbers"),
            std::string::npos)
      << bad.error();
}

TEST(Registration, EstimatedFromRealFramesItBeatsTheIdentity) {
  RELOCALIZER_REQUIRE_REDKITCHEN(dir);
  DatasetOptions options;
  options.frames = "0,100,200,300,400";
  options.register_colour = false;
  auto dataset = openDataset(dir, options);
  ASSERT_TRUE(dataset.ok()) << dataset.error();
  std::vector<cv::Mat> colours, depths;
  for (size_t i = 0; i < (*dataset)->size(); ++i) {
    auto frame = (*dataset)->load(i);
    ASSERT_TRUE(frame.ok());
    colours.push_back(frame->colour);
    depths.push_back(frame->depth);
  }
  double score = 0, identity = 0;
  const ColourRegistration r =
      estimateColourRegistration(colours, depths, (*dataset)->camera(), &score, &identity);
  // A Kinect v1 colour camera: ~525 px focal length, a few cm beside the depth camera.
  EXPECT_NEAR(r.fx, 527, 8);
  EXPECT_LT(std::abs(r.depth_to_colour.x()), 0.06);
  EXPECT_GT(score, 1.5 * identity);
  const ColourRegistration shipped = ColourRegistration::sevenScenesKinect();
  EXPECT_NEAR(r.fx, shipped.fx, 8);
}
