// The node's building blocks without a ROS master: message checks and
// conversion, frame hand-over, pose conversion.

#include <gtest/gtest.h>
#include <sensor_msgs/image_encodings.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <thread>

#include "../../src/ros/conversion/message_conversion.h"
#include "../../src/ros/node/frame_buffer.h"
#include "../../src/ros/node/pose_handoff.h"

using namespace relocalizer_ros;
namespace enc = sensor_msgs::image_encodings;

namespace {

sensor_msgs::Image image(uint32_t width, uint32_t height, const std::string& encoding,
                         int bytes_per_pixel) {
  sensor_msgs::Image msg;
  msg.width = width;
  msg.height = height;
  msg.encoding = encoding;
  msg.step = width * bytes_per_pixel;
  msg.data.assign(static_cast<size_t>(msg.step) * height, 0);
  msg.header.frame_id = "camera";
  return msg;
}

sensor_msgs::CameraInfo info(uint32_t width, uint32_t height) {
  sensor_msgs::CameraInfo msg;
  msg.width = width;
  msg.height = height;
  msg.K = {100, 0, width / 2.0, 0, 100, height / 2.0, 0, 0, 1};
  return msg;
}

// 8x6 32FC1 depth whose pixel i (row-major) is value(i).
sensor_msgs::Image depth32(const std::function<float(int)>& value) {
  auto msg = image(8, 6, enc::TYPE_32FC1, 4);
  for (int i = 0; i < 48; ++i) {
    const float v = value(i);
    std::memcpy(&msg.data[4 * i], &v, 4);
  }
  return msg;
}

}  // namespace

TEST(MessageConversion, AcceptsTheRep118DepthEncodingsAndTheColourOnes) {
  for (const auto& [colour, bpp] :
       {std::pair{enc::BGR8, 3}, {enc::RGB8, 3}, {enc::MONO8, 1}, {enc::BGRA8, 4}})
    for (const auto& [depth, dbpp] :
         {std::pair{enc::TYPE_16UC1, 2}, {enc::TYPE_32FC1, 4}, {enc::MONO16, 2}})
      EXPECT_EQ(checkFrameMessages(image(8, 6, colour, bpp), image(8, 6, depth, dbpp), info(8, 6)),
                "")
          << colour << " " << depth;
}

TEST(MessageConversion, ConvertsUnitsChannelsAndInvalidDepth) {
  auto colour = image(2, 1, enc::RGB8, 3);
  colour.data = {10, 20, 30, 40, 50, 60};
  auto depth = image(2, 1, enc::TYPE_16UC1, 2);
  const uint16_t mm[2] = {1500, 0};
  std::memcpy(depth.data.data(), mm, sizeof(mm));
  auto frame = frameFromMessages(colour, depth, info(2, 1));
  ASSERT_TRUE(frame.ok()) << frame.error();
  EXPECT_EQ(frame->colour.at<cv::Vec3b>(0, 0), cv::Vec3b(30, 20, 10));  // BGR
  EXPECT_FLOAT_EQ(frame->depth.at<float>(0, 0), 1.5f);
  EXPECT_TRUE(std::isnan(frame->depth.at<float>(0, 1)));
  EXPECT_EQ(frame->camera.fx, 100.0);

  auto metres = image(2, 1, enc::TYPE_32FC1, 4);
  const float m[2] = {2.25f, std::nanf("")};
  std::memcpy(metres.data.data(), m, sizeof(m));
  auto mono = image(2, 1, enc::MONO8, 1);
  mono.data = {7, 9};
  frame = frameFromMessages(mono, metres, info(2, 1));
  ASSERT_TRUE(frame.ok()) << frame.error();
  EXPECT_EQ(frame->colour.at<cv::Vec3b>(0, 1), cv::Vec3b(9, 9, 9));
  EXPECT_FLOAT_EQ(frame->depth.at<float>(0, 0), 2.25f);
  EXPECT_TRUE(std::isnan(frame->depth.at<float>(0, 1)));
}

