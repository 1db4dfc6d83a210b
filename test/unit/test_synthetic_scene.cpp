#include <gtest/gtest.h>
#include <sys/wait.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <utility>
#include <vector>

#include "relocalizer/core/frame.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/data/dataset.h"
#include "relocalizer/forest/sampling.h"
#include "relocalizer/sim/synthetic_scene.h"
#include "support.h"

using namespace relocalizer;
namespace fs = std::filesystem;

namespace {

using relocalizer::testing::sameImage;

const CameraIntrinsics kSmall = CameraIntrinsics::kinectDefault().scaledTo(320, 240);
const CameraIntrinsics kTiny = CameraIntrinsics::kinectDefault().scaledTo(160, 120);

// NaN where either is NaN, otherwise bitwise equal.
bool sameDepth(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != CV_32FC1 || b.type() != CV_32FC1) return false;
  for (int v = 0; v < a.rows; ++v)
    for (int u = 0; u < a.cols; ++u) {
      const float x = a.at<float>(v, u), y = b.at<float>(v, u);
      if (std::isnan(x) != std::isnan(y) || (!std::isnan(x) && x != y)) return false;
    }
  return true;
}

Pose lookingDownFrom(const SyntheticRoom& room, double height) {
  Pose pose = Pose::Identity();
  // Camera x along world x, y along -y, z (forward) along -z.
  pose.linear() << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  const Eigen::Vector3d centre = room.bounds().center();
  pose.translation() = Eigen::Vector3d(centre.x(), centre.y(), height);
  return pose;
}

// Median gap between neighbouring distinct depths whose exact depth is near z.
double medianDepthGap(const cv::Mat& noisy) {
  std::vector<float> values;
  for (int v = 0; v < noisy.rows; ++v)
    for (int u = 0; u < noisy.cols; ++u)
      if (std::isfinite(noisy.at<float>(v, u))) values.push_back(noisy.at<float>(v, u));
  std::sort(values.begin(), values.end());
  values.erase(std::unique(values.begin(), values.end()), values.end());
  std::vector<double> gaps;
  for (size_t i = 1; i < values.size(); ++i) gaps.push_back(values[i] - values[i - 1]);
  if (gaps.empty()) return 0.0;
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  return gaps[gaps.size() / 2];
}

int lineCount(const std::string& text) {
  return static_cast<int>(std::count(text.begin(), text.end(), '\n'));
}

}  // namespace

// ------------------------------------------------------------------ determinism

TEST(SyntheticScene, SameSeedWritesIdenticalBytesAndOtherSeedsDiffer) {
  relocalizer::testing::TempDir a, b, c;
  SyntheticSceneOptions options;
  options.seed = 7;
  options.train_frames = 5;
  options.test_frames = 3;
  options.camera = kTiny;
  options.moving_objects = true;  // effects must be deterministic too
  options.illumination_change = true;
  ASSERT_TRUE(writeSyntheticScene(a.str(), options).ok());
  ASSERT_TRUE(writeSyntheticScene(b.str(), options).ok());
  const auto first = relocalizer::testing::readTree(a.path()),
             second = relocalizer::testing::readTree(b.path());
  // 8 frames x 3 files, intrinsics and registration per split, scene.json, contact sheet.
  ASSERT_EQ(first.size(), 8u * 3 + 2 * 2 + 2);
  EXPECT_TRUE(first == second);

  options.seed = 8;
  ASSERT_TRUE(writeSyntheticScene(c.str(), options).ok());
  const auto other = relocalizer::testing::readTree(c.path());
  EXPECT_NE(first.at("train/frame-000000.color.png"), other.at("train/frame-000000.color.png"));
  const cv::Mat colour_a = cv::imread((a.path() / "train/frame-000000.color.png").string());
  const cv::Mat colour_c = cv::imread((c.path() / "train/frame-000000.color.png").string());
  EXPECT_GT(cv::norm(colour_a, colour_c, cv::NORM_L1) / colour_a.total(), 10.0)
      << "different seeds should give visibly different rooms";
}

TEST(SyntheticScene, RenderDoesNotDependOnThreadCount) {
  const SyntheticRoom room(3);
  const Pose pose = room.trajectories(40, 0).train[17];
  RenderEffects effects;
  effects.moving_objects = true;
  RgbdFrame one_thread;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one_thread = room.render(pose, kSmall, 17, effects);
  }
  const RgbdFrame many_threads = room.render(pose, kSmall, 17, effects);
  EXPECT_TRUE(sameImage(one_thread.colour, many_threads.colour));
  EXPECT_TRUE(sameDepth(one_thread.depth, many_threads.depth));
}

