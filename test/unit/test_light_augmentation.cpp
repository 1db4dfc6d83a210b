// Training under lights the camera did not record: the lights drawn, the
// training images they give and the model header that keeps the choice
// (test_end_to_end.cpp relocalizes evening frames with a model so trained).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <random>

#include "relocalizer/core/photometric_change.h"
#include "relocalizer/forest/light_augmentation.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/forest/training.h"
#include "relocalizer/forest/training_config.h"
#include "relocalizer/sim/synthetic_scene.h"

using namespace relocalizer;

namespace {

LightAugmentation daylightToTungsten() {
  LightAugmentation a;
  a.max_stops = 1.0;
  a.min_kelvin = 2500.0;
  a.max_kelvin = 8500.0;
  return a;
}

double meanGreen(const cv::Mat& bgr) { return cv::mean(bgr)[1]; }
double redOverBlue(const cv::Mat& bgr) {
  const cv::Scalar m = cv::mean(bgr);
  return m[2] / m[0];
}

}  // namespace

// The lights cover the range asked for, evenly (stops uniform, kelvin uniform
// in its logarithm), and none is drawn when nothing is asked.
TEST(LightAugmentation, LightsAreDrawnEvenlyWithinTheRange) {
  const LightAugmentation a = daylightToTungsten();
  std::mt19937_64 bits(5);
  std::vector<double> stops, log_kelvin;
  for (int i = 0; i < 4000; ++i) {
    const PhotometricChange light = drawLight(a, bits());
    ASSERT_TRUE(light.validationError().empty()) << light.validationError();
    stops.push_back(light.stops);
    log_kelvin.push_back(std::log(light.kelvin));
  }
  auto quantile = [](std::vector<double> v, double q) {
    std::nth_element(v.begin(), v.begin() + static_cast<long>(q * (v.size() - 1)), v.end());
    return v[static_cast<size_t>(q * (v.size() - 1))];
  };
  EXPECT_GE(*std::min_element(stops.begin(), stops.end()), -1.0);
  EXPECT_LE(*std::max_element(stops.begin(), stops.end()), 1.0);
  EXPECT_NEAR(quantile(stops, 0.25), -0.5, 0.05);
  EXPECT_NEAR(quantile(stops, 0.75), 0.5, 0.05);
  const double low = std::log(2500.0), high = std::log(8500.0);
  EXPECT_GE(*std::min_element(log_kelvin.begin(), log_kelvin.end()), low);
  EXPECT_LE(*std::max_element(log_kelvin.begin(), log_kelvin.end()), high);
  EXPECT_NEAR(quantile(log_kelvin, 0.5), 0.5 * (low + high), 0.05 * (high - low));

  EXPECT_TRUE(drawLight(LightAugmentation{}, bits()).identity());
  LightAugmentation level_only;
  level_only.max_stops = 0.5;
  EXPECT_EQ(drawLight(level_only, bits()).kelvin, 0.0);
}

TEST(LightAugmentation, ImpossibleRangesAreRefusedNamingTheKey) {
  EXPECT_EQ(LightAugmentation{}.validationError(), "");
  EXPECT_EQ(daylightToTungsten().validationError(), "");
  LightAugmentation a = daylightToTungsten();
  a.max_stops = -1.0;
  EXPECT_NE(a.validationError().find("light_augmentation.max_stops"), std::string::npos);
  a = daylightToTungsten();
  a.max_stops = 4.0;
  EXPECT_NE(a.validationError().find("light_augmentation.max_stops"), std::string::npos);
  a = daylightToTungsten();
  a.min_kelvin = 9000.0;  // above max_kelvin
  EXPECT_NE(a.validationError().find("min_kelvin"), std::string::npos);
  a = daylightToTungsten();
  a.min_kelvin = 0.0;  // one end only
  EXPECT_NE(a.validationError().find("min_kelvin"), std::string::npos);

  const auto wrong = parseTrainingParams("light_augmentation: {max_stops: 5}\n", "aug.yaml");
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().find("aug.yaml"), std::string::npos) << wrong.error();
  EXPECT_NE(wrong.error().find("light_augmentation.max_stops"), std::string::npos) << wrong.error();
}