// Moved from the core's unit tests when colour encodings became the ROS layer's
// concern (cv_bridge); the same pixels and the same refusal.
TEST(MessageConversion, ColourConvertsRgbAndMonoAndRejectsOthers) {
  auto rgb = image(1, 1, enc::RGB8, 3);
  rgb.data = {10, 20, 30};
  auto bgr = colourToBgr8(rgb);
  ASSERT_TRUE(bgr.ok());
  EXPECT_EQ(bgr->at<cv::Vec3b>(0, 0), cv::Vec3b(30, 20, 10));
  auto mono = image(1, 1, enc::MONO8, 1);
  mono.data = {77};
  EXPECT_EQ(colourToBgr8(mono)->at<cv::Vec3b>(0, 0), cv::Vec3b(77, 77, 77));
  auto yuv = rgb;
  yuv.encoding = "yuv422";
  auto bad = colourToBgr8(yuv);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("yuv422"), std::string::npos);
}

// Registered depth (depth_registered topics) is in the colour camera's
// rectified image, whose camera matrix is P; K is the unrectified sensor's.
TEST(MessageConversion, IntrinsicsComeFromPWhenItIsSet) {
  auto k_and_p = info(8, 6);
  k_and_p.P = {120, 0, 3.5, 0, 0, 130, 2.5, 0, 0, 0, 1, 0};
  const relocalizer::CameraIntrinsics from_p = cameraFromInfo(k_and_p);
  EXPECT_EQ(from_p.fx, 120.0);
  EXPECT_EQ(from_p.fy, 130.0);
  EXPECT_EQ(from_p.cx, 3.5);
  EXPECT_EQ(from_p.cy, 2.5);
  EXPECT_EQ(std::string(intrinsicsMatrixName(k_and_p)), "P");

  auto colour = image(8, 6, enc::BGR8, 3);
  auto depth = image(8, 6, enc::TYPE_16UC1, 2);
  for (size_t i = 0; i < depth.data.size(); i += 2) depth.data[i + 1] = 0x03;  // 768 mm
  auto frame = frameFromMessages(colour, depth, k_and_p);
  ASSERT_TRUE(frame.ok()) << frame.error();
  EXPECT_EQ(frame->camera.fx, 120.0);
  EXPECT_EQ(frame->camera.cy, 2.5);

  // An unusable P is named as such, even when K is fine.
  auto bad_p = k_and_p;
  bad_p.P[5] = 0.0;
  EXPECT_EQ(
      checkFrameMessages(colour, depth, bad_p).rfind("camera_info P is unusable: focal length", 0),
      0u)
      << checkFrameMessages(colour, depth, bad_p);
  // A camera_info that fills only K (P all zero) still works, from K.
  const auto only_k = info(8, 6);
  EXPECT_EQ(cameraFromInfo(only_k).fx, 100.0);
  EXPECT_EQ(std::string(intrinsicsMatrixName(only_k)), "K");
}

TEST(MessageConversion, RowPaddingIsHonoured) {
  auto colour = image(2, 2, enc::MONO8, 1);
  colour.step = 4;  // two bytes of padding per row
  colour.data = {1, 2, 99, 99, 3, 4, 99, 99};
  auto depth = image(2, 2, enc::TYPE_16UC1, 2);
  depth.data = {0xe8, 0x03, 0xe8, 0x03,
                0xe8, 0x03, 0xe8, 0x03};  // 1000 mm (all-zero depth is refused)
  auto frame = frameFromMessages(colour, depth, info(2, 2));
  ASSERT_TRUE(frame.ok()) << frame.error();
  EXPECT_EQ(frame->colour.at<cv::Vec3b>(1, 0)[0], 3);
}

