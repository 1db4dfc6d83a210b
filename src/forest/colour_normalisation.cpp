#include "relocalizer/forest/colour_normalisation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace relocalizer {

namespace {

constexpr double kTargetMean = 128.0;
constexpr double kTargetDeviation = 48.0;
// A channel with less spread than this (a blank wall, darkness) is stretched
// no more than this allows, so its noise is not blown up into texture.
constexpr double kMinDeviation = 8.0;
constexpr int kStatisticsStride = 2;

// Local means are taken over square blocks of pixels, averaged over a window
// of blocks around each block, and interpolated between block centres, so the
// gain field is smooth and costs little. Integer arithmetic throughout: the
// same result on every platform.
constexpr int kBlock = 8;
// The window reaches 16 blocks (128 pixels) each way: wide enough to keep the
// colour of a cupboard door, narrow enough that a person in one part of the
// view leaves the rest as it was (docs/benchmarks.md: 3 and 6 blocks lost
// kitchen frames; the whole frame lost a quarter of the frames with two people).
constexpr int kLocalRadiusBlocks = 16;
constexpr int kLocalTarget = 96;  // a pixel at its neighbourhood's mean
constexpr int kMaxLocalGain = 6;  // darkness is not blown up into texture
constexpr int kFixed = 512;       // fixed-point unit of the gains

// Where pixel `i` of a row or column lies between the centres of its
// `blocks` (at kBlock * b + (kBlock - 1) / 2): between block `below` and
// `above`, `weight` / (2 kBlock) of the way to `above`. Before the first and
// after the last centre, both are that block.
struct BetweenCentres {
  int below, above, weight;
};

BetweenCentres betweenCentres(int i, int blocks) {
  const int twice = std::max(0, 2 * i - (kBlock - 1));  // half pixels past the first centre
  const int below = std::min(twice / (2 * kBlock), blocks - 1);
  return {below, std::min(below + 1, blocks - 1), std::min(twice - 2 * kBlock * below, 2 * kBlock)};
}

// Per block and channel: kFixed * kLocalTarget / (the mean over the blocks
// within `radius` blocks), at most kFixed * kMaxLocalGain. The means are taken
// over every other pixel of every other row, as the channel statistics are.
std::vector<int32_t> blockGains(const cv::Mat& bgr, int grid_w, int grid_h, int radius) {
  const int stride = (grid_w + 1) * 4;
  std::vector<int64_t> integral(stride * (grid_h + 1), 0);
  for (int y = 0; y < bgr.rows; y += kStatisticsStride) {
    const uint8_t* row = bgr.ptr<uint8_t>(y);
    int64_t* block = &integral[(y / kBlock + 1) * stride + 4];
    for (int x = 0; x < bgr.cols; x += kStatisticsStride) {
      int64_t* sums = block + (x / kBlock) * 4;
      sums[0] += row[3 * x], sums[1] += row[3 * x + 1], sums[2] += row[3 * x + 2], ++sums[3];
    }
  }
  for (int gy = 1; gy <= grid_h; ++gy)
    for (int i = 4; i < stride; ++i)
      integral[gy * stride + i] += integral[gy * stride + i - 4] + integral[(gy - 1) * stride + i] -
                                   integral[(gy - 1) * stride + i - 4];
  std::vector<int32_t> gains(grid_w * grid_h * 3);
  for (int gy = 0; gy < grid_h; ++gy)
    for (int gx = 0; gx < grid_w; ++gx) {
      const int x0 = std::max(0, gx - radius) * 4, x1 = std::min(grid_w, gx + radius + 1) * 4;
      const int y0 = std::max(0, gy - radius) * stride,
                y1 = std::min(grid_h, gy + radius + 1) * stride;
      int64_t window[4];
      for (int k = 0; k < 4; ++k)
        window[k] = integral[y1 + x1 + k] - integral[y1 + x0 + k] - integral[y0 + x1 + k] +
                    integral[y0 + x0 + k];
      const int64_t darkest = std::max<int64_t>(1, window[3] * kLocalTarget / kMaxLocalGain);
      for (int c = 0; c < 3; ++c)
        gains[(gy * grid_w + gx) * 3 + c] = static_cast<int32_t>(
            int64_t{kFixed} * kLocalTarget * window[3] / std::max(window[c], darkest));
    }
  return gains;
}

// One block row of gains (one per block and channel) interpolated linearly
// between block centres into one gain per pixel and channel; beyond the first
// and last centre, the gain of that block.
void interpolateAlongRow(const int32_t* block_gains, int grid_w, int cols, uint16_t* pixel_gains) {
  for (int x = 0; x < cols; ++x) {
    const BetweenCentres at = betweenCentres(x, grid_w);
    for (int c = 0; c < 3; ++c)
      pixel_gains[3 * x + c] =
          static_cast<uint16_t>((block_gains[3 * at.below + c] * (2 * kBlock - at.weight) +
                                 block_gains[3 * at.above + c] * at.weight + kBlock) /
                                (2 * kBlock));
  }
}

// Between two interpolated block rows: weight/(2 kBlock) of the way to
// `lower`. In 16 bits (gains are at most kFixed * kMaxLocalGain, times 2
// kBlock fits), so the compiler vectorises it 8 lanes wide.
void interpolateAcrossRows(const uint16_t* __restrict upper, const uint16_t* __restrict lower,
                           uint16_t weight, int n, uint16_t* __restrict gains) {
  static_assert(kFixed * kMaxLocalGain * 2 * kBlock + kBlock < 65536, "16-bit interpolation");
  const uint16_t upper_weight = static_cast<uint16_t>(2 * kBlock - weight);
  for (int i = 0; i < n; ++i) {
    const uint16_t from_upper = static_cast<uint16_t>(upper[i] * upper_weight);
    const uint16_t from_lower = static_cast<uint16_t>(lower[i] * weight);
    gains[i] = static_cast<uint16_t>(static_cast<uint16_t>(from_upper + from_lower + kBlock) /
                                     (2 * kBlock));
  }
}

// out = in * gain / kFixed, saturated, as the high half of a 16-bit product:
// a loop the compiler vectorises.
void scaleRow(const uint8_t* __restrict in, const uint16_t* __restrict gain, int n,
              uint8_t* __restrict out) {
  static_assert(kFixed == 512, "in << 7 times the gain, high half, is in * gain / 512");
  for (int i = 0; i < n; ++i) {
    const uint16_t shifted = static_cast<uint16_t>(in[i] << 7);
    const uint16_t scaled = static_cast<uint16_t>((static_cast<uint32_t>(shifted) * gain[i]) >> 16);
    out[i] = static_cast<uint8_t>(scaled > 255 ? 255 : scaled);
  }
}

cv::Mat normaliseByLocalMean(const cv::Mat& bgr) {
  const int grid_w = (bgr.cols + kBlock - 1) / kBlock, grid_h = (bgr.rows + kBlock - 1) / kBlock;
  const int row_size = bgr.cols * 3;
  const std::vector<int32_t> gains = blockGains(bgr, grid_w, grid_h, kLocalRadiusBlocks);
  std::vector<uint16_t> along(grid_h * row_size), pixel_gains(row_size);
  for (int gy = 0; gy < grid_h; ++gy)
    interpolateAlongRow(&gains[gy * grid_w * 3], grid_w, bgr.cols, &along[gy * row_size]);
  cv::Mat normalised(bgr.size(), CV_8UC3);
  for (int y = 0; y < bgr.rows; ++y) {
    const BetweenCentres at = betweenCentres(y, grid_h);
    interpolateAcrossRows(&along[at.below * row_size], &along[at.above * row_size],
                          static_cast<uint16_t>(at.weight), row_size, pixel_gains.data());
    scaleRow(bgr.ptr<uint8_t>(y), pixel_gains.data(), row_size, normalised.ptr<uint8_t>(y));
  }
  return normalised;
}

}  // namespace

const char* colourNormalisationName(ColourNormalisation normalisation) {
  switch (normalisation) {
    case ColourNormalisation::kChannelStatistics:
      return "channel_statistics";
    case ColourNormalisation::kLocalMean:
      return "local_mean";
    default:
      return "none";
  }
}

std::optional<ColourNormalisation> colourNormalisationNamed(const std::string& name) {
  for (ColourNormalisation n : {ColourNormalisation::kNone, ColourNormalisation::kChannelStatistics,
                                ColourNormalisation::kLocalMean})
    if (name == colourNormalisationName(n)) return n;
  return std::nullopt;
}

cv::Mat normaliseColour(const cv::Mat& bgr, ColourNormalisation normalisation) {
  if (normalisation == ColourNormalisation::kNone) return bgr;
  if (bgr.type() != CV_8UC3)
    throw std::invalid_argument("normaliseColour: expected an 8-bit 3-channel image");
  if (normalisation == ColourNormalisation::kLocalMean) return normaliseByLocalMean(bgr);
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
