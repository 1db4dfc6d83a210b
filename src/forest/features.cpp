#include "relocalizer/forest/features.h"

#include <algorithm>
#include <cmath>

namespace relocalizer {

FeatureImage FeatureImage::of(const cv::Mat& colour, const cv::Mat& depth) {
  CV_Assert(colour.type() == CV_8UC3 && depth.type() == CV_32FC1 && colour.size() == depth.size());
  FeatureImage image;
  image.colour = colour.ptr<uint8_t>();
  image.depth = depth.ptr<float>();
  image.width = colour.cols;
  image.height = colour.rows;
  image.colour_stride = colour.step[0];
  image.depth_stride = depth.step[0] / sizeof(float);
  return image;
}

namespace {

// In-place 8-point fast Walsh-Hadamard transform (natural / Hadamard order).
inline void hadamard8(float* x, int stride) {
  for (int half = 1; half < 8; half *= 2)
    for (int start = 0; start < 8; start += 2 * half)
      for (int i = start; i < start + half; ++i) {
        const float a = x[i * stride], b = x[(i + half) * stride];
        x[i * stride] = a + b;
        x[(i + half) * stride] = a - b;
      }
}

// Natural-order indices of the Walsh functions with sequency 0..3 (number of
// sign changes), so that a 4x4 block of them is the low-frequency corner.
constexpr int kLowSequency[4] = {0, 4, 6, 2};

}  // namespace

DescriptorF computeDescriptor(const FeatureImage& image, int u, int v) {
  constexpr int kCells = 8;
  constexpr int kCell = kDescriptorPatch / kCells;  // 2x2 pixels averaged per cell
  float cells[3][kCells * kCells];
  const int u0 = u - kDescriptorPatch / 2, v0 = v - kDescriptorPatch / 2;
  const bool inside = u0 >= 0 && v0 >= 0 && u0 + kDescriptorPatch <= image.width &&
                      v0 + kDescriptorPatch <= image.height;
  for (int cy = 0; cy < kCells; ++cy) {
    for (int cx = 0; cx < kCells; ++cx) {
      int sum[3] = {0, 0, 0};
      for (int dy = 0; dy < kCell; ++dy) {
        int y = v0 + cy * kCell + dy;
        if (!inside) y = std::clamp(y, 0, image.height - 1);
        const uint8_t* row = image.colour + y * image.colour_stride;
        for (int dx = 0; dx < kCell; ++dx) {
          int x = u0 + cx * kCell + dx;
          if (!inside) x = std::clamp(x, 0, image.width - 1);
          sum[0] += row[x * 3];
          sum[1] += row[x * 3 + 1];
          sum[2] += row[x * 3 + 2];
        }
      }
      for (int c = 0; c < 3; ++c) cells[c][cy * kCells + cx] = static_cast<float>(sum[c]);
    }
  }
  DescriptorF out;
  float norm = 0.0f;
  for (int c = 0; c < 3; ++c) {
    float* m = cells[c];
    for (int row = 0; row < kCells; ++row) hadamard8(m + row * kCells, 1);
    for (int col = 0; col < kCells; ++col) hadamard8(m + col, kCells);
    for (int sy = 0; sy < 4; ++sy)
      for (int sx = 0; sx < 4; ++sx) {
        const float value = m[kLowSequency[sy] * kCells + kLowSequency[sx]];
        out[c * kDescriptorPerChannel + sy * 4 + sx] = value;
        norm += value * value;
      }
  }
  const float scale = norm > 0.0f ? 1.0f / std::sqrt(norm) : 0.0f;
  for (float& value : out) value *= scale;
  return out;
}

Descriptor quantizeDescriptor(const DescriptorF& descriptor) {
  Descriptor out;
  for (int i = 0; i < kDescriptorSize; ++i)
    out[i] = static_cast<int8_t>(std::clamp(std::lround(descriptor[i] * 127.0f), -127L, 127L));
  return out;
}

}  // namespace relocalizer