TEST(MessageConversion, RejectsWhatWouldReadOutOfBoundsOrMisregister) {
  const auto colour = image(8, 6, enc::BGR8, 3);
  const auto depth = image(8, 6, enc::TYPE_16UC1, 2);
  auto short_step = colour;
  short_step.step = 10;
  EXPECT_NE(checkFrameMessages(short_step, depth, info(8, 6)).find("step 10"), std::string::npos);
  auto short_data = depth;
  short_data.data.resize(5);
  EXPECT_NE(checkFrameMessages(colour, short_data, info(8, 6)).find("holds 5 bytes"),
            std::string::npos);
  auto big_endian = depth;
  big_endian.is_bigendian = 1;
  EXPECT_NE(checkFrameMessages(colour, big_endian, info(8, 6)).find("byte order"),
            std::string::npos);
  EXPECT_NE(checkFrameMessages(colour, depth, info(4, 3)).find("camera_info is for 4x3"),
            std::string::npos);
  auto other_frame = depth;
  other_frame.header.frame_id = "/camera";  // a leading slash is the same frame
  EXPECT_EQ(checkFrameMessages(colour, other_frame, info(8, 6)), "");
  other_frame.header.frame_id = "depth";
  EXPECT_NE(checkFrameMessages(colour, other_frame, info(8, 6)).find("registered"),
            std::string::npos);
  auto nan_k = info(8, 6);
  nan_k.K[4] = std::nan("");
  EXPECT_NE(checkFrameMessages(colour, depth, nan_k).find("K is unusable"), std::string::npos);
  EXPECT_NE(checkFrameMessages(image(0, 0, enc::BGR8, 3), depth, info(8, 6)).find("empty"),
            std::string::npos);
}

TEST(MessageConversion, ColourLabelledAsDepthIsRejected) {
  const auto colour = image(8, 6, enc::BGR8, 3);
  // A bgr8 buffer (3 bytes a pixel, its own step) published as 16UC1.
  auto relabelled = image(8, 6, enc::BGR8, 3);
  relabelled.encoding = enc::TYPE_16UC1;
  EXPECT_EQ(checkFrameMessages(colour, relabelled, info(8, 6)),
            "depth image is labelled '16UC1' (2 bytes a pixel) but its rows hold 3 bytes a pixel "
            "(step 24 for width 8): a colour image on the depth topic?");
  // The same buffer with a 16-bit step: more bytes than the header describes.
  relabelled.step = 16;
  EXPECT_EQ(checkFrameMessages(colour, relabelled, info(8, 6)),
            "depth image holds 144 bytes, more than step x height (96) for '16UC1' 8x6");
  // A colour image sent on the depth topic as it is.
  EXPECT_EQ(
      checkFrameMessages(colour, image(8, 6, enc::BGR8, 3), info(8, 6)),
      "unsupported depth encoding 'bgr8' (expected 16UC1 millimetres or 32FC1 metres, REP 118); "
      "a colour image on the depth topic?");
  // Row padding that is not a colour row is still fine.
  auto padded = image(8, 6, enc::TYPE_16UC1, 2);
  padded.step = 20;
  padded.data.assign(20 * 6, 0);
  EXPECT_EQ(checkFrameMessages(colour, padded, info(8, 6)), "");
}

TEST(MessageConversion, DepthWithoutAValidPixelSaysWhatItHolds) {
  const auto colour = image(8, 6, enc::BGR8, 3);
  auto depth16 = [](uint16_t value) {
    auto msg = image(8, 6, enc::TYPE_16UC1, 2);
    for (size_t i = 0; i < msg.data.size(); i += 2) std::memcpy(&msg.data[i], &value, 2);
    return msg;
  };
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<std::pair<sensor_msgs::Image, std::string>> cases = {
      {depth16(0), "depth has no valid pixel: 48 zero"},
      {depth16(65535), "depth has no valid pixel: 48 65535 (saturated)"},
      {depth32([](int) { return 0.0f; }), "depth has no valid pixel: 48 zero"},
      {depth32([](int) { return std::nanf(""); }), "depth has no valid pixel: 48 NaN"},
      {depth32([inf](int) { return inf; }), "depth has no valid pixel: 48 infinite"},
      {depth32([inf](int i) { return i % 2 ? -inf : -1.5f; }),
       "depth has no valid pixel: 24 infinite, 24 negative"},
      {depth32([](int i) { return i < 8 ? std::nanf("") : -0.5f; }),
       "depth has no valid pixel: 8 NaN, 40 negative"},
  };
  for (const auto& [depth, reason] : cases) {
    EXPECT_EQ(checkFrameMessages(colour, depth, info(8, 6)), "");  // headers are fine
    auto frame = frameFromMessages(colour, depth, info(8, 6));
    ASSERT_FALSE(frame.ok()) << reason;
    EXPECT_EQ(frame.error(), reason);
  }
  // One valid pixel is a frame; too little depth is then the core's call.
  auto one = depth16(0);
  const uint16_t mm = 1200;
  std::memcpy(&one.data[10], &mm, 2);
  EXPECT_TRUE(frameFromMessages(colour, one, info(8, 6)).ok());
}

