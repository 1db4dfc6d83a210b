#pragma once
// The split features, shared by training and prediction.
//
// Split feature (depth-adaptive pixel comparison, as in SCoRe forests):
//   colour: f = I(p, c1) - I(p + delta / D(p), c2)            (intensity units)
//   depth : f = D(p + delta / D(p)) - D(p)                      (metres)
// delta is in pixel-metres, so the second pixel moves with the surface when the
// camera moves closer or further. The rule at the second pixel q:
//   - q outside the image is clamped to the nearest border pixel (colour and
//     depth alike), so a feature never reads outside the image and is defined
//     everywhere;
//   - for depth features, invalid depth at q reads as kFarDepth (10 m): holes
//     are mostly "something behind" (edges, out of range), so they sort with
//     far background rather than being dropped.
// The same code evaluates features in training and at test time. The patch
// descriptor that picks among a leaf's modes is in patch_descriptor.h.

#include <cstdint>
#include <opencv2/core.hpp>

namespace relocalizer {

enum class FeatureType : uint8_t { Colour = 0, Depth = 1 };

constexpr float kFarDepth = 10.0f;

struct PixelFeature {
  int16_t offset_u = 0;  // pixel-metres
  int16_t offset_v = 0;
  FeatureType type = FeatureType::Colour;
  uint8_t channel_p = 0;  // BGR channel at p (colour features)
  uint8_t channel_q = 0;  // BGR channel at q
  uint8_t padding = 0;
};
static_assert(sizeof(PixelFeature) == 8, "PixelFeature is packed into split nodes");

// Non-owning view of one frame's images in the layout features read.
struct FeatureImage {
  const uint8_t* colour = nullptr;  // BGR interleaved, `colour_stride` bytes per row
  const float* depth = nullptr;     // metres, NaN invalid, `depth_stride` floats per row
  int width = 0;
  int height = 0;
  size_t colour_stride = 0;
  size_t depth_stride = 0;

  // `colour` CV_8UC3 and `depth` CV_32FC1 of the same size; both must outlive
  // the view. `depth` may be empty where no depth feature is evaluated
  // (training after the samples are drawn, when depth_feature_share is 0).
  static FeatureImage of(const cv::Mat& colour, const cv::Mat& depth);
};

// The sample p a feature is evaluated at: integer pixel (u, v) with valid
// depth > 0, and 1 / D(p), by which every feature scales its offset. A descent
// evaluates one feature per node on the same sample, so the division is done
// once per sample here, not once per node (the same float reciprocal, so the
// same second pixel).
struct FeatureSite {
  int u = 0;
  int v = 0;
  float depth = 0.0f;
  float inverse_depth = 0.0f;

  static FeatureSite at(int u, int v, float depth) { return {u, v, depth, 1.0f / depth}; }
};

// The second pixel q of `feature` at `p`: p + delta / D(p), rounded and
// clamped to the image.
inline void secondPixel(const PixelFeature& feature, const FeatureImage& image,
                        const FeatureSite& p, int& qu, int& qv) {
  qu = p.u + static_cast<int>(feature.offset_u * p.inverse_depth +
                              (feature.offset_u >= 0 ? 0.5f : -0.5f));
  qv = p.v + static_cast<int>(feature.offset_v * p.inverse_depth +
                              (feature.offset_v >= 0 ? 0.5f : -0.5f));
  qu = qu < 0 ? 0 : (qu >= image.width ? image.width - 1 : qu);
  qv = qv < 0 ? 0 : (qv >= image.height ? image.height - 1 : qv);
}

// f at `p` with its second pixel (qu, qv) already found by secondPixel, for
// callers that find q first and read it later (after prefetchPixel); `colour_p`
// is p's colour (BGR).
inline float featureValueAt(const PixelFeature& feature, const FeatureImage& image,
                            const FeatureSite& p, const uint8_t* colour_p, int qu, int qv) {
  if (feature.type == FeatureType::Colour) {
    const int ip = colour_p[feature.channel_p];
    const int iq = image.colour[qv * image.colour_stride + qu * 3 + feature.channel_q];
    return static_cast<float>(ip - iq);
  }
  const float depth_q = image.depth[qv * image.depth_stride + qu];
  return (depth_q == depth_q ? depth_q : kFarDepth) - p.depth;  // NaN != NaN
}

// Starts loading the pixel q that featureValueAt will read.
inline void prefetchPixel(const PixelFeature& feature, const FeatureImage& image, int qu, int qv) {
  if (feature.type == FeatureType::Colour)
    __builtin_prefetch(image.colour + qv * image.colour_stride + qu * 3);
  else
    __builtin_prefetch(image.depth + qv * image.depth_stride + qu);
}

// f at `p`, whose colour (BGR) the caller already holds in `colour_p`:
// training keeps it with each sample, so a colour feature reads one image
// pixel, not two.
inline float evaluateFeature(const PixelFeature& feature, const FeatureImage& image,
                             const FeatureSite& p, const uint8_t* colour_p) {
  int qu, qv;
  secondPixel(feature, image, p, qu, qv);
  return featureValueAt(feature, image, p, colour_p, qu, qv);
}

// f at `p`.
inline float evaluateFeature(const PixelFeature& feature, const FeatureImage& image,
                             const FeatureSite& p) {
  return evaluateFeature(feature, image, p, image.colour + p.v * image.colour_stride + p.u * 3);
}

// f for the sample at integer pixel (u, v) with valid depth `depth_p` > 0 and
// colour `colour_p`, for callers that evaluate one feature per sample.
inline float evaluateFeature(const PixelFeature& feature, const FeatureImage& image, int u, int v,
                             float depth_p, const uint8_t* colour_p) {
  return evaluateFeature(feature, image, FeatureSite::at(u, v, depth_p), colour_p);
}

// f for the sample at integer pixel (u, v) with valid depth `depth_p` > 0.
inline float evaluateFeature(const PixelFeature& feature, const FeatureImage& image, int u, int v,
                             float depth_p) {
  return evaluateFeature(feature, image, FeatureSite::at(u, v, depth_p));
}

// Starts loading the second pixel q that evaluateFeature will read, for
// callers that evaluate one feature on many samples scattered over many images
// and keep each sample's own pixel I(p) at hand: issued some samples ahead, the
// cache misses overlap instead of following one another.
inline void prefetchSecondPixel(const PixelFeature& feature, const FeatureImage& image, int u,
                                int v, float depth_p) {
  int qu, qv;
  secondPixel(feature, image, FeatureSite::at(u, v, depth_p), qu, qv);
  prefetchPixel(feature, image, qu, qv);
}

}  // namespace relocalizer
