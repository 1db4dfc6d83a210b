#include <gtest/gtest.h>

#include <sys/resource.h>
#include <tbb/global_control.h>
#include <zlib.h>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <climits>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "relocalizer/core/file_io.h"
#include "relocalizer/forest/forest.h"
#include "relocalizer/forest/mean_shift.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/forest/packed_mode.h"
#include "relocalizer/forest/sampling.h"
#include "relocalizer/forest/training.h"
#include "relocalizer/forest/training_config.h"
#include "relocalizer/relocalize/relocalizer.h"
#include "relocalizer/sim/synthetic_scene.h"
#include "support.h"

using namespace relocalizer;

namespace {

Eigen::Vector3f gaussianSample(std::mt19937& rng, const Eigen::Vector3f& mean,
                               const Eigen::Matrix3f& sqrt_cov) {
  std::normal_distribution<float> n(0.0f, 1.0f);
  return mean + sqrt_cov * Eigen::Vector3f(n(rng), n(rng), n(rng));
}

// Random-texture frames with a fronto-parallel depth ramp: enough structure
// for trees to split, with exactly known world coordinates.
std::vector<TrainingImage> randomImages(int count, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<TrainingImage> images;
  for (int i = 0; i < count; ++i) {
    TrainingImage image;
    image.camera = CameraIntrinsics{100, 100, 40, 30, 80, 60};
    cv::Mat small(15, 20, CV_8UC3);
    cv::randu(small, 0, 255);
    cv::resize(small, image.colour, cv::Size(80, 60), 0, 0, cv::INTER_LINEAR);
    image.depth = cv::Mat(60, 80, CV_32FC1);
    for (int v = 0; v < 60; ++v)
      for (int u = 0; u < 80; ++u) image.depth.at<float>(v, u) = 1.0f + 0.01f * u + 0.005f * v;
    image.depth.at<float>(5, 5) = std::numeric_limits<float>::quiet_NaN();
    image.pose = Pose::Identity();
    image.pose.translation() = Eigen::Vector3d(0.1 * i, 0.0, 0.0);
    images.push_back(image);
  }
  return images;
}

TrainingParams smallParams() {
  TrainingParams p;
  p.points.trees = 2;
  p.points.max_depth = 10;
  p.points.min_samples_leaf = 5;
  p.points.samples_per_image = 300;
  p.points.feature_candidates = 16;
  p.lines = p.points;
  return p;
}

}  // namespace

TEST(Entropy, ClosedFormOfDiagonalGaussian) {
  Eigen::Matrix3d sigma = Eigen::Vector3d(0.04, 0.01, 0.09).asDiagonal();
  const double expected =
      1.5 * std::log(2 * M_PI * M_E) + 0.5 * (std::log(0.04) + std::log(0.01) + std::log(0.09));
  EXPECT_NEAR(gaussianEntropy(sigma), expected, 1e-12);
}

TEST(Entropy, SampleStatisticsMatchTheGaussianTheyCameFrom) {
  std::mt19937 rng(3);
  Eigen::Matrix3f a;
  a << 0.2f, 0.0f, 0.0f, 0.05f, 0.1f, 0.0f, -0.03f, 0.02f, 0.3f;
  const Eigen::Matrix3d sigma = (a * a.transpose()).cast<double>();
  LabelStats stats;
  for (int i = 0; i < 200000; ++i) stats.add(gaussianSample(rng, {1, 2, 3}, a));
  EXPECT_NEAR(stats.entropy(), gaussianEntropy(sigma), 0.02);
  EXPECT_LT((stats.covariance() - sigma).cwiseAbs().maxCoeff(), 2e-3);
}

TEST(MeanShift, RecoversSeparatedClustersWithTheirCovariances) {
  std::mt19937 rng(11);
  const Eigen::Vector3f centre_a(0, 0, 0), centre_b(1, 0.5, 0.2);
  const Eigen::Matrix3f sqrt_a = Eigen::Vector3f(0.02f, 0.03f, 0.015f).asDiagonal();
  Eigen::Matrix3f sqrt_b;
  sqrt_b << 0.03f, 0, 0, 0.01f, 0.02f, 0, 0, 0, 0.025f;
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 3000; ++i) points.push_back(gaussianSample(rng, centre_a, sqrt_a));
  for (int i = 0; i < 1500; ++i) points.push_back(gaussianSample(rng, centre_b, sqrt_b));
  MeanShiftParams params;
  params.min_std = 0.0f;  // no floor: compare covariances exactly
  std::vector<int> assignment;
  const auto modes = meanShiftModes(points, params, &assignment);
  ASSERT_EQ(modes.size(), 2u);
  EXPECT_EQ(modes[0].support, 3000);
  EXPECT_EQ(modes[1].support, 1500);
  EXPECT_LT((modes[0].mean - centre_a).norm(), 0.003f);
  EXPECT_LT((modes[1].mean - centre_b).norm(), 0.003f);
  const Eigen::Matrix3f cov_a = sqrt_a * sqrt_a.transpose(), cov_b = sqrt_b * sqrt_b.transpose();
  EXPECT_LT((modes[0].covariance - cov_a).cwiseAbs().maxCoeff(), 1e-4f);
  EXPECT_LT((modes[1].covariance - cov_b).cwiseAbs().maxCoeff(), 1e-4f);
  EXPECT_EQ(assignment[0], 0);
  EXPECT_EQ(assignment[4000], 1);
}

TEST(MeanShift, DropsWeakModesAndKeepsAtMostMaxModes) {
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 90; ++i) points.emplace_back(0.001f * (i % 3), 0, 0);
  for (int i = 0; i < 5; ++i) points.emplace_back(3.0f, 0, 0);  // 5%: under the 10% share
  const auto modes = meanShiftModes(points, MeanShiftParams{});
  ASSERT_EQ(modes.size(), 1u);
  EXPECT_EQ(modes[0].support, 90);
}

TEST(LineRansac, RejectsInjectedOutliers) {
  std::mt19937 rng(5);
  std::normal_distribution<float> noise(0.0f, 0.002f);
  const Eigen::Vector3f origin(0.2f, -0.1f, 2.0f),
      direction = Eigen::Vector3f(1, 0.5f, 0.2f).normalized();
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 30; ++i)
    points.push_back(origin + direction * (0.02f * i) +
                     Eigen::Vector3f(noise(rng), noise(rng), noise(rng)));
  // Every fourth point jumps to the background, as at a depth edge.
  for (int i = 0; i < 30; i += 4) points[i].z() += 0.5f;
  Line3D line;
  std::vector<int> inliers;
  ASSERT_TRUE(fitLineRansac(points, 0.015f, 64, rng, line, inliers));
  EXPECT_EQ(inliers.size(), 22u);
  for (int i : inliers) EXPECT_NE(i % 4, 0);
  EXPECT_GT(std::abs(line.direction.dot(direction)), 0.999f);
  EXPECT_LT(line.distance(origin), 0.005f);
}