TEST(MessageConversion, CameraInfoFocalLengthMustBeFiniteAndPositive) {
  const auto colour = image(8, 6, enc::BGR8, 3);
  const auto depth = image(8, 6, enc::TYPE_16UC1, 2);
  const std::vector<std::pair<size_t, double>> spoilt = {
      {0, 0.0},
      {4, 0.0},
      {0, -100.0},
      {0, std::nan("")},
      {4, std::numeric_limits<double>::infinity()}};
  for (const auto& [index, value] : spoilt) {
    auto k = info(8, 6);
    k.K[index] = value;
    EXPECT_EQ(checkFrameMessages(colour, depth, k)
                  .rfind("camera_info K is unusable: focal length must be "
                         "finite and positive (fx=",
                         0),
              0u)
        << index << " " << value << ": " << checkFrameMessages(colour, depth, k);
  }
  auto uncalibrated = info(8, 6);
  uncalibrated.K = {};  // what an uncalibrated driver sends
  EXPECT_NE(checkFrameMessages(colour, depth, uncalibrated)
                .find("focal length must be finite and positive"),
            std::string::npos);
}

// Issue 23: finite but wrong depth and intrinsics got only "no pose hypothesis
// passed the rigidity checks". Millimetres in 32FC1 is a common driver slip.
TEST(MessageConversion, FloatDepthInMillimetresIsRefusedAsNotMetres) {
  const auto colour = image(8, 6, enc::BGR8, 3);
  // Half the pixels without depth: the median is over the valid ones.
  auto millimetres = depth32([](int i) { return i % 2 ? std::nanf("") : 1523.0f; });
  EXPECT_EQ(checkFrameMessages(colour, millimetres, info(8, 6)),
            "");  // headers say nothing of units
  auto frame = frameFromMessages(colour, millimetres, info(8, 6));
  ASSERT_FALSE(frame.ok());
  EXPECT_EQ(frame.error(),
            "32FC1 depth must be metres (REP 118): median valid depth 1523.0 m, beyond any RGB-D "
            "sensor's range "
            "(50 m); millimetres?");
  // Metres pass, a few far outliers among them too, and 16-bit millimetres are REP 118's own.
  EXPECT_TRUE(frameFromMessages(colour, depth32([](int i) { return i < 10 ? 3000.0f : 1.523f; }),
                                info(8, 6))
                  .ok());
  auto depth16 = image(8, 6, enc::TYPE_16UC1, 2);
  for (size_t i = 0; i < depth16.data.size(); i += 2) {
    const uint16_t mm = 1523;
    std::memcpy(&depth16.data[i], &mm, 2);
  }
  EXPECT_TRUE(frameFromMessages(colour, depth16, info(8, 6)).ok());
}

TEST(MessageConversion, FocalLengthsThatGiveNoCameraFieldOfViewAreRefused) {
  const auto colour = image(640, 480, enc::BGR8, 3);
  const auto depth = image(640, 480, enc::TYPE_16UC1, 2);
  auto tiny_fx = info(640, 480);
  tiny_fx.K[0] = 1e-30;
  EXPECT_EQ(checkFrameMessages(colour, depth, tiny_fx),
            "camera_info K gives a 180.0 deg horizontal field of view (fx=1e-30 for width 640): an "
            "RGB-D camera "
            "sees 0.5 to 160 deg; is K in pixels, for this image size?");
  auto huge_fy = info(640, 480);
  huge_fy.K[4] = 1e30;
  EXPECT_EQ(
      checkFrameMessages(colour, depth, huge_fy)
          .rfind("camera_info K gives a 0.0 deg vertical field of view (fy=1e+30 for height 480)",
                 0),
      0u)
      << checkFrameMessages(colour, depth, huge_fy);
  // P, when set, is what is read and named.
  auto p = info(640, 480);
  p.P = {0.3, 0, 320, 0, 0, 525, 240, 0, 0, 0, 1, 0};
  EXPECT_EQ(
      checkFrameMessages(colour, depth, p).rfind("camera_info P gives a 179.9 deg horizontal", 0),
      0u)
      << checkFrameMessages(colour, depth, p);
  // Real cameras pass: Kinect (57 deg), a wide ToF camera (120 deg).
  auto kinect = info(640, 480);
  kinect.K[0] = kinect.K[4] = 585.0;
  EXPECT_EQ(checkFrameMessages(colour, depth, kinect), "");
  auto wide = info(640, 480);
  wide.K[0] = wide.K[4] = 185.0;
  EXPECT_EQ(checkFrameMessages(colour, depth, wide), "");
}