TEST(SyntheticScene, RoomsVaryWithSeedButKeepTheirSize) {
  for (const uint64_t seed : {1u, 2u, 3u, 99u}) {
    const SyntheticRoom room(seed);
    const Eigen::Vector3d size = room.bounds().sizes();
    EXPECT_GT(size.x(), 5.5);
    EXPECT_LT(size.x(), 6.5);
    EXPECT_GT(size.y(), 4.5);
    EXPECT_LT(size.y(), 5.5);
    EXPECT_GT(size.z(), 2.5);
    EXPECT_LT(size.z(), 3.1);
    EXPECT_GT(room.boxCount(), 80) << "seed " << seed << ": too little furniture";
  }
  EXPECT_NE(SyntheticRoom(1).bounds().sizes(), SyntheticRoom(2).bounds().sizes());
}

// ------------------------------------------------------------------ ground truth

TEST(SyntheticScene, ExactDepthBackProjectsOntoTheRoomsSurfaces) {
  const SyntheticRoom room(5);
  const SyntheticTrajectories paths = room.trajectories(60, 20);
  for (const Pose& pose : {paths.train[0], paths.train[33], paths.test[7]}) {
    const cv::Mat depth = room.exactDepth(pose, kSmall);
    int checked = 0;
    for (int v = 3; v < depth.rows; v += 9)
      for (int u = 5; u < depth.cols; u += 11) {
        const float z = depth.at<float>(v, u);
        ASSERT_TRUE(std::isfinite(z)) << "a closed room has a surface behind every pixel";
        const Eigen::Vector3d camera_point = kSmall.backProject(u, v, z).cast<double>();
        const Eigen::Vector3d world = pose * camera_point;
        // The box distance field is independent of the ray caster.
        EXPECT_LT(room.surfaceDistance(world), 2e-3) << "pixel " << u << "," << v << " z " << z;
        // Casting the same ray again in double precision gives the same depth.
        const std::optional<double> t =
            room.castRay(pose.translation(), pose.linear() * (camera_point / z));
        ASSERT_TRUE(t.has_value());
        EXPECT_NEAR(*t, z, 1e-4 * z);
        ++checked;
      }
    EXPECT_GT(checked, 500);
  }
}

TEST(SyntheticScene, ExactDepthMatchesKnownPlanes) {
  // From the middle of the room: straight down onto the 1 cm rug, which fills
  // the middle of the view, and straight up at the ceiling between the lights.
  const SyntheticRoom room(5);
  const cv::Mat down = room.exactDepth(lookingDownFrom(room, 1.5), kSmall);
  for (int v = kSmall.height / 4; v < 3 * kSmall.height / 4; v += 5)
    for (int u = kSmall.width / 4; u < 3 * kSmall.width / 4; u += 5)
      ASSERT_NEAR(down.at<float>(v, u), 1.49, 1e-5) << u << "," << v;
  Pose up = lookingDownFrom(room, 1.2);
  up.linear() = up.linear() * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const cv::Mat ceiling = room.exactDepth(up, kSmall);
  EXPECT_NEAR(ceiling.at<float>(kSmall.height / 2, kSmall.width / 2), room.bounds().max().z() - 1.2,
              1e-5);
}

TEST(SyntheticScene, ExactDepthIsConsistentAcrossViews) {
  const SyntheticRoom room(11);
  const SyntheticTrajectories paths = room.trajectories(300, 0);
  const Pose& a = paths.train[100];
  const Pose& b = paths.train[112];
  const cv::Mat depth_a = room.exactDepth(a, kSmall), depth_b = room.exactDepth(b, kSmall);
  const Pose b_from_a = b.inverse() * a;
  int inside = 0, consistent = 0;
  for (int v = 0; v < depth_a.rows; v += 4)
    for (int u = 0; u < depth_a.cols; u += 4) {
      const Eigen::Vector3f p =
          (b_from_a * kSmall.backProject(u, v, depth_a.at<float>(v, u)).cast<double>())
              .cast<float>();
      if (p.z() <= 0) continue;
      const Eigen::Vector2f uv = kSmall.project(p);
      const int ub = static_cast<int>(std::lround(uv.x())),
                vb = static_cast<int>(std::lround(uv.y()));
      if (ub < 0 || vb < 0 || ub >= kSmall.width || vb >= kSmall.height) continue;
      ++inside;
      // Occluded points are allowed to disagree; visible ones must agree.
      if (std::abs(depth_b.at<float>(vb, ub) - p.z()) < 0.01f * p.z()) ++consistent;
    }
  ASSERT_GT(inside, 1000);
  EXPECT_GT(static_cast<double>(consistent) / inside, 0.9);
}

