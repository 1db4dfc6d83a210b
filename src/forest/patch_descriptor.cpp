#include "relocalizer/forest/patch_descriptor.h"

#include <algorithm>
#include <cmath>

namespace relocalizer {

const char* descriptorNormalisationName(DescriptorNormalisation normalisation) {
  return normalisation == DescriptorNormalisation::kPerChannel ? "per_channel" : "whole";
}

std::optional<DescriptorNormalisation> descriptorNormalisationNamed(const std::string& name) {
  for (DescriptorNormalisation n :
       {DescriptorNormalisation::kWhole, DescriptorNormalisation::kPerChannel})
    if (name == descriptorNormalisationName(n)) return n;
  return std::nullopt;
}

namespace {

// One coefficient of the 8-point Walsh-Hadamard transform in natural
// (Hadamard) order: row N of the matrix is (-1)^popcount(N & j). With the
// index a template argument every sign is a constant, so each coefficient is
// seven integer additions; only the 4 lowest-sequency ones are ever needed.
template <int N>
inline int hadamardCoefficient(const int* x) {
  int sum = 0;
  for (int j = 0; j < 8; ++j) sum += (__builtin_popcount(N & j) & 1) ? -x[j] : x[j];
  return sum;
}

// The 4 lowest-sequency coefficients (sequency 0..3 are natural indices
// 0, 4, 6, 2) of 8 consecutive values.
inline void lowSequency(const int* x, int out[4]) {
  out[0] = hadamardCoefficient<0>(x);
  out[1] = hadamardCoefficient<4>(x);
  out[2] = hadamardCoefficient<6>(x);
  out[3] = hadamardCoefficient<2>(x);
}

// `values` scaled to `length`, or left at zero.
void scaleToLength(float* values, int count, float length) {
  float norm = 0.0f;
  for (int i = 0; i < count; ++i) norm += values[i] * values[i];
  const float scale = norm > 0.0f ? length / std::sqrt(norm) : 0.0f;
  for (int i = 0; i < count; ++i) values[i] *= scale;
}

}  // namespace

void normaliseDescriptor(DescriptorF& descriptor, DescriptorNormalisation normalisation) {
  if (normalisation == DescriptorNormalisation::kWhole) {
    scaleToLength(descriptor.data(), kDescriptorSize, 1.0f);
    return;
  }
  // Equal lengths keep the whole vector at unit length, so distances between
  // descriptors stay on the scale the quantisation was chosen for.
  const float channel_length = 1.0f / std::sqrt(static_cast<float>(kDescriptorChannels));
  for (int c = 0; c < kDescriptorChannels; ++c)
    scaleToLength(descriptor.data() + c * kDescriptorPerChannel, kDescriptorPerChannel,
                  channel_length);
}

DescriptorF computeDescriptor(const FeatureImage& image, int u, int v,
                              DescriptorNormalisation normalisation) {
  constexpr int kCells = 8;
  static_assert(kDescriptorPatch == 2 * kCells, "cells average 2x2 pixels");
  // Cell sums stay integers (at most 4 * 255 per cell, 64 * 1020 per
  // coefficient, far below 2^24), so the transform is exact in int and the
  // floats below are the same as a float transform in any order would give.
  int cells[kDescriptorChannels][kCells * kCells];
  const int u0 = u - kDescriptorPatch / 2, v0 = v - kDescriptorPatch / 2;
  const bool inside = u0 >= 0 && v0 >= 0 && u0 + kDescriptorPatch <= image.width &&
                      v0 + kDescriptorPatch <= image.height;
  for (int cy = 0; cy < kCells; ++cy) {
    int y0 = v0 + 2 * cy, y1 = y0 + 1;
    if (!inside) {
      y0 = std::clamp(y0, 0, image.height - 1);
      y1 = std::clamp(y1, 0, image.height - 1);
    }
    const uint8_t* row0 = image.colour + y0 * image.colour_stride;
    const uint8_t* row1 = image.colour + y1 * image.colour_stride;
    for (int cx = 0; cx < kCells; ++cx) {
      int x0 = u0 + 2 * cx, x1 = x0 + 1;
      if (!inside) {
        x0 = std::clamp(x0, 0, image.width - 1);
        x1 = std::clamp(x1, 0, image.width - 1);
      }
      for (int c = 0; c < kDescriptorChannels; ++c)
        cells[c][cy * kCells + cx] =
            row0[x0 * 3 + c] + row0[x1 * 3 + c] + row1[x0 * 3 + c] + row1[x1 * 3 + c];
    }
  }
  DescriptorF out;
  for (int c = 0; c < kDescriptorChannels; ++c) {
    // by_row[k][r]: horizontal coefficient k of cell row r; then the vertical
    // transform of each of those columns gives coefficient (sy, sx).
    int by_row[4][kCells];
    for (int r = 0; r < kCells; ++r) {
      int k[4];
      lowSequency(cells[c] + r * kCells, k);
      for (int sx = 0; sx < 4; ++sx) by_row[sx][r] = k[sx];
    }
    for (int sx = 0; sx < 4; ++sx) {
      int k[4];
      lowSequency(by_row[sx], k);
      for (int sy = 0; sy < 4; ++sy)
        out[c * kDescriptorPerChannel + sy * 4 + sx] = static_cast<float>(k[sy]);
    }
  }
  normaliseDescriptor(out, normalisation);
  return out;
}

Descriptor quantizeDescriptor(const DescriptorF& descriptor) {
  Descriptor out;
  for (int c = 0; c < kDescriptorChannels; ++c)
    for (int k = 0; k < kKeptPerChannel; ++k)
      out[c * kKeptPerChannel + k] = static_cast<int8_t>(
          std::clamp(std::lround(descriptor[c * kDescriptorPerChannel + k] * 127.0f), -127L, 127L));
  return out;
}

Descriptor keptCoefficients(const std::array<int8_t, kDescriptorSize>& whole) {
  Descriptor out;
  for (int c = 0; c < kDescriptorChannels; ++c)
    for (int k = 0; k < kKeptPerChannel; ++k)
      out[c * kKeptPerChannel + k] = whole[c * kDescriptorPerChannel + k];
  return out;
}

}  // namespace relocalizer