// Issue 23: a 1 MB encoding was echoed whole into the log.
TEST(MessageConversion, StringsFromMessagesAreShortenedInReasons) {
  EXPECT_EQ(messageExcerpt("16UC1"), "16UC1");
  EXPECT_EQ(messageExcerpt(std::string(64, 'a')), std::string(64, 'a'));
  EXPECT_EQ(messageExcerpt(std::string(65, 'a')), std::string(64, 'a') + "... (65 bytes)");
  EXPECT_EQ(messageExcerpt("camera\nWARN forged"), "camera?WARN forged");

  const auto colour = image(8, 6, enc::BGR8, 3);
  const auto depth = image(8, 6, enc::TYPE_16UC1, 2);
  const std::string huge(1 << 20, 'x');
  auto bad_colour = colour;
  bad_colour.encoding = huge;
  EXPECT_EQ(checkFrameMessages(bad_colour, depth, info(8, 6)),
            "unsupported colour encoding '" + std::string(64, 'x') +
                "... (1048576 bytes)' (expected bgr8, rgb8, bgra8, rgba8 or mono8)");
  auto bad_depth = depth;
  bad_depth.encoding = huge;
  EXPECT_LT(checkFrameMessages(colour, bad_depth, info(8, 6)).size(), 200u);
  EXPECT_LT(colourToBgr8(bad_colour).error().size(), 200u);
  auto other_frame = depth;
  other_frame.header.frame_id = huge + "\n";
  const std::string why = checkFrameMessages(colour, other_frame, info(8, 6));
  EXPECT_NE(why.find("depth frame '" + std::string(64, 'x') + "... (1048577 bytes)' differs"),
            std::string::npos)
      << why.substr(0, 300);
  EXPECT_LT(why.size(), 200u);
}

TEST(MessageConversion, StripsLeadingSlashes) {
  EXPECT_EQ(stripLeadingSlashes("/map"), "map");
  EXPECT_EQ(stripLeadingSlashes("//a/b"), "a/b");
  EXPECT_EQ(stripLeadingSlashes("odom"), "odom");
  EXPECT_EQ(stripLeadingSlashes("/"), "");
}