TEST(LineSampling, LsdScaleKeepsTheMinimumWidthAndNeverUpscales) {
  LineSamplingParams quarter;  // the default
  ASSERT_EQ(quarter.lsd_scale, 0.25f);
  ASSERT_EQ(quarter.lsd_min_width_px, 160);
  EXPECT_EQ(lsdScaleFor(quarter, 640), 0.25f);  // 160x120
  EXPECT_EQ(lsdScaleFor(quarter, 320), 0.5f);   // 160x120, not 80x60
  EXPECT_EQ(lsdScaleFor(quarter, 160), 1.0f);
  EXPECT_EQ(lsdScaleFor(quarter, 100), 1.0f);  // narrower than the floor: as it is
  EXPECT_EQ(lsdScaleFor(quarter, 1280), 0.25f);
  LineSamplingParams old;  // config/lsd_half.yaml, and models written before the floor
  old.lsd_scale = 0.5f;
  old.lsd_min_width_px = 0;
  EXPECT_EQ(lsdScaleFor(old, 640), 0.5f);
  EXPECT_EQ(lsdScaleFor(old, 160), 0.5f);
  old.lsd_scale = 0.01f;
  EXPECT_EQ(lsdScaleFor(old, 640), 0.1f);
}

namespace {

bool sameLineSamples(const LineSamples& a, const LineSamples& b) {
  if (a.segments_detected != b.segments_detected || a.samples.size() != b.samples.size() ||
      a.lines.size() != b.lines.size())
    return false;
  for (size_t i = 0; i < a.samples.size(); ++i)
    if (a.samples[i].u != b.samples[i].u || a.samples[i].v != b.samples[i].v ||
        a.samples[i].line != b.samples[i].line)
      return false;
  for (size_t i = 0; i < a.lines.size(); ++i)
    if (a.lines[i].point != b.lines[i].point || a.lines[i].direction != b.lines[i].direction)
      return false;
  return true;
}

LineSamples linesAt(const RgbdFrame& frame, float lsd_scale, int lsd_min_width_px) {
  LineSamplingParams params;
  params.lsd_scale = lsd_scale;
  params.lsd_min_width_px = lsd_min_width_px;
  std::mt19937 rng(3);
  return sampleLines(frame, params, 0, rng);
}

}  // namespace

TEST(LineSampling, SmallFramesKeepTheirLsdResolution) {
  const SyntheticRoom room(4);
  const Pose pose = room.trajectories(60, 0).train[30];
  // The default quarter on 320x240 (the synthetic tests, the rostest fixture,
  // the README's demo): exactly the line samples of half-size LSD, the
  // default before issue 28.
  const RgbdFrame small =
      room.render(pose, CameraIntrinsics::kinectDefault().scaledTo(320, 240), 30);
  const LineSamples kept = linesAt(small, 0.25f, 160);
  EXPECT_TRUE(sameLineSamples(kept, linesAt(small, 0.5f, 0)));
  EXPECT_FALSE(sameLineSamples(kept, linesAt(small, 0.25f, 0))) << "LSD on 80x60 without the floor";
  EXPECT_GE(kept.segments_kept, 10);
  // 160x120: LSD on the whole image.
  const RgbdFrame tiny =
      room.render(pose, CameraIntrinsics::kinectDefault().scaledTo(160, 120), 30);
  EXPECT_TRUE(sameLineSamples(linesAt(tiny, 0.25f, 160), linesAt(tiny, 1.0f, 0)));
}

TEST(Features, SecondPixelIsClampedAndInvalidDepthReadsFar) {
  cv::Mat colour(10, 10, CV_8UC3, cv::Scalar(0, 0, 0));
  colour.at<cv::Vec3b>(0, 9) = cv::Vec3b(200, 100, 50);
  cv::Mat depth(10, 10, CV_32FC1, cv::Scalar(2.0f));
  depth.at<float>(9, 0) = std::numeric_limits<float>::quiet_NaN();
  const FeatureImage image = FeatureImage::of(colour, depth);
  PixelFeature f;
  f.offset_u = 1000;  // 500 px at 2 m: far outside, clamps to column 9
  f.offset_v = -1000;
  f.channel_p = 0;
  f.channel_q = 0;
  EXPECT_FLOAT_EQ(evaluateFeature(f, image, 5, 5, 2.0f), -200.0f);
  f.channel_q = 2;
  EXPECT_FLOAT_EQ(evaluateFeature(f, image, 5, 5, 2.0f), -50.0f);
  PixelFeature d;
  d.type = FeatureType::Depth;
  d.offset_u = -1000;
  d.offset_v = 1000;  // clamps to (0, 9), which has no depth
  EXPECT_FLOAT_EQ(evaluateFeature(d, image, 5, 5, 2.0f), kFarDepth - 2.0f);
  d.offset_u = 2;  // 1 px right at 2 m
  d.offset_v = 0;
  EXPECT_FLOAT_EQ(evaluateFeature(d, image, 5, 5, 2.0f), 0.0f);
}

TEST(Descriptor, UnitLengthAndInvariantToContrastGain) {
  cv::Mat colour(40, 40, CV_8UC3);
  cv::randu(colour, 0, 120);
  cv::Mat brighter = colour * 2;
  cv::Mat depth(40, 40, CV_32FC1, cv::Scalar(1.0f));
  const DescriptorF a =
      computeDescriptor(FeatureImage::of(colour, depth), 20, 20, DescriptorNormalisation::kWhole);
  const DescriptorF b =
      computeDescriptor(FeatureImage::of(brighter, depth), 20, 20, DescriptorNormalisation::kWhole);
  float norm = 0, diff = 0;
  for (int i = 0; i < kDescriptorSize; ++i) {
    norm += a[i] * a[i];
    diff += (a[i] - b[i]) * (a[i] - b[i]);
  }
  EXPECT_NEAR(norm, 1.0f, 1e-5f);
  EXPECT_LT(diff, 1e-8f);
  // A flat patch has only DC energy.
  cv::Mat flat(40, 40, CV_8UC3, cv::Scalar(10, 20, 30));
  const DescriptorF f =
      computeDescriptor(FeatureImage::of(flat, depth), 20, 20, DescriptorNormalisation::kWhole);
  for (int c = 0; c < 3; ++c)
    for (int k = 1; k < kDescriptorPerChannel; ++k)
      EXPECT_EQ(f[c * kDescriptorPerChannel + k], 0.0f);
  EXPECT_GT(f[2 * kDescriptorPerChannel], f[0]);  // red (30) over blue (10)
}

// A warm light multiplies each channel by its own gain: the descriptor scaled
// per channel does not see it, the one scaled as a whole does.
TEST(Descriptor, ScaledPerChannelIgnoresAColourCastThatTheWholeVectorSees) {
  cv::Mat colour(40, 40, CV_8UC3);
  cv::RNG(3).fill(colour, cv::RNG::UNIFORM, 20, 120);
  cv::Mat warm;
  cv::multiply(colour, cv::Scalar(1.0, 1.0, 2.0), warm);  // BGR: twice the red, exactly
  const cv::Mat depth(40, 40, CV_32FC1, cv::Scalar(1.0f));
  auto distance = [&](DescriptorNormalisation normalisation) {
    const DescriptorF a = computeDescriptor(FeatureImage::of(colour, depth), 20, 20, normalisation);
    const DescriptorF b = computeDescriptor(FeatureImage::of(warm, depth), 20, 20, normalisation);
    float squared = 0.0f;
    for (int i = 0; i < kDescriptorSize; ++i) squared += (a[i] - b[i]) * (a[i] - b[i]);
    return std::sqrt(squared);
  };
  EXPECT_LT(distance(DescriptorNormalisation::kPerChannel), 1e-3f);
  EXPECT_GT(distance(DescriptorNormalisation::kWhole), 0.3f);

  const DescriptorF d = computeDescriptor(FeatureImage::of(colour, depth), 20, 20,
                                          DescriptorNormalisation::kPerChannel);
  for (int c = 0; c < 3; ++c) {
    float squared = 0.0f;
    for (int k = 0; k < kDescriptorPerChannel; ++k)
      squared += d[c * kDescriptorPerChannel + k] * d[c * kDescriptorPerChannel + k];
    EXPECT_NEAR(squared, 1.0f / 3.0f, 1e-5f) << "channel " << c;
  }
  // A black channel stays zero rather than dividing by nothing.
  cv::Mat no_blue = colour.clone();
  no_blue.forEach<cv::Vec3b>([](cv::Vec3b& pixel, const int*) { pixel[0] = 0; });
  const DescriptorF z = computeDescriptor(FeatureImage::of(no_blue, depth), 20, 20,
                                          DescriptorNormalisation::kPerChannel);
  for (int k = 0; k < kDescriptorPerChannel; ++k) EXPECT_EQ(z[k], 0.0f);
  EXPECT_EQ(descriptorNormalisationNamed("per_channel"), DescriptorNormalisation::kPerChannel);
  EXPECT_EQ(descriptorNormalisationNamed("whole"), DescriptorNormalisation::kWhole);
  EXPECT_FALSE(descriptorNormalisationNamed("Whole").has_value());
}

