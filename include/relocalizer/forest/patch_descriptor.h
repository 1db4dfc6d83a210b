#pragma once
// The patch descriptor that picks, among a leaf's modes, the one whose local
// appearance matches: Walsh-Hadamard (WHT) projections of the 16x16 pixel
// patch centred on the sample, box-filtered 2x2 down to 8x8, per colour
// channel; the 4x4 lowest-sequency coefficients of each channel (16 x 3 = 48
// values), scaled to unit length. What leaves keep and samples are compared
// by is the 4x2 lowest of them per channel (both vertical sequencies 0 and 1,
// every horizontal one: 8 x 3 = 24 values) quantised to int8 (x127); scaled
// over all 48, so a patch whose contrast lies in finer detail keeps shorter
// coefficients. Leaves keep the mean descriptor of each mode.
//
// The 24 of model format 5 chose the same modes as the 48 before them: on
// redkitchen-dev within half a point, surface stage on and off; even no
// descriptor at all moved the figures by 1.5 points at most (docs/benchmarks.md,
// "Models half the size"). Older models keep their first 24.
//
// How the vector is scaled decides which changes of the light it ignores. The
// whole vector to unit length cancels a gain of the light; each channel to the
// same length cancels a gain per channel, that is a change of the white
// balance too, at the price of the patch's chromaticity (docs/benchmarks.md
// has what each did).

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "relocalizer/forest/features.h"

namespace relocalizer {

enum class DescriptorNormalisation {
  kWhole,       // the whole vector to unit length (every model before issue 40)
  kPerChannel,  // each channel's 16 values to length 1/sqrt(3)
};

const char* descriptorNormalisationName(DescriptorNormalisation normalisation);
std::optional<DescriptorNormalisation> descriptorNormalisationNamed(const std::string& name);

constexpr int kDescriptorPatch = 16;       // pixels per side
constexpr int kDescriptorChannels = 3;     // B, G, R
constexpr int kDescriptorPerChannel = 16;  // 4x4 lowest-sequency WHT coefficients
constexpr int kDescriptorSize = kDescriptorChannels * kDescriptorPerChannel;
constexpr int kKeptPerChannel = 8;  // of those, vertical sequency 0 and 1 (the first 8)
constexpr int kKeptDescriptorSize = kDescriptorChannels * kKeptPerChannel;
using Descriptor = std::array<int8_t, kKeptDescriptorSize>;  // what leaves keep and samples compare
using DescriptorF = std::array<float, kDescriptorSize>;

// `descriptor` scaled as `normalisation` says; a part that is all zero stays
// zero. Training scales each mode's mean descriptor with it too.
void normaliseDescriptor(DescriptorF& descriptor, DescriptorNormalisation normalisation);

// The unit-length float descriptor of the patch centred on (u, v); the patch
// is clamped to the image like the features.
DescriptorF computeDescriptor(const FeatureImage& image, int u, int v,
                              DescriptorNormalisation normalisation);

// The kept coefficients of `descriptor`, quantised.
Descriptor quantizeDescriptor(const DescriptorF& descriptor);
// The kept coefficients of a descriptor quantised whole (model formats 1 to 4
// stored all 48).
Descriptor keptCoefficients(const std::array<int8_t, kDescriptorSize>& whole);

// Squared Euclidean distance between quantised descriptors (units of 1/127^2).
inline int32_t descriptorDistance(const Descriptor& a, const Descriptor& b) {
  int32_t sum = 0;
  for (int i = 0; i < kKeptDescriptorSize; ++i) {
    const int32_t d = static_cast<int32_t>(a[i]) - static_cast<int32_t>(b[i]);
    sum += d * d;
  }
  return sum;
}

}  // namespace relocalizer
