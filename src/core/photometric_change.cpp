#include "relocalizer/core/photometric_change.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace relocalizer {

namespace {

// The sRGB transfer curve (IEC 61966-2-1): consumer cameras, the Kinect's
// included, encode colour with it, so light adds up only after decoding.
double srgbToLinear(double v) {
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}
double linearToSrgb(double l) {
  return l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1.0 / 2.4) - 0.055;
}

// Spectral radiance of a black body at `kelvin`, up to a constant, at
// `wavelength_um` (Planck's law; c2 = hc/k in micrometre kelvin).
double planck(double wavelength_um, double kelvin) {
  constexpr double kSecondRadiationConstant = 14387.77;
  return std::pow(wavelength_um, -5.0) /
         std::expm1(kSecondRadiationConstant / (wavelength_um * kelvin));
}

// Where a colour camera's blue, green and red filters pass most light.
constexpr double kChannelWavelengthUm[3] = {0.465, 0.540, 0.610};
// Luma weights of linear BT.709 / sRGB primaries, in B, G, R order.
constexpr double kLumaWeight[3] = {0.0722, 0.7152, 0.2126};

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

}  // namespace

std::string PhotometricChange::validationError() const {
  if (!std::isfinite(stops) || std::abs(stops) > 8.0)
    return "stops: expected a number of stops in [-8, 8], got " + number(stops);
  if (kelvin != 0.0 && !(kelvin >= kMinKelvin && kelvin <= kMaxKelvin))
    return "kelvin: expected 0 (no change) or a colour temperature in [" + number(kMinKelvin) +
           ", " + number(kMaxKelvin) + "] K, got " + number(kelvin);
  if (!(gamma >= 0.2 && gamma <= 5.0))
    return "gamma: expected an exponent in [0.2, 5], got " + number(gamma);
  return {};
}

std::string PhotometricChange::describe() const {
  if (identity()) return "none";
  std::string text;
  const auto add = [&text](const std::string& part) { text += (text.empty() ? "" : ", ") + part; };
  if (stops != 0.0) add((stops > 0 ? "+" : "") + number(stops) + " stop");
  if (kelvin != 0.0) add(number(kelvin) + " K");
  if (gamma != 1.0) add("gamma " + number(gamma));
  return text;
}

cv::Vec3d whiteBalanceGains(double kelvin) {
  cv::Vec3d gains;
  double luma = 0.0;
  for (int c = 0; c < 3; ++c) {
    gains[c] = planck(kChannelWavelengthUm[c], kelvin) /
               planck(kChannelWavelengthUm[c], PhotometricChange::kBalancedKelvin);
    luma += kLumaWeight[c] * gains[c];
  }
  return gains / luma;
}

namespace {

// One table per channel: linear light times `gain` and 2^stops, clipped, the
// tone curve, requantised.
cv::Mat changedLight(const cv::Mat& bgr, double stops, const cv::Vec3d& gains, double gamma) {
  cv::Mat table(1, 256, CV_8UC3);
  for (int value = 0; value < 256; ++value)
    for (int c = 0; c < 3; ++c) {
      const double light = std::min(1.0, srgbToLinear(value / 255.0) * std::exp2(stops) * gains[c]);
      const double encoded = std::pow(linearToSrgb(light), gamma);
      table.at<cv::Vec3b>(0, value)[c] =
          static_cast<unsigned char>(std::lround(255.0 * std::clamp(encoded, 0.0, 1.0)));
    }
  cv::Mat changed;
  cv::LUT(bgr, table, changed);
  return changed;
}

void requireBgr(const cv::Mat& bgr, const char* caller) {
  if (bgr.type() != CV_8UC3)
    throw std::invalid_argument(std::string(caller) + ": expected an 8-bit 3-channel image");
}

}  // namespace

cv::Mat applyPhotometricChange(const cv::Mat& bgr, const PhotometricChange& change) {
  requireBgr(bgr, "applyPhotometricChange");
  const std::string invalid = change.validationError();
  if (!invalid.empty()) throw std::invalid_argument("applyPhotometricChange: " + invalid);
  if (change.identity()) return bgr.clone();
  const cv::Vec3d balance =
      change.kelvin == 0.0 ? cv::Vec3d(1.0, 1.0, 1.0) : whiteBalanceGains(change.kelvin);
  return changedLight(bgr, change.stops, balance, change.gamma);
}

cv::Mat applyChannelGains(const cv::Mat& bgr, const cv::Vec3d& gains) {
  requireBgr(bgr, "applyChannelGains");
  return changedLight(bgr, 0.0, gains, 1.0);
}

namespace {

// Calls `add(cell, linear B, G, R)` for every other pixel of every other row,
// `cell` its kLightGridColumns x kLightGridRows grid cell: the one sampling
// of a frame's light.
template <typename Add>
void forEachLightSample(const cv::Mat& bgr, Add&& add) {
  static const std::array<double, 256> linear = [] {
    std::array<double, 256> table{};
    for (int value = 0; value < 256; ++value) table[value] = srgbToLinear(value / 255.0);
    return table;
  }();
  for (int y = 0; y < bgr.rows; y += 2) {
    const cv::Vec3b* row = bgr.ptr<cv::Vec3b>(y);
    const int cell_row = y * kLightGridRows / bgr.rows * kLightGridColumns;
    for (int x = 0; x < bgr.cols; x += 2)
      add(cell_row + x * kLightGridColumns / bgr.cols, linear[row[x][0]], linear[row[x][1]],
          linear[row[x][2]]);
  }
}

}  // namespace

LightGrid lightGrid(const cv::Mat& bgr) {
  requireBgr(bgr, "lightGrid");
  std::array<double, LightGrid().size()> sum{};
  std::array<int, kLightGridColumns * kLightGridRows> samples{};
  forEachLightSample(bgr, [&](int cell, double b, double g, double r) {
    sum[3 * cell] += b;
    sum[3 * cell + 1] += g;
    sum[3 * cell + 2] += r;
    ++samples[cell];
  });
  LightGrid grid{};
  for (size_t i = 0; i < grid.size(); ++i)
    grid[i] = samples[i / 3] > 0 ? static_cast<float>(sum[i] / samples[i / 3]) : 0.0f;
  return grid;
}

cv::Vec3d lightChromaticity(const cv::Mat& bgr) {
  requireBgr(bgr, "lightChromaticity");
  cv::Vec3d sum(0.0, 0.0, 0.0);
  forEachLightSample(bgr, [&sum](int, double b, double g, double r) { sum += cv::Vec3d(b, g, r); });
  const double luma = kLumaWeight[0] * sum[0] + kLumaWeight[1] * sum[1] + kLumaWeight[2] * sum[2];
  return luma > 0.0 ? sum / luma : cv::Vec3d(0.0, 0.0, 0.0);
}

}  // namespace relocalizer