namespace {

// The descriptor as first written: 2x2 box filter to 8x8 cells, a full float
// fast WHT of rows then columns, and the 4x4 low-sequency corner. The library
// computes only those 16 coefficients, in integers; the floats must be the same.
DescriptorF referenceDescriptor(const FeatureImage& image, int u, int v) {
  auto hadamard8 = [](float* x, int stride) {
    for (int half = 1; half < 8; half *= 2)
      for (int start = 0; start < 8; start += 2 * half)
        for (int i = start; i < start + half; ++i) {
          const float a = x[i * stride], b = x[(i + half) * stride];
          x[i * stride] = a + b;
          x[(i + half) * stride] = a - b;
        }
  };
  constexpr int kLowSequency[4] = {0, 4, 6, 2};
  float cells[3][64];
  for (int cy = 0; cy < 8; ++cy)
    for (int cx = 0; cx < 8; ++cx) {
      int sum[3] = {0, 0, 0};
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const int y = std::clamp(v - 8 + 2 * cy + dy, 0, image.height - 1);
          const int x = std::clamp(u - 8 + 2 * cx + dx, 0, image.width - 1);
          for (int c = 0; c < 3; ++c) sum[c] += image.colour[y * image.colour_stride + x * 3 + c];
        }
      for (int c = 0; c < 3; ++c) cells[c][cy * 8 + cx] = static_cast<float>(sum[c]);
    }
  DescriptorF out;
  float norm = 0.0f;
  for (int c = 0; c < 3; ++c) {
    for (int row = 0; row < 8; ++row) hadamard8(cells[c] + row * 8, 1);
    for (int col = 0; col < 8; ++col) hadamard8(cells[c] + col, 8);
    for (int sy = 0; sy < 4; ++sy)
      for (int sx = 0; sx < 4; ++sx) {
        const float value = cells[c][kLowSequency[sy] * 8 + kLowSequency[sx]];
        out[c * kDescriptorPerChannel + sy * 4 + sx] = value;
        norm += value * value;
      }
  }
  const float scale = norm > 0.0f ? 1.0f / std::sqrt(norm) : 0.0f;
  for (float& value : out) value *= scale;
  return out;
}

}  // namespace

TEST(Descriptor, SameFloatsAsTheFullFloatTransformInsideAndAtBorders) {
  cv::Mat colour(37, 53, CV_8UC3);
  cv::RNG(7).fill(colour, cv::RNG::UNIFORM, 0, 256);  // not cv::theRNG(): later tests draw from it
  cv::Mat depth(37, 53, CV_32FC1, cv::Scalar(1.0f));
  const FeatureImage image = FeatureImage::of(colour, depth);
  int compared = 0;
  for (int v = -3; v < 40; v += 2)
    for (int u = -3; u < 56; u += 3) {
      const DescriptorF fast = computeDescriptor(image, u, v, DescriptorNormalisation::kWhole);
      const DescriptorF reference = referenceDescriptor(image, u, v);
      for (int i = 0; i < kDescriptorSize; ++i)
        ASSERT_EQ(fast[i], reference[i]) << "pixel (" << u << ", " << v << "), coefficient " << i;
      ++compared;
    }
  EXPECT_GT(compared, 300);
}

bool sameMode(const LeafMode& a, const LeafMode& b) {
  return std::memcmp(&a, &b, sizeof(LeafMode)) == 0;
}

// Packing keeps what RANSAC and refinement read: the mean within half a grid
// step, the Mahalanobis distances within a fraction of a percent, and a
// positive definite information however elongated the mode (half-precision
// rounding of the matrix itself would make this one indefinite).
TEST(PackedMode, KeepsTheMeanTheDistancesAndPositiveDefiniteness) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> where(-4.0f, 6.0f), spread(0.01f, 0.5f);
  std::vector<LeafMode> modes(500);
  for (LeafMode& mode : modes) {
    mode.mean = Eigen::Vector3f(where(rng), where(rng), where(rng) / 3.0f);
    const Eigen::Matrix3f axes = Eigen::Quaternionf::UnitRandom().toRotationMatrix();
    const Eigen::Vector3f sigma(spread(rng), spread(rng), spread(rng));
    mode.setCovariance(axes * sigma.cwiseProduct(sigma).asDiagonal() * axes.transpose());
  }
  LeafMode needle;  // 1 cm across, 1 m along a diagonal
  const Eigen::Vector3f along = Eigen::Vector3f(1, 1, 0.5f).normalized();
  needle.setCovariance(1e-4f * Eigen::Matrix3f::Identity() + 1.0f * along * along.transpose());
  modes.push_back(needle);
  ModeGrid grid;
  std::vector<PackedMode> packed;
  packModes(modes, grid, packed);
  EXPECT_LT(grid.step, 10.0f / 65535.0f * 1.001f);
  for (size_t m = 0; m < modes.size(); ++m) {
    const LeafMode back = unpackMode(packed[m], grid);
    EXPECT_LE((back.mean - modes[m].mean).cwiseAbs().maxCoeff(), 0.51f * grid.step) << m;
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f>(back.informationMatrix())
                  .eigenvalues()
                  .minCoeff(),
              0.0f)
        << m;
    for (int k = 0; k < 20; ++k) {
      const Eigen::Vector3f x = modes[m].mean + 0.1f * Eigen::Vector3f::Random();
      const float truth = modes[m].mahalanobisSquared(x);
      EXPECT_NEAR(back.mahalanobisSquared(back.mean + (x - modes[m].mean)), truth,
                  0.005f * truth + 1e-3f)
          << m;
    }
  }
}

class TrainedTree : public ::testing::Test {
 protected:
  void SetUp() override {
    images_ = randomImages(6, 21);
    params_ = smallParams();
    forest_ = trainForest(images_, ForestKind::Points, params_);
  }
  std::vector<TrainingImage> images_;
  TrainingParams params_;
  Forest forest_;
};

TEST_F(TrainedTree, GrowsWithinLimitsAndEveryLeafHasAMode) {
  ASSERT_EQ(forest_.trees.size(), 2u);
  for (const Tree& t : forest_.trees) {
    EXPECT_GT(t.leafCount(), 10u);
    EXPECT_LE(t.depth(), params_.points.max_depth);
    EXPECT_EQ(t.descriptors.size(), t.modes.size());
    for (const SplitNode& n : t.nodes)
      if (n.isLeaf()) {
        EXPECT_GE(n.leafModes().mode_count, 1u);
      }
  }
}

