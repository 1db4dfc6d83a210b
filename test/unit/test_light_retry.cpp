// Finding the light a frame was seen in (light_retry.h): the training view it
// resembles under some level and lamp colour tells that change of light,
// where the mean colour of the training images cannot tell a lamp from a
// coloured wall.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "relocalizer/core/photometric_change.h"
#include "relocalizer/relocalize/light_retry.h"

using namespace relocalizer;

namespace {

// A view of a wall of coloured tiles: reddish tiles (`warm`) or bluish ones,
// each view its own.
cv::Mat tiledView(std::mt19937& random, bool warm) {
  std::uniform_int_distribution<int> strong(120, 220), weak(30, 110);
  cv::Mat view(96, 128, CV_8UC3);
  for (int y = 0; y < view.rows; y += 8)
    for (int x = 0; x < view.cols; x += 8) {
      const int r = warm ? strong(random) : weak(random), b = warm ? weak(random) : strong(random);
      view(cv::Rect(x, y, 8, 8)).setTo(cv::Scalar(b, (r + b) / 2, r));
    }
  return view;
}

struct TiledRoom {
  std::vector<cv::Mat> views;
  Model model;  // no forests: what the light is matched with is its summary
  TiledRoom() {
    std::mt19937 random(7);
    cv::Vec3d chromaticity(0, 0, 0);
    for (int i = 0; i < 40; ++i) {
      views.push_back(tiledView(random, i % 2 == 0));
      model.summary.view_lights.push_back(lightGrid(views.back()));
      chromaticity += lightChromaticity(views.back());
    }
    chromaticity /= 40.0;
    model.summary.light_chromaticity =
        Eigen::Vector3d(chromaticity[0], chromaticity[1], chromaticity[2]).cast<float>();
  }
};

double mired(double kelvin) { return 1e6 / kelvin; }

PhotometricChange lampAndLevel(double kelvin, double stops) {
  PhotometricChange change;
  change.kelvin = kelvin;
  change.stops = stops;
  return change;
}

}  // namespace

TEST(NearestViewLight, FindsTheViewItsLampAndItsLevel) {
  const TiledRoom room;
  for (const auto& [view, kelvin, stops] :
       {std::tuple{17, 2700.0, -1.0}, std::tuple{4, 6500.0, 0.0}, std::tuple{30, 3500.0, -2.0},
        std::tuple{9, 5500.0, -1.0}}) {
    SCOPED_TRACE("view " + std::to_string(view) + " at " + std::to_string(kelvin) + " K, " +
                 std::to_string(stops) + " stops");
    const cv::Mat seen = applyPhotometricChange(room.views[view], lampAndLevel(kelvin, stops));
    const std::optional<LightChange> change =
        nearestViewLight(lightGrid(seen), room.model.summary.view_lights);
    ASSERT_TRUE(change);
    EXPECT_EQ(change->view, static_cast<size_t>(view));
    EXPECT_LE(std::abs(mired(change->kelvin) - mired(kelvin)), 5.0);  // the candidates' half step
    EXPECT_NEAR(change->stops, stops, 0.05);
    EXPECT_LT(change->mismatch, 1e-3);
  }
  const std::optional<LightChange> same =
      nearestViewLight(lightGrid(room.views[3]), room.model.summary.view_lights);
  ASSERT_TRUE(same);
  EXPECT_EQ(same->view, 3u);
  EXPECT_EQ(same->kelvin, PhotometricChange::kBalancedKelvin);
  EXPECT_NEAR(same->stops, 0.0, 1e-6);
  EXPECT_NEAR(same->mismatch, 0.0, 1e-9);
  // Nothing to match with, or nothing seen.
  EXPECT_FALSE(nearestViewLight(lightGrid(room.views[3]), {}));
  EXPECT_FALSE(nearestViewLight(lightGrid(cv::Mat(96, 128, CV_8UC3, cv::Scalar(0, 0, 0))),
                                room.model.summary.view_lights));
}

// A bluish view under a warm lamp is taken back into the training light by
// the lamp's own gains; the mean colour of the training images, half of them
// reddish, would take it to their mean instead, and has no way to see a
// change of level at all.
TEST(NearestViewLight, RebalancesByTheLampWhereTheMeanColourCannot) {
  const TiledRoom room;
  const cv::Mat seen = applyPhotometricChange(room.views[11], lampAndLevel(2700, -1));
  const std::optional<LightRebalance> rebalance =
      rebalanceIntoTrainingLight(seen, room.model, 0.25f);
  ASSERT_TRUE(rebalance);
  const cv::Vec3d lamp = whiteBalanceGains(2700);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(rebalance->gains[c] * lamp[c], 2.0, 0.1) << "channel " << c;
  double cast = 0.0;
  for (int c = 0; c < 3; ++c) cast = std::max(cast, std::abs(std::log(2.0 / lamp[c])));
  EXPECT_NEAR(rebalance->cast, cast, 0.05);
  EXPECT_LT(rebalance->mismatch, 1e-3);

  Model without_views = room.model;
  without_views.summary.view_lights.clear();
  const std::optional<LightRebalance> by_mean =
      rebalanceIntoTrainingLight(seen, without_views, 0.25f);
  ASSERT_TRUE(by_mean);
  EXPECT_TRUE(std::isinf(by_mean->mismatch));
  double worst = 0.0;
  for (int c = 0; c < 3; ++c)
    worst = std::max(worst,
                     std::abs(std::log(by_mean->gains[c] / by_mean->gains[1] * lamp[c] / lamp[1])));
  EXPECT_GT(worst, 0.3) << "the mean colour found the lamp: the test's views are too alike";

  // The light of training is not asked about again, nor any light when the
  // retry is off.
  EXPECT_FALSE(rebalanceIntoTrainingLight(room.views[11], room.model, 0.25f));
  EXPECT_FALSE(rebalanceIntoTrainingLight(seen, room.model, 0.0f));
}