TEST(MessageConversion, PosesRoundTripAndCovarianceIsRowMajor) {
  Pose pose = Pose::Identity();
  pose.linear() = Eigen::AngleAxisd(1.0, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(1, -2, 3);
  EXPECT_TRUE(fromPoseMsg(toPoseMsg(pose)).isApprox(pose, 1e-12));
  EXPECT_TRUE(fromTransformMsg(toTransformMsg(pose)).isApprox(pose, 1e-12));
  relocalizer::Matrix6d covariance = relocalizer::Matrix6d::Zero();
  covariance(0, 5) = 7.0;
  EXPECT_EQ(toPoseWithCovarianceMsg(pose, covariance).covariance[5], 7.0);
}

TEST(FrameBuffer, LatestKeepsOnePendingFrameAndCountsWhatItReplaces) {
  FrameBuffer<int> buffer(FrameBuffer<int>::Policy::Latest);
  buffer.push(1);
  buffer.push(2);
  buffer.push(3);
  EXPECT_EQ(buffer.dropped(), 2u);
  auto taken = buffer.take();
  ASSERT_TRUE(taken);
  EXPECT_EQ(taken->value, 3);
  EXPECT_EQ(taken->seq, 3u);
  EXPECT_EQ(buffer.pendingCount(), 0u);
}

TEST(FrameBuffer, FifoKeepsEveryFrameInOrder) {
  FrameBuffer<int> buffer(FrameBuffer<int>::Policy::Fifo);
  for (int i = 1; i <= 5; ++i) buffer.push(i);
  EXPECT_EQ(buffer.dropped(), 0u);
  for (int i = 1; i <= 5; ++i) EXPECT_EQ(buffer.take()->value, i);
}

TEST(FrameBuffer, NewestWaitsForALaterFrameAndReadsWithoutTaking) {
  using Clock = FrameBuffer<int>::Clock;
  FrameBuffer<int> buffer(FrameBuffer<int>::Policy::Latest);
  EXPECT_FALSE(buffer.newest(0, Clock::now() + std::chrono::milliseconds(20)));
  buffer.push(10);
  EXPECT_EQ(buffer.newest(0, Clock::now())->value, 10);
  EXPECT_EQ(buffer.pendingCount(), 1u);  // still there for the worker
  const uint64_t after = buffer.lastSeq();
  EXPECT_FALSE(buffer.newest(after, Clock::now() + std::chrono::milliseconds(20)));
  std::thread later([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    buffer.push(11);
  });
  auto next = buffer.newest(after, Clock::now() + std::chrono::seconds(5));
  later.join();
  ASSERT_TRUE(next);
  EXPECT_EQ(next->value, 11);
}

TEST(FrameBuffer, ClearForgetsPendingAndLatestButNotTheSequence) {
  using Clock = FrameBuffer<int>::Clock;
  FrameBuffer<int> buffer(FrameBuffer<int>::Policy::Fifo);
  for (int i = 1; i <= 3; ++i) buffer.push(i);
  EXPECT_EQ(buffer.clear(), 3u);
  EXPECT_EQ(buffer.dropped(), 3u);
  EXPECT_EQ(buffer.pendingCount(), 0u);
  EXPECT_EQ(buffer.lastSeq(), 3u);
  // A call for "the latest frame" now waits for one from after the clear.
  EXPECT_FALSE(buffer.newest(0, Clock::now() + std::chrono::milliseconds(20)));
  buffer.push(4);
  auto latest = buffer.newest(0, Clock::now());
  ASSERT_TRUE(latest);
  EXPECT_EQ(latest->value, 4);
  EXPECT_EQ(latest->seq, 4u);
  EXPECT_EQ(buffer.take()->value, 4);
}

TEST(FrameBuffer, CloseWakesEveryWaiter) {
  using Clock = FrameBuffer<int>::Clock;
  FrameBuffer<int> buffer(FrameBuffer<int>::Policy::Fifo);
  std::thread closer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    buffer.close();
  });
  const auto start = Clock::now();
  EXPECT_FALSE(buffer.take());
  EXPECT_FALSE(buffer.newest(0, Clock::now() + std::chrono::seconds(10)));
  EXPECT_FALSE(buffer.sleepUntil(Clock::now() + std::chrono::seconds(10)));
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(5));
  closer.join();
}

// A base 0.5 m beside a camera that is uncertain only about its heading: the
// base swings on the lever arm, sideways by 0.5 m per radian, and is no less
// uncertain about its heading; a base at the camera is as uncertain as it.
TEST(PoseHandoff, CovarianceFollowsTheLeverArm) {
  Matrix6d covariance = Matrix6d::Zero();
  covariance(5, 5) = 0.01;  // rotation about map z, rad^2
  Pose map_T_camera = Pose::Identity();
  map_T_camera.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).matrix();
  map_T_camera.translation() = Eigen::Vector3d(1, 2, 0.3);
  Pose camera_T_base = Pose::Identity();
  camera_T_base.translation() = Eigen::Vector3d(0.5, 0, 0);  // map +y once rotated
  const Matrix6d moved = moveCovariance(covariance, map_T_camera, camera_T_base);
  // The lever points along map y, so the heading moves the base along map -x.
  EXPECT_NEAR(moved(0, 0), 0.25 * 0.01, 1e-12);
  EXPECT_NEAR(moved(1, 1), 0.0, 1e-12);
  EXPECT_NEAR(moved(0, 5), -0.5 * 0.01, 1e-12);
  EXPECT_NEAR(moved(5, 5), 0.01, 1e-12);
  EXPECT_TRUE(moveCovariance(covariance, map_T_camera, Pose::Identity()).isApprox(covariance));
}