TEST(SyntheticScene, MovingObjectsAreNotPartOfTheStaticGroundTruth) {
  const SyntheticRoom room(4);
  const SyntheticTrajectories paths = room.trajectories(300, 0);
  RenderEffects moving;
  moving.moving_objects = true;
  moving.depth_noise = false;
  RenderEffects still = moving;
  still.moving_objects = false;
  int frames_with_distractor = 0;
  for (int i = 0; i < 300; i += 10) {
    const RgbdFrame frame = room.render(paths.train[i], kTiny, i, moving);
    const RgbdFrame clean = room.render(paths.train[i], kTiny, i, still);
    const cv::Mat exact = room.exactDepth(paths.train[i], kTiny);
    EXPECT_TRUE(sameDepth(clean.depth, exact)) << "noise-free render is the exact depth";
    int nearer = 0;
    for (int v = 0; v < exact.rows; ++v)
      for (int u = 0; u < exact.cols; ++u)
        if (frame.depth.at<float>(v, u) < exact.at<float>(v, u) - 0.05f) ++nearer;
    if (nearer > 0.01 * exact.total()) {
      ++frames_with_distractor;
      // It moves: the same view later on shows it elsewhere (or not at all).
      const RgbdFrame later = room.render(paths.train[i], kTiny, i + 40, moving);
      EXPECT_FALSE(sameDepth(frame.depth, later.depth));
    }
  }
  EXPECT_GE(frames_with_distractor, 2) << "distractors should cross the camera's view";
}

// ------------------------------------------------------------------ depth model

TEST(SyntheticScene, NoisyDepthStaysWithinTheKinectNoiseModel) {
  const SyntheticRoom room(2);
  const Pose pose = room.trajectories(300, 0).train[40];
  const CameraIntrinsics camera = CameraIntrinsics::kinectDefault();
  const RgbdFrame noisy = room.render(pose, camera, 40);
  RenderEffects clean_effects;
  clean_effects.depth_noise = false;
  const RgbdFrame clean = room.render(pose, camera, 40, clean_effects);
  EXPECT_TRUE(sameImage(noisy.colour, clean.colour)) << "depth noise must not touch colour";
  int valid = 0, within_3_sigma = 0;
  for (int v = 0; v < camera.height; ++v)
    for (int u = 0; u < camera.width; ++u) {
      const float d = noisy.depth.at<float>(v, u);
      if (!std::isfinite(d)) continue;
      ++valid;
      const double z = clean.depth.at<float>(v, u);
      const double slack = KinectDepthModel::quantisationStep(z) / 2 + 0.0006;
      const double error = std::abs(d - z);
      EXPECT_LT(error, 6 * KinectDepthModel::noiseSigma(z) + slack) << u << "," << v;
      if (error < 3 * KinectDepthModel::noiseSigma(z) + slack) ++within_3_sigma;
      EXPECT_GE(d, KinectDepthModel::kMinDepth);
      EXPECT_LE(d, KinectDepthModel::kMaxDepth);
    }
  EXPECT_GT(valid, 0.6 * camera.width * camera.height);
  EXPECT_GT(static_cast<double>(within_3_sigma) / valid, 0.99);
}

