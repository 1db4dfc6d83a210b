// Other light on a recorded scene: the change is physical (stops double the
// light, a colour temperature tints it, a grey keeps its luma) and touches
// colour only.

#include <gtest/gtest.h>

#include <cmath>

#include "relocalizer/core/photometric_change.h"
#include "relocalizer/data/changed_frame_source.h"

using namespace relocalizer;

namespace {

double linear(int encoded) {
  const double v = encoded / 255.0;
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

// Every 8-bit value once in each channel.
cv::Mat allValues() {
  cv::Mat image(1, 256, CV_8UC3);
  for (int v = 0; v < 256; ++v) image.at<cv::Vec3b>(0, v) = cv::Vec3b(v, v, v);
  return image;
}

// Half an 8-bit step of linear light around `encoded`: the quantisation's tolerance.
double halfStep(int encoded) {
  return 0.5 * (linear(std::min(255, encoded + 1)) - linear(std::max(0, encoded - 1))) + 1e-12;
}

}  // namespace

TEST(PhotometricChange, OneStopDarkerHalvesTheLinearLight) {
  PhotometricChange change;
  change.stops = -1;
  const cv::Mat out = applyPhotometricChange(allValues(), change);
  for (int v = 0; v < 256; ++v) {
    const int o = out.at<cv::Vec3b>(0, v)[1];
    EXPECT_NEAR(linear(o), 0.5 * linear(v), halfStep(o)) << v;
  }
  EXPECT_EQ(out.at<cv::Vec3b>(0, 255)[0], 188);  // white is now a mid grey
}

TEST(PhotometricChange, OneStopBrighterSaturatesTheUpperHalf) {
  PhotometricChange change;
  change.stops = 1;
  const cv::Mat out = applyPhotometricChange(allValues(), change);
  for (int v = 0; v < 256; ++v) {
    const int o = out.at<cv::Vec3b>(0, v)[2];
    if (linear(v) >= 0.5)
      EXPECT_EQ(o, 255) << v;
    else
      EXPECT_NEAR(linear(o), 2.0 * linear(v), halfStep(o)) << v;
  }
}

TEST(PhotometricChange, ColourTemperatureTintsAndKeepsAGreysLuma) {
  const cv::Vec3d warm = whiteBalanceGains(2700), cold = whiteBalanceGains(6500),
                  balanced = whiteBalanceGains(PhotometricChange::kBalancedKelvin);
  // B, G, R: a tungsten lamp is red-orange, daylight blue.
  EXPECT_GT(warm[2], 1.3);
  EXPECT_LT(warm[0], 0.6);
  EXPECT_GT(cold[0], cold[1]);
  EXPECT_GT(cold[1], cold[2]);
  for (const cv::Vec3d& gains : {warm, cold})
    EXPECT_NEAR(0.0722 * gains[0] + 0.7152 * gains[1] + 0.2126 * gains[2], 1.0, 1e-12);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(balanced[c], 1.0, 1e-12);

  PhotometricChange change;
  change.kelvin = 2700;
  const cv::Vec3b grey = applyPhotometricChange(allValues(), change).at<cv::Vec3b>(0, 100);
  EXPECT_GT(grey[2], 100 + 20);
  EXPECT_LT(grey[0], 100 - 20);
}

namespace {

// Patches of several colours, none near saturation (a white balance applied
// afterwards cannot bring back what clipped).
cv::Mat colouredPatches() {
  cv::Mat image(40, 60, CV_8UC3);
  const cv::Vec3b colours[] = {{60, 90, 140}, {150, 120, 80}, {70, 160, 70}, {110, 110, 110}};
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) image.at<cv::Vec3b>(y, x) = colours[(x / 15) % 4];
  return image;
}

}  // namespace