// The grower routes each sample by the values it scored the split on (nodes
// of at most split_sample_cap samples) or evaluated again: either way the
// training samples, descended as a test frame's are, reach the leaves they
// were grown into, so every leaf gets at least min_samples_leaf of them.
// cv::theRNG is put back after drawing the images: other tests' images come
// from it, and some of their checks hold for the images they get today only.
// The modes keep their mean descriptor scaled as the model says, so a mode and
// a test frame's sample are compared on the same terms. The training images'
// blue is faint: scaled as a whole, blue would have far less than a third of
// each descriptor's energy.
TEST(TreeGrowing, ModesKeepTheDescriptorScalingTheModelNames) {
  const cv::RNG before = cv::theRNG();
  std::vector<TrainingImage> images = randomImages(6, 21);
  cv::theRNG() = before;
  for (TrainingImage& image : images)
    cv::multiply(image.colour, cv::Scalar(0.25, 1.0, 1.0), image.colour);
  auto blueShare = [](const Descriptor& d) {
    double blue = 0.0, others = 0.0;
    for (int i = 0; i < kKeptDescriptorSize; ++i) {
      (i < kKeptPerChannel ? blue : others) += d[i] * d[i];
    }
    return blue / (blue + others);
  };
  TrainingParams params = smallParams();
  for (DescriptorNormalisation normalisation :
       {DescriptorNormalisation::kPerChannel, DescriptorNormalisation::kWhole}) {
    params.descriptor_normalisation = normalisation;
    const Forest forest = trainForest(images, ForestKind::Points, params);
    double lowest = 1.0, highest = 0.0;
    size_t modes = 0;
    for (const Tree& tree : forest.trees)
      for (const Descriptor& d : tree.descriptors) {
        lowest = std::min(lowest, blueShare(d));
        highest = std::max(highest, blueShare(d));
        ++modes;
      }
    ASSERT_GT(modes, 20u);
    if (normalisation == DescriptorNormalisation::kPerChannel) {
      EXPECT_GT(lowest, 0.3);  // a third, but for the int8 rounding
      EXPECT_LT(highest, 0.37);
    } else {
      EXPECT_LT(highest, 0.2);
    }
  }
  // The header keeps the choice; models written before it scaled the whole vector.
  params.descriptor_normalisation = DescriptorNormalisation::kPerChannel;
  nlohmann::json header = nlohmann::json::parse(trainingParamsToJson(params));
  EXPECT_EQ(header["descriptor_normalisation"], "per_channel");
  auto same = trainingParamsFromJson(header.dump());
  ASSERT_TRUE(same.ok()) << same.error();
  EXPECT_EQ(same->descriptor_normalisation, DescriptorNormalisation::kPerChannel);
  header.erase("descriptor_normalisation");
  auto older = trainingParamsFromJson(header.dump());
  ASSERT_TRUE(older.ok()) << older.error();
  EXPECT_EQ(older->descriptor_normalisation, DescriptorNormalisation::kWhole);
  const auto wrong = parseTrainingParams("descriptor_normalisation: per_pixel\n", "d.yaml");
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().find("'descriptor_normalisation' must be"), std::string::npos)
      << wrong.error();
  // Samples described one way are not another model's.
  SamplingRecipe whole, per_channel;
  per_channel.descriptor_normalisation = DescriptorNormalisation::kPerChannel;
  EXPECT_FALSE(whole.sameAs(per_channel));
}

TEST(TreeGrowing, TrainingSamplesDescendToTheLeavesTheyWereGrownInto) {
  const cv::RNG before = cv::theRNG();
  const std::vector<TrainingImage> images = randomImages(6, 21);
  cv::theRNG() = before;
  const TrainingParams params = smallParams();
  const Forest forest = trainForest(images, ForestKind::Points, params);
  const std::vector<TreeSamples> drawn = drawTreeSamples(images, ForestKind::Points, params);
  ASSERT_EQ(drawn.size(), forest.trees.size());
  for (size_t t = 0; t < drawn.size(); ++t) {
    const Tree& tree = forest.trees[t];
    ASSERT_GT(drawn[t].items.size(), static_cast<size_t>(params.points.split_sample_cap));
    // Leaves by their first mode; a leaf without modes (mean shift kept none)
    // shares it with the next leaf, whose count it then adds to.
    size_t leaves_with_modes = 0;
    for (const SplitNode& node : tree.nodes)
      if (node.isLeaf() && node.leafModes().mode_count > 0) ++leaves_with_modes;
    std::map<uint32_t, int> per_leaf;
    for (const TreeSamples::Item& item : drawn[t].items) {
      const LeafRange leaf = tree.descend(images[item.image].view(), item.u, item.v, item.depth);
      if (leaf.mode_count > 0) ++per_leaf[leaf.first_mode];
    }
    EXPECT_EQ(per_leaf.size(), leaves_with_modes);
    for (const auto& [leaf, count] : per_leaf)
      EXPECT_GE(count, params.points.min_samples_leaf) << "leaf with first mode " << leaf;
  }
}

TEST_F(TrainedTree, OneLeafBacktrackingEqualsPlainDescentAndMoreLeavesNeverWorsen) {
  std::mt19937 rng(1);
  const TrainingImage& image = images_[2];
  RgbdFrame frame;
  frame.colour = image.colour;
  frame.depth = image.depth;
  frame.camera = image.camera;
  std::vector<Sample> samples;
  samplePoints(frame, 200, rng, samples);
  std::vector<Descriptor> descriptors;
  computeDescriptors(image.view(), samples, DescriptorNormalisation::kWhole, descriptors);
  const Tree& tree = forest_.trees[0];
  for (size_t i = 0; i < samples.size(); ++i) {
    const Sample& s = samples[i];
    const LeafRange range = tree.descend(image.view(), s.u, s.v, s.depth);
    int32_t nearest = std::numeric_limits<int32_t>::max();
    for (uint32_t m = range.first_mode; m < range.first_mode + range.mode_count; ++m)
      nearest = std::min(nearest, descriptorDistance(tree.descriptors[m], descriptors[i]));
    const ModeCandidate one = predictInTree(tree, image.view(), s, descriptors[i], 1);
    ASSERT_TRUE(one.found());
    EXPECT_EQ(one.descriptor_distance, nearest);
    bool of_the_leaf = false;
    for (uint32_t m = range.first_mode; m < range.first_mode + range.mode_count; ++m)
      of_the_leaf = of_the_leaf || sameMode(one.mode, tree.mode(m));
    EXPECT_TRUE(of_the_leaf) << "sample " << i;
    int32_t previous = one.descriptor_distance;
    for (int leaves = 2; leaves <= 16; leaves *= 2) {
      const ModeCandidate more = predictInTree(tree, image.view(), s, descriptors[i], leaves);
      EXPECT_LE(more.descriptor_distance, previous);
      previous = more.descriptor_distance;
    }
  }
}