TEST(SyntheticScene, HolesFollowDepthEdges) {
  // Both sides of every big depth jump are dropped; smooth surfaces well away
  // from jumps keep their depth, unless they are glass or dark (windows and
  // screens, hence the median over views).
  const SyntheticRoom room(2);
  const SyntheticTrajectories paths = room.trajectories(300, 0);
  RenderEffects clean_effects;
  clean_effects.depth_noise = false;
  int edge_pixels = 0, edge_holes = 0;
  std::vector<double> smooth_hole_shares;
  for (int i = 0; i < 300; i += 30) {
    const RgbdFrame noisy = room.render(paths.train[i], kSmall, i);
    const RgbdFrame clean = room.render(paths.train[i], kSmall, i, clean_effects);
    int smooth_pixels = 0, smooth_holes = 0;
    for (int v = 4; v < kSmall.height - 4; ++v)
      for (int u = 4; u < kSmall.width - 4; ++u) {
        const float z = clean.depth.at<float>(v, u), right = clean.depth.at<float>(v, u + 1);
        if (std::abs(right - z) > 0.15f * std::min(z, right)) {
          edge_pixels += 2;
          edge_holes += !std::isfinite(noisy.depth.at<float>(v, u));
          edge_holes += !std::isfinite(noisy.depth.at<float>(v, u + 1));
        }
        bool smooth = z > 0.5f && z < 5.5f;
        for (int dv = -4; dv <= 4 && smooth; ++dv)
          for (int du = -4; du <= 4 && smooth; ++du)
            smooth = std::abs(clean.depth.at<float>(v + dv, u + du) - z) <
                     0.02f * z * (1 + std::max(std::abs(du), std::abs(dv)));
        if (smooth) {
          ++smooth_pixels;
          smooth_holes += !std::isfinite(noisy.depth.at<float>(v, u));
        }
      }
    ASSERT_GT(smooth_pixels, 1000) << "frame " << i;
    smooth_hole_shares.push_back(static_cast<double>(smooth_holes) / smooth_pixels);
  }
  ASSERT_GT(edge_pixels, 1000) << "the views should contain depth discontinuities";
  EXPECT_GT(static_cast<double>(edge_holes) / edge_pixels, 0.98);
  std::sort(smooth_hole_shares.begin(), smooth_hole_shares.end());
  EXPECT_LT(smooth_hole_shares[smooth_hole_shares.size() / 2], 0.03);
}

TEST(SyntheticScene, DepthQuantisationStepsGrowWithDistance) {
  EXPECT_NEAR(KinectDepthModel::quantisationStep(1.0), 1.0 / (8 * 0.075 * 585), 1e-12);
  for (const double z : {0.7, 1.3, 2.9, 4.4})
    EXPECT_NEAR(KinectDepthModel::quantise(z), z, KinectDepthModel::quantisationStep(z) * 0.51);

  // Looking straight down at the floor from 1 m and from 2.5 m.
  const SyntheticRoom room(6);
  const RgbdFrame near = room.render(lookingDownFrom(room, 1.0), kSmall, 0);
  const RgbdFrame far = room.render(lookingDownFrom(room, 2.5), kSmall, 0);
  const double near_gap = medianDepthGap(near.depth), far_gap = medianDepthGap(far.depth);
  EXPECT_NEAR(near_gap, KinectDepthModel::quantisationStep(0.99), 0.0011);
  EXPECT_NEAR(far_gap, KinectDepthModel::quantisationStep(2.49), 0.25 * far_gap);
  EXPECT_GT(far_gap, 4 * near_gap);
}

TEST(SyntheticScene, DarkAndTransparentSurfacesAndRangeLimitsGiveHoles) {
  // Far too close to anything: all of it is below the Kinect's range.
  const SyntheticRoom room(6);
  const RgbdFrame close = room.render(lookingDownFrom(room, 0.3), kTiny, 0);
  EXPECT_EQ(countValidDepth(close.depth), 0);
  // Over many views, some pixels are dropped although no depth edge is near
  // (screens and windows).
  const SyntheticTrajectories paths = room.trajectories(300, 0);
  int unexplained = 0;
  for (int i = 0; i < 300; i += 15) {
    const RgbdFrame frame = room.render(paths.train[i], kTiny, i);
    const cv::Mat exact = room.exactDepth(paths.train[i], kTiny);
    for (int v = 3; v < exact.rows - 3; ++v)
      for (int u = 3; u < exact.cols - 3; ++u) {
        const float z = exact.at<float>(v, u);
        bool smooth = z > 0.5f && z < 5.5f;
        for (int dv = -3; dv <= 3 && smooth; ++dv)
          for (int du = -3; du <= 3 && smooth; ++du)
            smooth = std::abs(exact.at<float>(v + dv, u + du) - z) < 0.1f * z;
        if (smooth && !std::isfinite(frame.depth.at<float>(v, u))) ++unexplained;
      }
  }
  EXPECT_GT(unexplained, 200);
}