// What a lamp does to a frame's colour is what the frame's chromaticity sees
// move: the white balance's gains, channel by channel, up to quantisation.
TEST(PhotometricChange, ChromaticityMovesByTheLightsGains) {
  const cv::Mat recorded = colouredPatches();
  PhotometricChange lamp;
  lamp.kelvin = 2700;
  const cv::Vec3d before = lightChromaticity(recorded);
  const cv::Vec3d after = lightChromaticity(applyPhotometricChange(recorded, lamp));
  const cv::Vec3d gains = whiteBalanceGains(2700);
  // Each channel's share relative to green: the luma scaling cancels.
  for (int c : {0, 2})
    EXPECT_NEAR((after[c] / after[1]) / (before[c] / before[1]), gains[c] / gains[1],
                0.02 * gains[c] / gains[1])
        << "channel " << c;
  const cv::Vec3d grey = lightChromaticity(cv::Mat(8, 8, CV_8UC3, cv::Scalar(128, 128, 128)));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(grey[c], 1.0, 1e-9);
  EXPECT_EQ(lightChromaticity(cv::Mat(8, 8, CV_8UC3, cv::Scalar(0, 0, 0))), cv::Vec3d(0, 0, 0));
  EXPECT_THROW(lightChromaticity(cv::Mat(4, 4, CV_8UC1)), std::invalid_argument);
}

// The light grid keeps where the light falls: each cell holds its own
// patch's linear light, a lamp moves every cell by its gains, and the grid's
// channels add up to the frame's chromaticity.
TEST(PhotometricChange, LightGridKeepsWhereTheLightFalls) {
  // A bluish left half, a reddish right half: lit by the lamp, neither clips
  // nor falls where 8 bits quantise coarsely.
  cv::Mat split(60, 80, CV_8UC3, cv::Scalar(200, 110, 70));
  split(cv::Rect(40, 0, 40, 60)).setTo(cv::Scalar(90, 110, 170));
  const LightGrid grid = lightGrid(split);
  for (int row = 0; row < kLightGridRows; ++row)
    for (int column = 0; column < kLightGridColumns; ++column) {
      const bool left = column < kLightGridColumns / 2;
      const float* cell = &grid[3 * (row * kLightGridColumns + column)];
      EXPECT_NEAR(cell[0], linear(left ? 200 : 90), 1e-6) << row << ", " << column;
      EXPECT_NEAR(cell[2], linear(left ? 70 : 170), 1e-6) << row << ", " << column;
    }
  PhotometricChange lamp;
  lamp.kelvin = 3000;
  const LightGrid lit = lightGrid(applyPhotometricChange(split, lamp));
  const cv::Vec3d gains = whiteBalanceGains(3000);
  for (size_t i = 0; i < grid.size(); ++i)
    EXPECT_NEAR(lit[i] / grid[i], gains[i % 3], 0.03 * gains[i % 3]) << "value " << i;
  cv::Vec3d sum(0, 0, 0);
  for (size_t i = 0; i < grid.size(); ++i) sum[i % 3] += grid[i];
  const cv::Vec3d chromaticity = lightChromaticity(split);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(sum[c] / sum[1], chromaticity[c] / chromaticity[1], 1e-6) << "channel " << c;
  EXPECT_THROW(lightGrid(cv::Mat(4, 4, CV_8UC1)), std::invalid_argument);
}

// Gains that invert the lamp's bring the recorded colour back, within the
// quantisation of the two 8-bit passes.
TEST(PhotometricChange, ChannelGainsUndoAWhiteBalance) {
  const cv::Mat recorded = colouredPatches();
  PhotometricChange lamp;
  lamp.kelvin = 3500;
  const cv::Vec3d gains = whiteBalanceGains(3500);
  const cv::Mat undone = applyChannelGains(applyPhotometricChange(recorded, lamp),
                                           cv::Vec3d(1 / gains[0], 1 / gains[1], 1 / gains[2]));
  EXPECT_LE(cv::norm(recorded, undone, cv::NORM_INF), 2.0);
  EXPECT_EQ(cv::norm(recorded, applyChannelGains(recorded, cv::Vec3d(1, 1, 1)), cv::NORM_INF), 0.0);
  EXPECT_THROW(applyChannelGains(cv::Mat(4, 4, CV_8UC1), cv::Vec3d(1, 1, 1)),
               std::invalid_argument);
}

