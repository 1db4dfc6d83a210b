// What the forests see of colour: the frame's own channel statistics, or each
// pixel against its neighbourhood, so that other light (a gain, a colour cast)
// leaves it as it was.

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "relocalizer/forest/colour_normalisation.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/forest/training.h"
#include "relocalizer/forest/training_config.h"
#include "relocalizer/relocalize/frame_samples.h"

using namespace relocalizer;

namespace {

// A textured image whose values stay well inside [0, 255] after `gains`.
cv::Mat texture(const cv::Vec3d& gains) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> value(40, 150);
  cv::Mat image(60, 80, CV_8UC3);
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) {
      const int v = value(rng);
      cv::Vec3b& p = image.at<cv::Vec3b>(y, x);
      for (int c = 0; c < 3; ++c)
        p[c] = cv::saturate_cast<uint8_t>(gains[c] * (v + 20 * c + (x % 7)));
    }
  return image;
}

}  // namespace

TEST(ColourNormalisation, AGainAndAColourCastCancel) {
  const cv::Mat seen = normaliseColour(texture({1, 1, 1}), ColourNormalisation::kChannelStatistics);
  const cv::Mat other_light =
      normaliseColour(texture({0.5, 0.8, 1.3}), ColourNormalisation::kChannelStatistics);
  // Only the rounding of the scaled values remains.
  EXPECT_LE(cv::norm(seen, other_light, cv::NORM_INF), 3.0);
  // Without normalisation the same change moves values by up to 100 levels.
  EXPECT_GT(cv::norm(texture({1, 1, 1}), texture({0.5, 0.8, 1.3}), cv::NORM_INF), 50.0);
  cv::Scalar mean, deviation;
  cv::meanStdDev(seen, mean, deviation);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(mean[c], 128.0, 2.0);
    EXPECT_NEAR(deviation[c], 48.0, 2.0);
  }
}

TEST(ColourNormalisation, AgainstTheLocalMeanAGainAndAColourCastCancel) {
  const cv::Mat seen = normaliseColour(texture({1, 1, 1}), ColourNormalisation::kLocalMean);
  const cv::Mat other_light =
      normaliseColour(texture({0.5, 0.8, 1.3}), ColourNormalisation::kLocalMean);
  // The rounding of the recorded values and of the gains remains.
  EXPECT_LE(cv::norm(seen, other_light, cv::NORM_INF), 3.0);
  cv::Scalar mean = cv::mean(seen);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(mean[c], 96.0, 3.0);
}

// A person walking into view (a large bright patch) changes what the forests
// see only around them with the local mean; through the whole frame's
// statistics, every pixel.
TEST(ColourNormalisation, AgainstTheLocalMeanAPersonChangesOnlyTheirSurroundings) {
  cv::Mat room(480, 640, CV_8UC3);
  cv::resize(texture({1, 1, 1}), room, room.size(), 0, 0, cv::INTER_NEAREST);
  cv::Mat with_person = room.clone();
  with_person(cv::Rect(0, 40, 160, 440)).setTo(cv::Scalar(200, 215, 250));
  // Beyond the person, past the window of the local mean (16 blocks of 8
  // pixels) and one block of interpolation.
  const cv::Rect far_away(160 + 17 * 8 + 8, 0, 640 - (160 + 17 * 8 + 8), 480);
  const cv::Mat local = normaliseColour(room, ColourNormalisation::kLocalMean);
  const cv::Mat local_person = normaliseColour(with_person, ColourNormalisation::kLocalMean);
  EXPECT_EQ(cv::norm(local(far_away), local_person(far_away), cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(local, local_person, cv::NORM_INF), 50.0);
  const cv::Mat global = normaliseColour(room, ColourNormalisation::kChannelStatistics);
  const cv::Mat global_person =
      normaliseColour(with_person, ColourNormalisation::kChannelStatistics);
  EXPECT_GT(cv::norm(global(far_away), global_person(far_away), cv::NORM_INF), 10.0);
}

TEST(ColourNormalisation, AgainstTheLocalMeanDarknessIsNotBlownUp) {
  cv::Mat dark(200, 400, CV_8UC3, cv::Scalar(2, 3, 4));
  dark(cv::Rect(300, 0, 100, 200)).setTo(cv::Scalar(200, 200, 200));
  const cv::Mat seen = normaliseColour(dark, ColourNormalisation::kLocalMean);
  // At most 6 times: 2, 3, 4 levels become at most 12, 18, 24.
  const cv::Vec3b corner = seen.at<cv::Vec3b>(0, 0);
  for (int c = 0; c < 3; ++c) EXPECT_LE(corner[c], 6 * (2 + c));
  // Where the bright half dominates the neighbourhood, it stays bright.
  EXPECT_GT(seen.at<cv::Vec3b>(100, 399)[0], 80);
}

TEST(ColourNormalisation, AFlatImageIsNotStretchedIntoTexture) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(100.0, 2.0);
  cv::Mat wall(60, 80, CV_8UC3);
  for (auto it = wall.begin<cv::Vec3b>(); it != wall.end<cv::Vec3b>(); ++it)
    for (int c = 0; c < 3; ++c) (*it)[c] = cv::saturate_cast<uint8_t>(noise(rng));
  cv::Scalar mean, deviation;
  cv::meanStdDev(normaliseColour(wall, ColourNormalisation::kChannelStatistics), mean, deviation);
  // At most 48 / 8 = 6 times its spread of about 2 levels.
  for (int c = 0; c < 3; ++c) EXPECT_LT(deviation[c], 14.0);
  // Against the local mean, a flat wall stays flat: its mean is the local mean everywhere.
  cv::meanStdDev(normaliseColour(wall, ColourNormalisation::kLocalMean), mean, deviation);
  for (int c = 0; c < 3; ++c) EXPECT_LT(deviation[c], 3.0);
}