TEST(SyntheticScene, DepthToMillimetresRoundTrips) {
  cv::Mat metres(1, 5, CV_32FC1);
  metres.at<float>(0) = std::numeric_limits<float>::quiet_NaN();
  metres.at<float>(1) = 1.234f;
  metres.at<float>(2) = 0.0f;
  metres.at<float>(3) = 70.0f;
  metres.at<float>(4) = 5.999f;
  const cv::Mat mm = depthToMillimetres(metres);
  ASSERT_EQ(mm.type(), CV_16UC1);
  EXPECT_EQ(mm.at<uint16_t>(0), 0);
  EXPECT_EQ(mm.at<uint16_t>(1), 1234);
  EXPECT_EQ(mm.at<uint16_t>(2), 0);
  EXPECT_EQ(mm.at<uint16_t>(3), 0);
  EXPECT_EQ(mm.at<uint16_t>(4), 5999);
}

// ------------------------------------------------------------------ files

TEST(SyntheticScene, WrittenFilesReadBackAsTheInMemoryRender) {
  relocalizer::testing::TempDir dir;
  SyntheticSceneOptions options;
  options.seed = 12;
  options.train_frames = 4;
  options.test_frames = 2;
  options.camera = kSmall;
  ASSERT_TRUE(writeSyntheticScene(dir.str(), options).ok());
  const SyntheticRoom room(options.seed);
  const SyntheticTrajectories paths = room.trajectories(4, 2);
  struct Case {
    std::string split;
    int index, time;
    Pose pose;
  };
  for (const Case& c : {Case{"train", 3, 3, paths.train[3]}, Case{"test", 1, 5, paths.test[1]}}) {
    const RgbdFrame expected = room.render(c.pose, kSmall, c.time);
    const std::string stem =
        (dir.path() / c.split / ("frame-00000" + std::to_string(c.index))).string();
    const cv::Mat colour = cv::imread(stem + ".color.png", cv::IMREAD_UNCHANGED);
    EXPECT_TRUE(sameImage(colour, expected.colour)) << stem;
    const cv::Mat raw_depth = cv::imread(stem + ".depth.png", cv::IMREAD_UNCHANGED);
    ASSERT_EQ(raw_depth.type(), CV_16UC1);
    const Expected<cv::Mat> depth = depthToMetres(raw_depth);
    ASSERT_TRUE(depth.ok());
    EXPECT_TRUE(sameDepth(*depth, expected.depth)) << stem;
    std::ifstream pose_file(stem + ".pose.txt");
    Eigen::Matrix4d m;
    for (int i = 0; i < 16; ++i) pose_file >> m(i / 4, i % 4);
    ASSERT_TRUE(pose_file) << stem;
    EXPECT_TRUE(m.isApprox(c.pose.matrix(), 1e-8)) << m;
  }
  std::ifstream k_file(dir.path() / "train" / "camera-intrinsics.txt");
  Eigen::Matrix3d k;
  for (int i = 0; i < 9; ++i) k_file >> k(i / 3, i % 3);
  ASSERT_TRUE(k_file);
  EXPECT_NEAR(k(0, 0), kSmall.fx, 1e-9);
  EXPECT_NEAR(k(1, 2), kSmall.cy, 1e-9);
  EXPECT_EQ(k(2, 2), 1.0);
  EXPECT_EQ(relocalizer::testing::readBytes(dir.path() / "test" / "colour-registration.txt"),
            "registered\n");
  const cv::Mat sheet = cv::imread((dir.path() / "contact_sheet.png").string());
  EXPECT_FALSE(sheet.empty());
  const std::string json = relocalizer::testing::readBytes(dir.path() / "scene.json");
  EXPECT_NE(json.find("\"seed\": 12"), std::string::npos) << json;
}

TEST(SyntheticScene, TheSevenScenesReaderSeesWhatWasRendered) {
  relocalizer::testing::TempDir dir;
  SyntheticSceneOptions options;
  options.seed = 13;
  options.train_frames = 3;
  options.test_frames = 2;
  options.camera = kSmall;
  ASSERT_TRUE(writeSyntheticScene(dir.str(), options).ok());
  const Expected<std::unique_ptr<Dataset>> dataset = openDataset((dir.path() / "test").string());
  ASSERT_TRUE(dataset.ok()) << dataset.error();
  ASSERT_EQ((*dataset)->size(), 2u);
  EXPECT_EQ((*dataset)->camera().width, kSmall.width);
  EXPECT_NEAR((*dataset)->camera().fx, kSmall.fx, 1e-9);
  const SyntheticRoom room(options.seed);
  const Pose truth = room.trajectories(3, 2).test[1];
  ASSERT_TRUE((*dataset)->groundTruth(1).has_value());
  EXPECT_LT(translationError(*(*dataset)->groundTruth(1), truth), 1e-9);
  EXPECT_LT(rotationErrorDegrees(*(*dataset)->groundTruth(1), truth), 1e-6);
  const Expected<RgbdFrame> frame = (*dataset)->load(1);
  ASSERT_TRUE(frame.ok()) << frame.error();
  const RgbdFrame expected = room.render(truth, kSmall, options.train_frames + 1);
  EXPECT_TRUE(sameImage(frame->colour, expected.colour)) << "colour must not be re-registered";
  EXPECT_TRUE(sameDepth(frame->depth, expected.depth));
}

