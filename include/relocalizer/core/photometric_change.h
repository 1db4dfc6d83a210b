#pragma once
// The same scene seen under other light or another camera setting: what a
// lamp's level, the time of day or an exposure and white balance the model was
// not trained under do to a colour image. Applied in linear light, so that
// one stop is a doubling of the light and a white balance is a gain per
// channel, as in the camera; the test frames of a benchmark go through it
// (changed_frame_source.h), the geometry (depth, poses) stays as it was.

#include <array>
#include <opencv2/core.hpp>
#include <string>

namespace relocalizer {

struct PhotometricChange {
  // Light or exposure: linear light times 2^stops (negative: darker), then
  // clipped where the sensor saturates and requantised to 8 bits.
  double stops = 0.0;
  // The colour temperature of the light, in kelvin, for a camera balanced for
  // kBalancedKelvin: 2700 is a tungsten lamp (orange), 6500 overcast daylight
  // (blue). Brightness (the luma of a grey) is kept. 0: no change.
  double kelvin = 0.0;
  // Another tone curve: the encoded value v in [0, 1] becomes v^gamma.
  double gamma = 1.0;

  static constexpr double kBalancedKelvin = 5500.0;
  static constexpr double kMinKelvin = 1000.0, kMaxKelvin = 20000.0;

  bool identity() const { return stops == 0.0 && kelvin == 0.0 && gamma == 1.0; }
  // Empty when usable, otherwise why not (naming the field).
  std::string validationError() const;
  // "none", or e.g. "-1 stop, 2700 K, gamma 1.4": for tables and summary.json.
  std::string describe() const;
};

// Linear-light gain of each channel (B, G, R, as OpenCV stores colour) of a
// light of `kelvin` seen by a camera balanced for kBalancedKelvin, from
// Planck's law at each channel's central wavelength, scaled so that a grey
// keeps its luma.
cv::Vec3d whiteBalanceGains(double kelvin);

// `bgr` (8-bit, 3 channels) seen under `change`: a table per channel, so each
// input value always gives the same output value.
// Throws std::invalid_argument on another image type or an invalid change.
cv::Mat applyPhotometricChange(const cv::Mat& bgr, const PhotometricChange& change);

// The colour of the light a frame was seen in, as far as the frame tells: the
// mean linear light of each channel (B, G, R) over every other pixel of every
// other row, scaled so that its luma is 1 (a grey scene under the balanced
// light gives 1, 1, 1). What fills the view moves it too, so it compares
// lights only where they differ by more than the scenes do. Zeros for a black
// image. Throws std::invalid_argument on another image type than 8-bit BGR.
cv::Vec3d lightChromaticity(const cv::Mat& bgr);

// Where a view's light falls: the mean linear light of each channel in each
// cell of a kLightGridColumns x kLightGridRows grid over the image (every
// other pixel of every other row), row by row, B, G, R per cell. Unlike
// lightChromaticity it keeps where the colours are, so two views of the same
// place in other light differ by one gain per channel, and views of other
// places do not (light_retry.h). Throws std::invalid_argument on another
// image type than 8-bit BGR.
constexpr int kLightGridColumns = 8, kLightGridRows = 6;
using LightGrid = std::array<float, kLightGridColumns * kLightGridRows * 3>;
LightGrid lightGrid(const cv::Mat& bgr);

// `bgr` with each channel's linear light times `gains` (B, G, R), clipped
// where the sensor saturates: a white balance set afterwards.
cv::Mat applyChannelGains(const cv::Mat& bgr, const cv::Vec3d& gains);

}  // namespace relocalizer