TEST(PhotometricChange, GammaBendsTheToneCurve) {
  PhotometricChange change;
  change.gamma = 2.0;
  const cv::Mat out = applyPhotometricChange(allValues(), change);
  EXPECT_EQ(out.at<cv::Vec3b>(0, 128)[0], 64);  // 255 (128/255)^2 = 64.25
  EXPECT_EQ(out.at<cv::Vec3b>(0, 255)[0], 255);
  EXPECT_EQ(out.at<cv::Vec3b>(0, 0)[0], 0);
}

TEST(PhotometricChange, NoChangeIsTheSameImage) {
  const cv::Mat in = allValues();
  const cv::Mat out = applyPhotometricChange(in, PhotometricChange{});
  EXPECT_EQ(cv::norm(in, out, cv::NORM_INF), 0.0);
  EXPECT_EQ(PhotometricChange{}.describe(), "none");
}

TEST(PhotometricChange, BadChangesAndImagesAreRefusedByName) {
  PhotometricChange change;
  change.stops = 9;
  EXPECT_NE(change.validationError().find("stops"), std::string::npos);
  change = {};
  change.kelvin = 500;
  EXPECT_NE(change.validationError().find("kelvin"), std::string::npos);
  change = {};
  change.gamma = 0;
  EXPECT_NE(change.validationError().find("gamma"), std::string::npos);
  EXPECT_THROW(applyPhotometricChange(cv::Mat(4, 4, CV_8UC1), PhotometricChange{}),
               std::invalid_argument);
  change = {};
  change.stops = -1;
  change.kelvin = 2700;
  EXPECT_EQ(change.describe(), "-1 stop, 2700 K");
}

namespace {

// One recorded frame: a colour ramp, depth 2 m, posed 1 m along x.
class OneFrame : public FrameSource {
 public:
  size_t size() const override { return 1; }
  int id(size_t) const override { return 7; }
  double stamp(size_t) const override { return 7.0; }
  const std::optional<Pose>& groundTruth(size_t) const override { return truth_; }
  Expected<RgbdFrame> load(size_t) const override {
    RgbdFrame frame;
    frame.colour = cv::Mat(8, 8, CV_8UC3, cv::Scalar(50, 120, 200));
    frame.depth = cv::Mat(8, 8, CV_32F, cv::Scalar(2.0f));
    frame.ground_truth = truth_;
    return frame;
  }
  const CameraIntrinsics& camera() const override { return camera_; }
  std::string summary() const override { return "one frame\n"; }
  const std::string& path() const override { return path_; }
  std::string formatDescription() const override { return "test"; }
  bool integerStamps() const override { return true; }

 private:
  std::optional<Pose> truth_ = Pose(Eigen::Translation3d(1, 0, 0));
  CameraIntrinsics camera_;
  std::string path_ = "recording";
};

}  // namespace

TEST(ChangedFrameSource, ChangesColourOnly) {
  PhotometricChange change;
  change.stops = -1;
  const ChangedFrameSource changed(std::make_unique<OneFrame>(), change);
  const Expected<RgbdFrame> original = OneFrame().load(0), seen = changed.load(0);
  ASSERT_TRUE(seen);
  EXPECT_GT(cv::norm(original->colour, seen->colour, cv::NORM_INF), 20.0);
  EXPECT_EQ(cv::norm(original->depth, seen->depth, cv::NORM_INF), 0.0);
  EXPECT_TRUE(seen->ground_truth->isApprox(*original->ground_truth));
  EXPECT_EQ(changed.id(0), 7);
  EXPECT_NE(changed.summary().find("-1 stop"), std::string::npos);
  change.stops = 20;
  EXPECT_THROW(ChangedFrameSource(std::make_unique<OneFrame>(), change), std::invalid_argument);
}