TEST(SyntheticScene, RewritingWithFewerFramesRemovesTheOldTail) {
  relocalizer::testing::TempDir dir;
  SyntheticSceneOptions options;
  options.camera = kTiny;
  options.train_frames = 4;
  options.test_frames = 3;
  ASSERT_TRUE(writeSyntheticScene(dir.str(), options).ok());
  const fs::path unrelated = dir.path() / "train" / "notes.txt";
  std::ofstream(unrelated) << "kept";
  options.train_frames = 2;
  options.test_frames = 1;
  ASSERT_TRUE(writeSyntheticScene(dir.str(), options).ok());
  EXPECT_TRUE(fs::exists(dir.path() / "train" / "frame-000001.color.png"));
  EXPECT_FALSE(fs::exists(dir.path() / "train" / "frame-000002.color.png"));
  EXPECT_FALSE(fs::exists(dir.path() / "train" / "frame-000003.pose.txt"));
  EXPECT_FALSE(fs::exists(dir.path() / "test" / "frame-000001.depth.png"));
  EXPECT_TRUE(fs::exists(unrelated));
}

TEST(SyntheticScene, RejectsUnusableOptions) {
  relocalizer::testing::TempDir dir;
  SyntheticSceneOptions options;
  options.train_frames = 0;
  EXPECT_FALSE(writeSyntheticScene(dir.str(), options).ok());
  options.train_frames = 2;
  options.test_frames = -1;
  EXPECT_FALSE(writeSyntheticScene(dir.str(), options).ok());
  options.test_frames = 1;
  options.camera.fx = 0;
  const Status status = writeSyntheticScene(dir.str(), options);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.error().find("focal"), std::string::npos) << status.error();
  EXPECT_TRUE(fs::is_empty(dir.path())) << "nothing written for bad options";
}

// ------------------------------------------------------------------ texture

TEST(SyntheticScene, ImagesAreTexturedWithManyStraightEdges) {
  const SyntheticRoom room(1);
  const SyntheticTrajectories paths = room.trajectories(300, 0);
  const CameraIntrinsics camera = CameraIntrinsics::kinectDefault();
  int frames = 0, textured_frames = 0, frames_with_lines = 0;
  double textured_share_sum = 0;
  for (int i = 0; i < 300; i += 50) {
    const RgbdFrame frame = room.render(paths.train[i], camera, i);
    cv::Mat grey, gx, gy, magnitude;
    cv::cvtColor(frame.colour, grey, cv::COLOR_BGR2GRAY);
    cv::Sobel(grey, gx, CV_32F, 1, 0);
    cv::Sobel(grey, gy, CV_32F, 0, 1);
    cv::magnitude(gx, gy, magnitude);
    // Share of 40x40 blocks with enough gradient for colour-comparison features.
    int blocks = 0, textured = 0;
    for (int v = 0; v + 40 <= camera.height; v += 40)
      for (int u = 0; u + 40 <= camera.width; u += 40) {
        ++blocks;
        textured += cv::mean(magnitude(cv::Rect(u, v, 40, 40)))[0] > 20.0;
      }
    const double share = static_cast<double>(textured) / blocks;
    textured_share_sum += share;
    textured_frames += share > 0.5;
    // The package's own line detector (OpenCV's LSD is a stub on OpenCV 4.1-4.5.3).
    const std::vector<cv::Vec4f> lines =
        detectSegments(frame.colour, LineDetector::kOwn, 1.0f, true);
    const auto long_lines = std::count_if(lines.begin(), lines.end(), [](const cv::Vec4f& l) {
      return std::hypot(l[2] - l[0], l[3] - l[1]) > 20.0;
    });
    frames_with_lines += long_lines >= 30;
    ++frames;
  }
  EXPECT_GT(textured_share_sum / frames, 0.6);
  EXPECT_GE(textured_frames, frames - 1);
  EXPECT_GE(frames_with_lines, frames - 1);
}

