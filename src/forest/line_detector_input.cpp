// The line segment detector's input image: BT.601 luma in fixed point, shrunk
// by area averaging, in plain loops so it is the same on every platform.

#include "relocalizer/forest/line_detector_input.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace relocalizer {

namespace {

// For each output index, the source indices it covers and their weights
// (overlap of the source pixel with the output pixel's footprint, normalised).
struct AreaWeights {
  std::vector<int> first, count;
  std::vector<double> weight;
};

AreaWeights areaWeights(int source, int target) {
  AreaWeights w;
  const double step = static_cast<double>(source) / target;
  for (int t = 0; t < target; ++t) {
    const double begin = t * step, end = std::min<double>(source, (t + 1) * step);
    const int s0 = static_cast<int>(std::floor(begin));
    w.first.push_back(s0);
    int used = 0;
    for (int s = s0; s < source && s < end; ++s, ++used)
      w.weight.push_back((std::min<double>(s + 1, end) - std::max<double>(s, begin)) / step);
    w.count.push_back(used);
  }
  return w;
}

}  // namespace

cv::Mat lineDetectorInput(const cv::Mat& bgr, float scale) {
  if (bgr.type() != CV_8UC3)
    throw std::invalid_argument("lineDetectorInput: expected an 8-bit three-channel BGR image");
  cv::Mat grey(bgr.rows, bgr.cols, CV_8UC1);
  for (int y = 0; y < bgr.rows; ++y) {
    const unsigned char* in = bgr.ptr<unsigned char>(y);
    unsigned char* out = grey.ptr<unsigned char>(y);
    // 0.114 B + 0.587 G + 0.299 R in units of 2^-14 (the weights sum to 2^14).
    for (int x = 0; x < bgr.cols; ++x, in += 3)
      out[x] =
          static_cast<unsigned char>((in[0] * 1868 + in[1] * 9617 + in[2] * 4899 + 8192) >> 14);
  }
  const int cols =
      std::max(1, static_cast<int>(std::lround(bgr.cols * static_cast<double>(scale))));
  const int rows =
      std::max(1, static_cast<int>(std::lround(bgr.rows * static_cast<double>(scale))));
  if (scale >= 1.0f || (cols == bgr.cols && rows == bgr.rows)) return grey;
  const AreaWeights wx = areaWeights(bgr.cols, cols), wy = areaWeights(bgr.rows, rows);
  std::vector<double> across(static_cast<size_t>(bgr.rows) * cols);  // rows shrunk first
  for (int y = 0; y < bgr.rows; ++y) {
    const unsigned char* in = grey.ptr<unsigned char>(y);
    for (int t = 0, k = 0; t < cols; ++t) {
      double sum = 0;
      for (int j = 0; j < wx.count[t]; ++j, ++k) sum += wx.weight[k] * in[wx.first[t] + j];
      across[static_cast<size_t>(y) * cols + t] = sum;
    }
  }
  cv::Mat small(rows, cols, CV_8UC1);
  for (int t = 0, k0 = 0; t < rows; k0 += wy.count[t], ++t) {
    unsigned char* out = small.ptr<unsigned char>(t);
    for (int x = 0; x < cols; ++x) {
      double sum = 0;
      for (int j = 0; j < wy.count[t]; ++j)
        sum += wy.weight[k0 + j] * across[static_cast<size_t>(wy.first[t] + j) * cols + x];
      out[x] = static_cast<unsigned char>(std::min(255.0, std::floor(sum + 0.5)));
    }
  }
  return small;
}

}  // namespace relocalizer