TEST(ColourNormalisation, NoneIsTheRecordedColourAndNamesRoundTrip) {
  const cv::Mat recorded = texture({1, 1, 1});
  EXPECT_EQ(normaliseColour(recorded, ColourNormalisation::kNone).data, recorded.data);
  for (ColourNormalisation n : {ColourNormalisation::kNone, ColourNormalisation::kChannelStatistics,
                                ColourNormalisation::kLocalMean})
    EXPECT_EQ(colourNormalisationNamed(colourNormalisationName(n)), n);
  EXPECT_FALSE(colourNormalisationNamed("grey_world"));
  EXPECT_THROW(normaliseColour(cv::Mat(4, 4, CV_8UC1), ColourNormalisation::kChannelStatistics),
               std::invalid_argument);
}

TEST(ColourNormalisation, ModelsWithoutItKeepTheRecordedColour) {
  EXPECT_EQ(TrainingParams{}.colour_normalisation, ColourNormalisation::kNone);
  for (ColourNormalisation n :
       {ColourNormalisation::kChannelStatistics, ColourNormalisation::kLocalMean}) {
    TrainingParams normalised;
    normalised.colour_normalisation = n;
    nlohmann::json header = nlohmann::json::parse(trainingParamsToJson(normalised));
    EXPECT_EQ(header["colour_normalisation"], colourNormalisationName(n));
    auto same = trainingParamsFromJson(header.dump());
    ASSERT_TRUE(same.ok()) << same.error();
    EXPECT_EQ(same->colour_normalisation, n);
    ASSERT_EQ(header.erase("colour_normalisation"), 1u);
    auto read = trainingParamsFromJson(header.dump());
    ASSERT_TRUE(read.ok()) << read.error();
    EXPECT_EQ(read->colour_normalisation, ColourNormalisation::kNone);
  }
  auto preset =
      loadTrainingParams(std::string(RELOCALIZER_SOURCE_DIR) + "/config/colour_normalised.yaml");
  ASSERT_TRUE(preset.ok()) << preset.error();
  EXPECT_EQ(preset->colour_normalisation, ColourNormalisation::kChannelStatistics);
  const auto wrong = parseTrainingParams("colour_normalisation: grey_world\n", "c.yaml");
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().find("'colour_normalisation' must be"), std::string::npos)
      << wrong.error();
  // Samples drawn from colour seen one way are not another model's.
  SamplingRecipe a, b;
  b.colour_normalisation = ColourNormalisation::kChannelStatistics;
  EXPECT_FALSE(a.sameAs(b));
}