TEST(SyntheticScene, OptionalEffectsChangeColourOnly) {
  const SyntheticRoom room(9);
  const SyntheticTrajectories paths = room.trajectories(300, 0);
  RenderEffects base;
  base.depth_noise = false;
  const RgbdFrame sharp = room.render(paths.train[120], kSmall, 120, base);

  RenderEffects blur = base;
  blur.motion_blur_poses = motionBlurPoses(paths.train, 120, 5, 2.0);
  ASSERT_EQ(blur.motion_blur_poses.size(), 5u);
  const RgbdFrame blurred = room.render(paths.train[120], kSmall, 120, blur);
  EXPECT_TRUE(sameDepth(blurred.depth, sharp.depth));
  auto gradient = [](const cv::Mat& colour) {
    cv::Mat grey, gx;
    cv::cvtColor(colour, grey, cv::COLOR_BGR2GRAY);
    cv::Sobel(grey, gx, CV_32F, 1, 0);
    return cv::norm(gx, cv::NORM_L1);
  };
  EXPECT_LT(gradient(blurred.colour), 0.9 * gradient(sharp.colour));

  RenderEffects light = base;
  light.illumination_change = true;
  std::vector<double> brightness;
  for (const int time : {0, 40, 80, 120}) {
    const RgbdFrame lit = room.render(paths.train[120], kSmall, time, light);
    EXPECT_TRUE(sameDepth(lit.depth, sharp.depth));
    brightness.push_back(cv::mean(lit.colour)[1]);
  }
  const auto [lo, hi] = std::minmax_element(brightness.begin(), brightness.end());
  EXPECT_GT(*hi - *lo, 8.0) << "illumination should visibly change over time";
}

// ------------------------------------------------------------------ trajectories

TEST(SyntheticScene, TrajectoriesAreSmoothDifferentAndCoverEachOther) {
  const SyntheticRoom room(1);
  const SyntheticTrajectories paths = room.trajectories(300, 100);
  ASSERT_EQ(paths.train.size(), 300u);
  ASSERT_EQ(paths.test.size(), 100u);
  const Eigen::AlignedBox3d inside = room.bounds();
  for (const auto* path : {&paths.train, &paths.test}) {
    for (size_t i = 0; i < path->size(); ++i) {
      const Pose& p = (*path)[i];
      EXPECT_TRUE(p.linear().isUnitary(1e-9));
      EXPECT_NEAR(p.linear().determinant(), 1.0, 1e-9);
      EXPECT_TRUE(inside.contains(p.translation()));
      EXPECT_GT(room.surfaceDistance(p.translation()), 0.5);
      if (i == 0) continue;
      const double step = translationError(p, (*path)[i - 1]);
      const double turn = rotationErrorDegrees(p, (*path)[i - 1]);
      EXPECT_GT(step, 0.01);
      EXPECT_LT(step, 0.03);
      EXPECT_GT(turn, 0.5);
      EXPECT_LT(turn, 3.0);
    }
  }
  // Training is a closed loop.
  EXPECT_LT(translationError(paths.train.front(), paths.train.back()), 0.03);

  int covered = 0;
  double nearest_sum = 0;
  for (const Pose& t : paths.test) {
    double nearest = 1e9;
    bool near_view = false;
    for (const Pose& r : paths.train) {
      nearest = std::min(nearest, translationError(t, r));
      near_view = near_view || (translationError(t, r) < 0.3 && rotationErrorDegrees(t, r) < 20);
    }
    covered += near_view;
    nearest_sum += nearest;
  }
  EXPECT_GE(covered, 95) << "test views should be seen from nearby in training";
  EXPECT_GT(nearest_sum / paths.test.size(), 0.08) << "test path must not retrace training";

  // What the camera looks at is roughly 0.8-3.5 m away.
  for (int i = 0; i < 300; i += 30) {
    cv::Mat depth =
        room.exactDepth(paths.train[i], CameraIntrinsics::kinectDefault().scaledTo(64, 48));
    std::vector<float> z(depth.begin<float>(), depth.end<float>());
    std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
    EXPECT_GT(z[z.size() / 2], 0.8);
    EXPECT_LT(z[z.size() / 2], 3.5);
  }
}