// predictForest descends many samples in lock-step; each tree's candidate must
// be exactly the one the one-sample-at-a-time predictInTree gives, for any
// backtracking budget, sample count (partial lane groups) and tree layout.
TEST_F(TrainedTree, LockStepPredictionEqualsPerSamplePrediction) {
  Forest forest = forest_;
  forest.trees.push_back(Tree{});  // a tree without nodes contributes no candidate
  forest.trees.push_back(forest_.trees[0]);
  std::mt19937 rng(5);
  for (int image_index : {1, 4}) {
    const TrainingImage& image = images_[image_index];
    RgbdFrame frame;
    frame.colour = image.colour;
    frame.depth = image.depth;
    frame.camera = image.camera;
    for (int count : {1, 17, 600}) {
      std::vector<Sample> samples;
      samplePoints(frame, count, rng, samples);
      std::vector<Descriptor> descriptors;
      computeDescriptors(image.view(), samples, DescriptorNormalisation::kWhole, descriptors);
      for (int max_leaves : {1, 2, 3, 8, 16}) {
        PredictionParams params;
        params.max_leaves = max_leaves;
        std::vector<Prediction> predictions;
        predictForest(forest, image.view(), samples, descriptors, params, predictions);
        ASSERT_EQ(predictions.size(), samples.size());
        for (size_t i = 0; i < samples.size(); ++i) {
          std::vector<ModeCandidate> expected;
          for (const Tree& tree : forest.trees) {
            const ModeCandidate c =
                predictInTree(tree, image.view(), samples[i], descriptors[i], max_leaves);
            if (c.found()) expected.push_back(c);
          }
          ASSERT_EQ(predictions[i].count, static_cast<int>(expected.size()));
          for (size_t k = 0; k < expected.size(); ++k) {
            EXPECT_TRUE(sameMode(predictions[i].candidates[k].mode, expected[k].mode))
                << "sample " << i << ", candidate " << k << ", max_leaves " << max_leaves;
            EXPECT_EQ(predictions[i].candidates[k].descriptor_distance,
                      expected[k].descriptor_distance);
          }
        }
      }
    }
  }
}

TEST_F(TrainedTree, SameSeedGivesSameModelBytesForAnyThreadCount) {
  Model a;
  a.params = params_;
  a.points = forest_;
  Model b = a;
  {
    tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
    b.points = trainForest(images_, ForestKind::Points, params_);
  }
  EXPECT_EQ(serializeModel(a), serializeModel(b));
  Model c = a;
  c.params.seed = 43;
  c.points = trainForest(images_, ForestKind::Points, c.params);
  c.params = a.params;
  EXPECT_NE(serializeModel(a), serializeModel(c));
}