// Each training image gets a light of its own, the same every time the same
// images are appended in the same order; the geometry is the recording's.
// Without augmentation the colour is the recorded Mat itself.
TEST(LightAugmentation, EachTrainingImageIsSeenUnderItsOwnRepeatableLight) {
  const SyntheticRoom room(7);
  const CameraIntrinsics camera = CameraIntrinsics::kinectDefault().scaledTo(160, 120);
  const SyntheticTrajectories paths = room.trajectories(6, 1);
  std::vector<RgbdFrame> frames;
  for (size_t i = 0; i < paths.train.size(); ++i)
    frames.push_back(room.render(paths.train[i], camera, static_cast<int>(i)));

  TrainingParams recorded;
  TrainingParams augmented;
  augmented.light_augmentation = daylightToTungsten();
  std::vector<TrainingImage> plain, first, second;
  for (const RgbdFrame& frame : frames) {
    ASSERT_TRUE(appendTrainingImage(frame, recorded, plain));
    for (int copy = 0; copy < 2; ++copy) {
      ASSERT_TRUE(appendTrainingImage(frame, augmented, first));
      ASSERT_TRUE(appendTrainingImage(frame, augmented, second));
    }
  }
  std::vector<double> gain, cast;
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(plain[i].colour.data, frames[i].colour.data);
    EXPECT_EQ(first[2 * i].depth.data, frames[i].depth.data);
    EXPECT_TRUE(first[2 * i].pose.isApprox(*frames[i].ground_truth));
    // The same frame appended again sits at another place in the set: another light.
    gain.push_back(meanGreen(first[2 * i].colour) / meanGreen(frames[i].colour));
    cast.push_back(redOverBlue(first[2 * i].colour) / redOverBlue(frames[i].colour));
    EXPECT_NE(cv::norm(first[2 * i].colour, first[2 * i + 1].colour, cv::NORM_L1), 0.0);
    for (size_t j : {2 * i, 2 * i + 1})
      EXPECT_EQ(cv::norm(first[j].colour, second[j].colour, cv::NORM_L1), 0.0) << j;
  }
  const auto [least_gain, most_gain] = std::minmax_element(gain.begin(), gain.end());
  const auto [coldest, warmest] = std::minmax_element(cast.begin(), cast.end());
  EXPECT_GT(*most_gain / *least_gain, 1.3);
  EXPECT_GT(*warmest / *coldest, 1.3);
}

TEST(LightAugmentation, ModelsKeepItAndModelsWithoutItWereTrainedOnTheRecordedLight) {
  EXPECT_FALSE(TrainingParams{}.light_augmentation.enabled());
  TrainingParams augmented;
  augmented.light_augmentation = daylightToTungsten();
  nlohmann::json header = nlohmann::json::parse(trainingParamsToJson(augmented));
  EXPECT_EQ(header["light_augmentation"]["max_kelvin"], 8500.0);
  auto same = trainingParamsFromJson(header.dump());
  ASSERT_TRUE(same.ok()) << same.error();
  EXPECT_EQ(same->light_augmentation.max_stops, 1.0);
  EXPECT_EQ(same->light_augmentation.min_kelvin, 2500.0);
  EXPECT_EQ(same->light_augmentation.max_kelvin, 8500.0);
  ASSERT_EQ(header.erase("light_augmentation"), 1u);
  auto older = trainingParamsFromJson(header.dump());
  ASSERT_TRUE(older.ok()) << older.error();
  EXPECT_FALSE(older->light_augmentation.enabled());
  auto preset =
      loadTrainingParams(std::string(RELOCALIZER_SOURCE_DIR) + "/config/light_augmented.yaml");
  ASSERT_TRUE(preset.ok()) << preset.error();
  EXPECT_EQ(preset->light_augmentation.max_stops, 1.0);
  EXPECT_EQ(preset->light_augmentation.min_kelvin, 2500.0);
  EXPECT_EQ(preset->colour_normalisation, ColourNormalisation::kNone);
  EXPECT_EQ(preset->descriptor_normalisation, DescriptorNormalisation::kPerChannel);
  header["light_augmentation"] = {{"max_stops", 1.0}, {"min_kelvin", 3000.0}, {"max_kelvin", 0.0}};
  auto broken = trainingParamsFromJson(header.dump());
  ASSERT_FALSE(broken.ok());
  EXPECT_NE(broken.error().find("max_kelvin"), std::string::npos) << broken.error();
}