TEST(SyntheticScene, ShortSequencesKeepTestInsideTrainingCoverage) {
  const SyntheticRoom room(21);
  const SyntheticTrajectories paths = room.trajectories(30, 10);
  ASSERT_EQ(paths.train.size(), 30u);
  ASSERT_EQ(paths.test.size(), 10u);
  for (const Pose& t : paths.test) {
    bool near_view = false;
    for (const Pose& r : paths.train)
      near_view = near_view || (translationError(t, r) < 0.3 && rotationErrorDegrees(t, r) < 20);
    EXPECT_TRUE(near_view);
  }
  EXPECT_TRUE(room.trajectories(0, 0).train.empty());
}

// ------------------------------------------------------------------ tool

TEST(SyntheticSceneTool, RejectsBadArgumentsWithOneLineNamingTheOptionAndWhatItExpects) {
  relocalizer::testing::TempDir dir;
  const fs::path err = dir.path() / "stderr.txt";
  const std::string out = "--output '" + (dir.path() / "scene").string() + "'";
  const std::string seed = "--seed: expected a whole number from 0 to 18446744073709551615, got ";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {out + " --train-frames -3",
       "--train-frames: expected a whole number from 1 to 1000000, got '-3'"},
      {out + " --train-frames 2.5",
       "--train-frames: expected a whole number from 1 to 1000000, got '2.5'"},
      {out + " --no-such-option", "'--no-such-option'"},
      {out + " --train", "'--train'"},  // no guessing at an abbreviation
      {"--seed 4", "'--output' is required"},
      {out + " --width 320", "--width requires --height"},
      {out + " --test-frames many",
       "--test-frames: expected a whole number from 0 to 1000000, got 'many'"},
      {out + " --seed -1", seed + "'-1'"},
      {out + " --seed 99999999999999999999", seed + "'99999999999999999999'"},
      {out + " --no-walk", "--no-walk requires --rooms"}};
  for (const auto& [arguments, reason] : cases) {
    EXPECT_EQ(relocalizer::testing::runTool("synthesize", arguments, err), 2) << arguments;
    const std::string message = relocalizer::testing::readBytes(err);
    EXPECT_EQ(lineCount(message), 1) << arguments << ": " << message;
    EXPECT_EQ(message.rfind("synthesize: error: ", 0), 0u) << message;
    EXPECT_NE(message.find(reason), std::string::npos) << arguments << ": " << message;
  }
  EXPECT_FALSE(fs::exists(dir.path() / "scene"));
  // --help: usage, every option with its description, default and what it takes.
  const fs::path help = dir.path() / "help.txt";
  EXPECT_EQ(relocalizer::testing::runTool("synthesize", "--help", err, help), 0);
  // Read with each run of spaces and line breaks as one space: --help wraps descriptions.
  std::istringstream words(relocalizer::testing::readBytes(help));
  std::string text;
  for (std::string word; words >> word;) text += word + " ";
  for (const std::string& part :
       {std::string("Usage: synthesize [OPTIONS]"), std::string("procedurally generated room"),
        std::string("-o [ --output ] TEXT"), std::string("[required]"),
        std::string("--train-frames INT (=300)"),
        std::string("Training frames [a whole number "
                    "from 1 to 1000000]"),
        std::string("--seed UINT (=1)"), std::string("--no-walk"), std::string("needs --rooms")})
    EXPECT_NE(text.find(part), std::string::npos) << part << " not in:\n" << text;
  EXPECT_EQ(relocalizer::testing::readBytes(err), "");
}

TEST(SyntheticSceneTool, WritesASmallScene) {
  relocalizer::testing::TempDir dir;
  const fs::path scene = dir.path() / "scene";
  EXPECT_EQ(relocalizer::testing::runTool(
                "synthesize",
                "--output '" + scene.string() +
                    "' --seed 5 --train-frames 3 --test-frames 2 --width 80 --height 60 "
                    "--motion-blur --illumination-change --moving-objects",
                dir.path() / "stderr.txt"),
            0)
      << relocalizer::testing::readBytes(dir.path() / "stderr.txt");
  EXPECT_TRUE(fs::exists(scene / "train" / "frame-000002.depth.png"));
  EXPECT_TRUE(fs::exists(scene / "test" / "frame-000001.pose.txt"));
  EXPECT_FALSE(fs::exists(scene / "test" / "frame-000002.pose.txt"));
  const cv::Mat colour = cv::imread((scene / "test" / "frame-000001.color.png").string());
  EXPECT_EQ(colour.cols, 80);
  EXPECT_EQ(colour.rows, 60);
}