class ModelFile : public TrainedTree {
 protected:
  void SetUp() override {
    TrainedTree::SetUp();
    model_.params = params_;
    model_.points = forest_;
    model_.lines = trainForest(images_, ForestKind::Points, params_);
    model_.summary.dataset = "random";
    model_.summary.images = 6;
    model_.summary.scene_max = Eigen::Vector3f(1, 2, 3);
    model_.surface = SurfaceModel(0.02f, {{Eigen::Vector3f(1, 2, 3), Eigen::Vector3f::UnitX()},
                                          {Eigen::Vector3f(1, 2.5f, 3), Eigen::Vector3f::UnitY()}});
    path_ = dir_.str() + "/model.bin";
    ASSERT_TRUE(saveModel(model_, path_).ok());
    std::ifstream in(path_, std::ios::binary);
    bytes_.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  std::string writeVariant(const std::vector<uint8_t>& bytes) {
    const std::string p = dir_.str() + "/variant.bin";
    std::ofstream(p, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    return p;
  }
  relocalizer::testing::TempDir dir_;
  Model model_;
  std::string path_;
  std::vector<uint8_t> bytes_;
};

TEST_F(ModelFile, RoundTripIsByteIdentical) {
  auto loaded = loadModel(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  EXPECT_EQ(serializeModel(*loaded), bytes_);
  EXPECT_EQ(loaded->summary.dataset, "random");
  EXPECT_EQ(loaded->points.trees.size(), 2u);
  EXPECT_EQ(loaded->params.points.min_samples_leaf, 5);
}

TEST_F(ModelFile, SurfaceRoundTrips) {
  auto loaded = loadModel(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  ASSERT_EQ(loaded->surface.elements().size(), 2u);
  EXPECT_EQ(loaded->surface.voxelSize(), 0.02f);
  EXPECT_EQ(loaded->surface.elements()[1].point, Eigen::Vector3f(1, 2.5f, 3));
  EXPECT_EQ(loaded->surface.elements()[1].normal, Eigen::Vector3f::UnitY());
  // The lookup index is rebuilt on load.
  ASSERT_NE(loaded->surface.near(Eigen::Vector3f(1.005f, 2.5f, 3.0f)), nullptr);
}

namespace {

void appendBytes(std::vector<uint8_t>& out, const void* data, size_t n) {
  out.insert(out.end(), static_cast<const uint8_t*>(data), static_cast<const uint8_t*>(data) + n);
}

// The header JSON as every format stores it: its length, then its text.
void putHeader(std::vector<uint8_t>& body, const nlohmann::json& header_json) {
  const std::string header = header_json.dump();
  const uint32_t size = static_cast<uint32_t>(header.size());
  appendBytes(body, &size, 4);
  appendBytes(body, header.data(), header.size());
}

// `body` behind a model file's preamble of `version`.
std::vector<uint8_t> withPreamble(uint32_t version, const std::vector<uint8_t>& body) {
  std::vector<uint8_t> out = {'P', 'L', 'F', 'O', 'R', 'E', 'S', 'T'};
  const uint32_t reserved = 0;
  const uint64_t size = body.size();
  const uint32_t crc =
      static_cast<uint32_t>(crc32(0L, body.data(), static_cast<uInt>(body.size())));
  for (const auto& [data, n] : std::initializer_list<std::pair<const void*, size_t>>{
           {&version, 4}, {&reserved, 4}, {&size, 8}, {&crc, 4}})
    appendBytes(out, data, n);
  out.insert(out.end(), body.begin(), body.end());
  return out;
}

// A descriptor as formats 1 to 4 stored it, all 48 coefficients: the kept ones
// where they stand, the others (which loading drops) a pattern of their own.
std::array<int8_t, kDescriptorSize> wholeDescriptor(const Descriptor& kept) {
  std::array<int8_t, kDescriptorSize> whole;
  for (int i = 0; i < kDescriptorSize; ++i) whole[i] = static_cast<int8_t>(i - 20);
  for (int c = 0; c < kDescriptorChannels; ++c)
    for (int k = 0; k < kKeptPerChannel; ++k)
      whole[c * kDescriptorPerChannel + k] = kept[c * kKeptPerChannel + k];
  return whole;
}

// `planes` of `count` elements of `size` bytes, byte plane by byte plane, as
// formats 3 to 5 store a tree's arrays.
void appendBytePlanes(std::vector<uint8_t>& out, const void* data, size_t count, size_t size) {
  const auto* bytes = static_cast<const uint8_t*>(data);
  for (size_t b = 0; b < size; ++b)
    for (size_t i = 0; i < count; ++i) out.push_back(bytes[i * size + b]);
}

void expectSameForest(const Forest& a, const Forest& b) {
  ASSERT_EQ(a.trees.size(), b.trees.size());
  for (size_t t = 0; t < a.trees.size(); ++t) {
    const Tree& x = a.trees[t];
    const Tree& y = b.trees[t];
    ASSERT_EQ(x.nodes.size(), y.nodes.size());
    ASSERT_EQ(x.modes.size(), y.modes.size());
    ASSERT_EQ(x.descriptors.size(), y.descriptors.size());
    EXPECT_EQ(std::memcmp(x.nodes.data(), y.nodes.data(), x.nodes.size() * sizeof(SplitNode)), 0)
        << "tree " << t;
    EXPECT_EQ(std::memcmp(x.modes.data(), y.modes.data(), x.modes.size() * sizeof(PackedMode)), 0)
        << "tree " << t;
    EXPECT_EQ(std::memcmp(&x.grid, &y.grid, sizeof(ModeGrid)), 0) << "tree " << t;
    EXPECT_EQ(x.descriptors, y.descriptors) << "tree " << t;
  }
}

// The model as format version 1 (relocalizer 0.1.0) or 2 wrote it: leaf nodes
// hold -(leaf index + 1) into a range array, modes are 92 bytes with the
// descriptor inline (support and log-determinant, which nothing reads, are
// written as given), nothing compressed. Version 2 appends the surface and
// names it in the header; version 1 has neither.
std::vector<uint8_t> oldVersionBytes(const Model& model, uint32_t version, float support = 7.0f) {
  std::vector<uint8_t> body;
  auto put = [&body](const void* data, size_t n) { appendBytes(body, data, n); };
  auto put32 = [&put](uint32_t v) { put(&v, 4); };
  nlohmann::json header_json = nlohmann::json::parse(modelHeaderJson(model, -1));
  header_json["format_version"] = version;
  header_json["training_set"].erase("light_chromaticity");  // kept since version 3
  if (version == 1) {
    header_json.erase("surface");
    header_json["params"].erase("surface");
  }
  putHeader(body, header_json);
  for (const Forest* forest : {&model.points, &model.lines}) {
    put32(static_cast<uint32_t>(forest->trees.size()));
    for (const Tree& tree : forest->trees) {
      std::vector<SplitNode> nodes = tree.nodes;
      std::vector<LeafRange> leaves;
      for (SplitNode& n : nodes)
        if (n.isLeaf()) {
          leaves.push_back(n.leafModes());
          n = SplitNode{};
          n.left = -static_cast<int32_t>(leaves.size());  // leaf index k is -(k + 1)
        }
      put32(static_cast<uint32_t>(nodes.size()));
      put(nodes.data(), nodes.size() * sizeof(SplitNode));
      put32(static_cast<uint32_t>(leaves.size()));
      put(leaves.data(), leaves.size() * sizeof(LeafRange));
      put32(static_cast<uint32_t>(tree.modes.size()));
      for (size_t m = 0; m < tree.modes.size(); ++m) {
        const LeafMode mode = tree.mode(static_cast<uint32_t>(m));
        put(mode.mean.data(), 12);
        put(&support, 4);
        put(mode.information.data(), 24);
        const float log_det = -9.0f;
        put(&log_det, 4);
        put(wholeDescriptor(tree.descriptors[m]).data(), kDescriptorSize);
      }
    }
  }
  if (version == 2) {
    const float voxel_size = model.surface.voxelSize();
    put(&voxel_size, 4);
    put32(static_cast<uint32_t>(model.surface.elements().size()));
    put(model.surface.elements().data(), model.surface.elements().size() * sizeof(SurfaceElement));
  }
  return withPreamble(version, body);
}

// The model as format version 3 or 4 wrote it: each tree's nodes, its modes
// at full precision (LeafMode) and its descriptors whole, byte plane by byte
// plane and deflated; then the surface, and in version 4 the view lights.
std::vector<uint8_t> fullPrecisionVersionBytes(const Model& model, uint32_t version) {
  std::vector<uint8_t> body;
  auto put = [&body](const void* data, size_t n) { appendBytes(body, data, n); };
  auto put32 = [&put](uint32_t v) { put(&v, 4); };
  nlohmann::json header_json = nlohmann::json::parse(modelHeaderJson(model, -1));
  header_json["format_version"] = version;
  putHeader(body, header_json);
  for (const Forest* forest : {&model.points, &model.lines}) {
    put32(static_cast<uint32_t>(forest->trees.size()));
    for (const Tree& tree : forest->trees) {
      std::vector<LeafMode> modes;
      std::vector<std::array<int8_t, kDescriptorSize>> descriptors;
      for (size_t m = 0; m < tree.modes.size(); ++m) {
        modes.push_back(tree.mode(static_cast<uint32_t>(m)));
        descriptors.push_back(wholeDescriptor(tree.descriptors[m]));
      }
      std::vector<uint8_t> raw;
      appendBytePlanes(raw, tree.nodes.data(), tree.nodes.size(), sizeof(SplitNode));
      appendBytePlanes(raw, modes.data(), modes.size(), sizeof(LeafMode));
      appendBytePlanes(raw, descriptors.data(), descriptors.size(), kDescriptorSize);
      uLongf stored = compressBound(static_cast<uLong>(raw.size()));
      std::vector<uint8_t> deflated(stored);
      EXPECT_EQ(compress2(deflated.data(), &stored, raw.data(), static_cast<uLong>(raw.size()), 1),
                Z_OK);
      put32(static_cast<uint32_t>(tree.nodes.size()));
      put32(static_cast<uint32_t>(modes.size()));
      const uint64_t stored_size = stored;
      put(&stored_size, 8);
      put(deflated.data(), stored);
    }
  }
  const float voxel_size = model.surface.voxelSize();
  put(&voxel_size, 4);
  put32(static_cast<uint32_t>(model.surface.elements().size()));
  put(model.surface.elements().data(), model.surface.elements().size() * sizeof(SurfaceElement));
  if (version >= 4) {
    put32(static_cast<uint32_t>(model.summary.view_lights.size()));
    put(model.summary.view_lights.data(), model.summary.view_lights.size() * sizeof(LightGrid));
  }
  return withPreamble(version, body);
}

}  // namespace

TEST_F(ModelFile, RoundTripKeepsEveryNodeModeAndDescriptor) {
  auto loaded = loadModel(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  expectSameForest(loaded->points, model_.points);
  expectSameForest(loaded->lines, model_.lines);
  // Deflated byte planes: well under the arrays' own size.
  size_t raw = 0;
  for (const Forest* f : {&model_.points, &model_.lines})
    for (const Tree& t : f->trees)
      raw += t.nodes.size() * sizeof(SplitNode) +
             t.modes.size() * (sizeof(PackedMode) + sizeof(Descriptor));
  EXPECT_LT(bytes_.size(), raw * 3 / 4);
}

TEST_F(ModelFile, VersionOneLoadsTheSameForestsWithoutASurfaceAndSaysSo) {
  const std::vector<uint8_t> old = oldVersionBytes(model_, 1);
  auto loaded = loadModel(writeVariant(old));
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  expectSameForest(loaded->points, model_.points);
  expectSameForest(loaded->lines, model_.lines);
  EXPECT_EQ(loaded->summary.dataset, "random");
  EXPECT_TRUE(loaded->surface.empty());
  const Relocalizer relocalizer(*loaded);
  EXPECT_NE(relocalizer.limitations().find("no scene surface"), std::string::npos)
      << relocalizer.limitations();
  EXPECT_EQ(Relocalizer(model_).limitations(), "");
}

// Formats 3 and 4 kept every mode at full precision and every descriptor
// whole: they load packed as training packs, the same model.
TEST_F(ModelFile, VersionFourLoadsAsTheSameModelAndSavesAsTheCurrentVersion) {
  Model lit = model_;
  lit.summary.view_lights = {LightGrid{}};
  auto loaded = loadModel(writeVariant(fullPrecisionVersionBytes(lit, 4)));
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  expectSameForest(loaded->points, model_.points);
  expectSameForest(loaded->lines, model_.lines);
  EXPECT_EQ(loaded->summary.view_lights.size(), 1u);
  EXPECT_EQ(serializeModel(*loaded), serializeModel(lit));
}

TEST_F(ModelFile, VersionTwoLoadsAsTheSameModelAndSavesAsTheCurrentVersion) {
  const std::vector<uint8_t> old = oldVersionBytes(model_, 2);
  auto loaded = loadModel(writeVariant(old));
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  expectSameForest(loaded->points, model_.points);
  expectSameForest(loaded->lines, model_.lines);
  ASSERT_EQ(loaded->surface.elements().size(), 2u);
  EXPECT_EQ(loaded->surface.elements()[1].point, Eigen::Vector3f(1, 2.5f, 3));
  EXPECT_EQ(serializeModel(*loaded), bytes_);
}

// The light the forests learned colour in (light_retry.h asks a frame again
// in it) is kept in the header; files written before it was kept load as not
// knowing it, which turns the retry off for them.
TEST_F(ModelFile, TheTrainingLightRoundTripsAndOlderFilesDoNotKnowIt) {
  Model lit = model_;
  lit.summary.light_chromaticity = Eigen::Vector3f(0.875f, 0.955f, 1.19f);
  const std::string path = dir_.str() + "/lit.bin";
  ASSERT_TRUE(saveModel(lit, path).ok());
  auto loaded = loadModel(path);
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  EXPECT_EQ(loaded->summary.light_chromaticity, lit.summary.light_chromaticity);
  auto old = loadModel(writeVariant(oldVersionBytes(lit, 2)));
  ASSERT_TRUE(old.ok()) << old.error();
  EXPECT_EQ(old->summary.light_chromaticity, Eigen::Vector3f::Zero());
}

// Where each training image's light fell (light_retry.h matches a frame's
// with them) follows the surface; a version-3 file, written before they were
// kept, loads without them, and a view light no image can have is refused.
TEST_F(ModelFile, TheViewLightsRoundTripAndVersionThreeFilesLoadWithoutThem) {
  Model lit = model_;
  LightGrid grid{};
  for (size_t i = 0; i < grid.size(); ++i) grid[i] = 0.001f * static_cast<float>(i);
  lit.summary.view_lights = {grid, LightGrid{}};
  const std::vector<uint8_t> bytes = serializeModel(lit);
  auto loaded = deserializeModel(bytes.data(), bytes.size(), "lit.model");
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  EXPECT_EQ(loaded->summary.view_lights, lit.summary.view_lights);

  // Version 3: version 4's trees (modes at full precision, descriptors whole)
  // without the view lights.
  const std::vector<uint8_t> version_three = fullPrecisionVersionBytes(model_, 3);
  auto old = loadModel(writeVariant(version_three));
  ASSERT_TRUE(old.ok()) << old.error();
  EXPECT_TRUE(old->summary.view_lights.empty());
  expectSameForest(old->points, model_.points);
  EXPECT_EQ(old->surface.elements().size(), 2u);

  for (float impossible : {-0.5f, std::numeric_limits<float>::quiet_NaN(), 1.5f}) {
    Model broken = lit;
    broken.summary.view_lights[1][7] = impossible;
    const std::vector<uint8_t> broken_bytes = serializeModel(broken);
    auto refused = deserializeModel(broken_bytes.data(), broken_bytes.size(), "lit.model");
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error(),
              "lit.model: invalid view lights: a cell's mean linear light is not in 0..1");
  }
}

TEST_F(ModelFile, OldVersionsLeafIndicesAreChecked) {
  // -(INT32_MIN + 1) overflows int32: the check must not.
  for (uint32_t version : {1u, 2u})
    for (int32_t code : {INT32_MIN, -100000}) {
      SCOPED_TRACE("version " + std::to_string(version) + ", code " + std::to_string(code));
      const Tree& tree = model_.points.trees[0];
      // oldVersionBytes numbers the leaves itself; corrupt its output instead.
      std::vector<uint8_t> bytes = oldVersionBytes(model_, version);
      uint32_t header_size = 0;
      std::memcpy(&header_size, bytes.data() + 28, 4);
      const size_t first_node =
          28 + 4 + header_size + 4 + 4;  // after the tree count and node count
      size_t leaf = 0;
      while (!tree.nodes[leaf].isLeaf()) ++leaf;
      std::memcpy(bytes.data() + first_node + leaf * sizeof(SplitNode) + 12, &code, 4);
      const uint32_t crc =
          static_cast<uint32_t>(crc32(0L, bytes.data() + 28, static_cast<uInt>(bytes.size() - 28)));
      std::memcpy(bytes.data() + 24, &crc, 4);
      auto r = deserializeModel(bytes.data(), bytes.size(), "old.model");
      ASSERT_FALSE(r.ok());
      EXPECT_EQ(r.error(), "old.model: invalid forest: leaf index out of range");
    }
}

TEST_F(ModelFile, RejectsWrongMagic) {
  auto b = bytes_;
  b[0] = 'X';
  auto r = loadModel(writeVariant(b));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("wrong magic"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("variant.bin"), std::string::npos);
}

TEST_F(ModelFile, RejectsFutureVersion) {
  auto b = bytes_;
  b[8] = static_cast<uint8_t>(kModelFormatVersion + 1);
  auto r = loadModel(writeVariant(b));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("format version " + std::to_string(kModelFormatVersion + 1) +
                           " is not supported"),
            std::string::npos)
      << r.error();
}

TEST_F(ModelFile, RejectsTruncation) {
  for (size_t keep : {size_t{4}, size_t{20}, bytes_.size() / 2, bytes_.size() - 1}) {
    auto b = bytes_;
    b.resize(keep);
    auto r = loadModel(writeVariant(b));
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(r.error().find("truncated") != std::string::npos ||
                r.error().find("wrong magic") != std::string::npos)
        << r.error();
  }
}

TEST_F(ModelFile, RejectsChecksumMismatch) {
  auto b = bytes_;
  b[b.size() - 7] ^= 0x40;
  auto r = loadModel(writeVariant(b));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("checksum mismatch"), std::string::npos) << r.error();
}

TEST_F(ModelFile, RejectsOtherFileTypesAndMissingFiles) {
  const std::string png = dir_.str() + "/image.png";
  cv::imwrite(png, cv::Mat(4, 4, CV_8UC3, cv::Scalar(1, 2, 3)));
  auto r = loadModel(png);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("not a relocalizer model"), std::string::npos);
  auto missing = loadModel(dir_.str() + "/nope.bin");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().find("cannot open"), std::string::npos);
  // A directory opens as a stream and claims an absurd size: an error, not std::bad_alloc.
  auto folder = loadModel(dir_.str());
  ASSERT_FALSE(folder.ok());
  EXPECT_NE(folder.error().find("is a directory, not a model file"), std::string::npos)
      << folder.error();
}

