#include "relocalizer/forest/colour_normalisation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>

namespace relocalizer {

namespace {

constexpr double kTargetMean = 128.0;
constexpr double kTargetDeviation = 48.0;
// A channel with less spread than this (a blank wall, darkness) is stretched
// no more than this allows, so its noise is not blown up into texture.
constexpr double kMinDeviation = 8.0;
constexpr int kStatisticsStride = 2;

}  // namespace

const char* colourNormalisationName(ColourNormalisation normalisation) {
  return normalisation == ColourNormalisation::kChannelStatistics ? "channel_statistics" : "none";
}

std::optional<ColourNormalisation> colourNormalisationNamed(const std::string& name) {
  for (ColourNormalisation n :
       {ColourNormalisation::kNone, ColourNormalisation::kChannelStatistics})
    if (name == colourNormalisationName(n)) return n;
  return std::nullopt;
}

cv::Mat normaliseColour(const cv::Mat& bgr, ColourNormalisation normalisation) {
  if (normalisation == ColourNormalisation::kNone) return bgr;
  if (bgr.type() != CV_8UC3)
    throw std::invalid_argument("normaliseColour: expected an 8-bit 3-channel image");
  // Every other pixel of every other row: the statistics of a whole frame, at
  // a quarter of the cost.
  std::array<std::array<uint64_t, 256>, 3> histogram{};
  uint64_t counted = 0;
  for (int y = 0; y < bgr.rows; y += kStatisticsStride) {
    const uint8_t* row = bgr.ptr<uint8_t>(y);
    for (int x = 0; x < bgr.cols; x += kStatisticsStride, ++counted)
      for (int c = 0; c < 3; ++c) ++histogram[c][row[3 * x + c]];
  }
  const double pixels = static_cast<double>(counted);
  cv::Mat table(1, 256, CV_8UC3);
  for (int c = 0; c < 3; ++c) {
    uint64_t sum = 0, squares = 0;
    for (uint64_t v = 0; v < 256; ++v) {
      sum += v * histogram[c][v];
      squares += v * v * histogram[c][v];
    }
    const double mean = pixels > 0 ? sum / pixels : 0.0;
    const double variance = pixels > 0 ? squares / pixels - mean * mean : 0.0;
    const double gain =
        kTargetDeviation / std::max(kMinDeviation, std::sqrt(std::max(0.0, variance)));
    for (int v = 0; v < 256; ++v)
      table.at<cv::Vec3b>(0, v)[c] =
          static_cast<uint8_t>(std::clamp(std::lround(kTargetMean + (v - mean) * gain), 0L, 255L));
  }
  cv::Mat normalised;
  cv::LUT(bgr, table, normalised);
  return normalised;
}

}  // namespace relocalizer
