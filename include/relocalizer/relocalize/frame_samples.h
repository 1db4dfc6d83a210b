#pragma once
// The half of a relocalization that does not depend on the forests: the
// frame's point and line samples and their descriptors. Places that sample
// alike share one set per frame, so a frame asked of many places pays for LSD
// and sampling once.

#include <random>
#include <vector>

#include "relocalizer/forest/colour_normalisation.h"
#include "relocalizer/forest/features.h"
#include "relocalizer/forest/patch_descriptor.h"
#include "relocalizer/forest/sampling.h"

namespace relocalizer {

// What decides a frame's samples. Two relocalizers with the same recipe draw
// the same samples from a frame, so either may use the other's.
struct SamplingRecipe {
  bool use_points = false;  // the point forest is used: points are sampled
  bool use_lines = false;   // the line forest is used: lines are sampled
  int point_samples = 0;
  int line_samples = 0;
  int min_valid_depth = 0;
  uint32_t seed = 0;
  LineSamplingParams line_sampling;
  ColourNormalisation colour_normalisation = ColourNormalisation::kNone;
  DescriptorNormalisation descriptor_normalisation = DescriptorNormalisation::kWhole;

  bool sameAs(const SamplingRecipe& other) const;
};

struct FrameSamples {
  SamplingRecipe recipe;
  std::vector<Sample> points;
  LineSamples lines;
  cv::Mat colour;      // the colour the forests see (normalised), which image views
  FeatureImage image;  // a view of the frame: it must outlive the samples
  std::vector<Descriptor> point_descriptors;
  std::vector<Descriptor> line_descriptors;
  // The random stream after sampling; the pose solver continues it, so a
  // place answers from shared samples exactly as it would alone.
  std::mt19937 rng;
  double point_seconds = 0.0;  // random pixels and their descriptors
  double line_seconds = 0.0;   // LSD, line samples, 3D line fits and descriptors
};

}  // namespace relocalizer