std::vector<uint8_t> fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<std::string> namesIn(const std::string& folder) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// Issue 41: saveModel truncated the file and wrote in place, so a write that
// failed half way (a full disk) left half a model where the old one was.
TEST_F(ModelFile, ASaveThatFailsMidwayLeavesTheOldFileWholeAndNoTemporary) {
  Model other = model_;
  other.summary.dataset = "another";
  const std::vector<uint8_t> other_bytes = serializeModel(other);
  ASSERT_NE(other_bytes, bytes_);
  // No file of this process may grow past half the new model: its write fails midway, as on a
  // full disk (a read-only folder would not stop root).
  struct rlimit unlimited = {};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &unlimited), 0);
  struct rlimit half = unlimited;
  half.rlim_cur = other_bytes.size() / 2;
  const auto handler = std::signal(SIGXFSZ, SIG_IGN);
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &half), 0);
  const Status failed = saveModel(other, path_);
  ::setrlimit(RLIMIT_FSIZE, &unlimited);
  std::signal(SIGXFSZ, handler);
  ASSERT_FALSE(failed.ok());
  EXPECT_EQ(failed.error().rfind(path_ + ": cannot write ", 0), 0u) << failed.error();
  EXPECT_NE(failed.error().find(systemErrorText(EFBIG)), std::string::npos) << failed.error();
  EXPECT_EQ(fileBytes(path_), bytes_);
  EXPECT_EQ(namesIn(dir_.str()), std::vector<std::string>{"model.bin"});

  // A folder where the model should go is refused and left as it is.
  const std::string folder = dir_.str() + "/folder.model";
  std::filesystem::create_directory(folder);
  const Status refused = saveModel(other, folder);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().rfind(folder + ": is a directory", 0), 0u) << refused.error();
  EXPECT_TRUE(std::filesystem::is_directory(folder));
  std::filesystem::remove(folder);

  // Without the limit the same save replaces the file, which reads back as the model.
  const Status saved = saveModel(other, path_);
  ASSERT_TRUE(saved.ok()) << saved.error();
  EXPECT_EQ(fileBytes(path_), other_bytes);
  const Expected<Model> loaded = loadModel(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  EXPECT_EQ(serializeModel(*loaded), other_bytes);
  EXPECT_EQ(namesIn(dir_.str()), std::vector<std::string>{"model.bin"});
}

TEST(Config, ForestYamlMatchesCompiledDefaults) {
  auto params = loadTrainingParams(std::string(RELOCALIZER_SOURCE_DIR) + "/config/forest.yaml");
  ASSERT_TRUE(params.ok()) << params.error();
  EXPECT_EQ(trainingParamsToJson(*params), trainingParamsToJson(TrainingParams{}));
}

TEST(Config, ModelsWithoutTheLsdFloorKeepTheirOwnLsdScale) {
  // A header written before lsd_min_width_px existed (e.g. a 0.5 model):
  // LSD keeps running at its own scale at every image size, whatever the
  // default floor becomes.
  TrainingParams old;
  old.line_sampling.lsd_scale = 0.5f;
  nlohmann::json header = nlohmann::json::parse(trainingParamsToJson(old));
  ASSERT_EQ(header["line_sampling"].erase("lsd_min_width_px"), 1u);
  auto read = trainingParamsFromJson(header.dump());
  ASSERT_TRUE(read.ok()) << read.error();
  EXPECT_EQ(read->line_sampling.lsd_scale, 0.5f);
  EXPECT_EQ(read->line_sampling.lsd_min_width_px, 0);
  // Headers that carry the floor read it back: the default's, and the
  // half-size preset's explicit 0 (the same LSD as those old models).
  const TrainingParams quarter;
  auto read_back = trainingParamsFromJson(trainingParamsToJson(quarter));
  ASSERT_TRUE(read_back.ok()) << read_back.error();
  EXPECT_EQ(read_back->line_sampling.lsd_scale, 0.25f);
  EXPECT_EQ(read_back->line_sampling.lsd_min_width_px, 160);
  auto half = loadTrainingParams(std::string(RELOCALIZER_SOURCE_DIR) + "/config/lsd_half.yaml");
  ASSERT_TRUE(half.ok()) << half.error();
  read_back = trainingParamsFromJson(trainingParamsToJson(*half));
  ASSERT_TRUE(read_back.ok()) << read_back.error();
  EXPECT_EQ(read_back->line_sampling.lsd_scale, 0.5f);
  EXPECT_EQ(read_back->line_sampling.lsd_min_width_px, 0);
}

TEST(Config, ModelsWithoutLsdValidationKeepValidating) {
  // Headers written before the key validated our detector's segments.
  TrainingParams unvalidated;
  unvalidated.line_sampling.lsd_validation = false;
  nlohmann::json header = nlohmann::json::parse(trainingParamsToJson(unvalidated));
  auto read_back = trainingParamsFromJson(header.dump());
  ASSERT_TRUE(read_back.ok()) << read_back.error();
  EXPECT_FALSE(read_back->line_sampling.lsd_validation);
  ASSERT_EQ(header["line_sampling"].erase("lsd_validation"), 1u);
  auto read = trainingParamsFromJson(header.dump());
  ASSERT_TRUE(read.ok()) << read.error();
  EXPECT_TRUE(read->line_sampling.lsd_validation);
}

TEST(Config, ModelsWithoutALineDetectorKeepOpenCvsLsd) {
  // Headers written before our own detector existed were trained on OpenCV's
  // LSD: they keep it, so their line forests see what they were trained on.
  const TrainingParams today;
  ASSERT_EQ(today.line_sampling.line_detector, LineDetector::kOwn);
  nlohmann::json header = nlohmann::json::parse(trainingParamsToJson(today));
  EXPECT_EQ(header["line_sampling"]["line_detector"], "own");
  auto read = trainingParamsFromJson(header.dump());
  ASSERT_TRUE(read.ok()) << read.error();
  EXPECT_EQ(read->line_sampling.line_detector, LineDetector::kOwn);
  ASSERT_EQ(header["line_sampling"].erase("line_detector"), 1u);
  read = trainingParamsFromJson(header.dump());
  ASSERT_TRUE(read.ok()) << read.error();
  EXPECT_EQ(read->line_sampling.line_detector, LineDetector::kOpenCvLsd);
  auto opencv = parseTrainingParams("line_sampling:\n  line_detector: opencv_lsd\n", "c.yaml");
  ASSERT_TRUE(opencv.ok()) << opencv.error();
  EXPECT_EQ(opencv->line_sampling.line_detector, LineDetector::kOpenCvLsd);
  const auto wrong = parseTrainingParams("line_sampling:\n  line_detector: hough\n", "c.yaml");
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().find("'line_sampling.line_detector' must be \"own\" or \"opencv_lsd\", "
                               "got \"hough\""),
            std::string::npos)
      << wrong.error();
  // Frames sampled for one detector are not another's.
  SamplingRecipe a, b;
  b.line_sampling.line_detector = LineDetector::kOpenCvLsd;
  EXPECT_TRUE(a.sameAs(a));
  EXPECT_FALSE(a.sameAs(b));
}

TEST(Config, OverridesAndRejectsUnknownKeysAndWrongTypes) {
  auto p =
      parseTrainingParams("points:\n  trees: 3\nline_sampling:\n  spacing_px: 4\n", "test.yaml");
  ASSERT_TRUE(p.ok()) << p.error();
  EXPECT_EQ(p->points.trees, 3);
  EXPECT_EQ(p->lines.trees, 5);
  EXPECT_FLOAT_EQ(p->line_sampling.spacing_px, 4.0f);
  auto typo = parseTrainingParams("points:\n  treees: 3\n", "test.yaml");
  ASSERT_FALSE(typo.ok());
  EXPECT_EQ(typo.error(), "test.yaml: unknown parameter 'points.treees'");
  auto wrong = parseTrainingParams("points:\n  trees: many\n", "test.yaml");
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().find("'points.trees' has the wrong type"), std::string::npos)
      << wrong.error();
}
