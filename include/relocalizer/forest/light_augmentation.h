#pragma once
// Training under lights the camera did not record. The split features compare
// absolute intensities, so a model trained in one light misses frames seen in
// another (a stop darker, a tungsten lamp). Showing each training image under
// a light drawn at random teaches the trees splits that hold across lights,
// while the run time still reads the recorded colour: unlike a normalisation
// (colour_normalisation.h), nothing that walks into view changes what the
// rest of the frame looks like, and the pixels keep the contrast the
// recording had (docs/benchmarks.md has what each did).

#include <cstdint>
#include <string>

#include "relocalizer/core/photometric_change.h"

namespace relocalizer {

struct LightAugmentation {
  // The light level of each image, drawn uniformly within +-max_stops.
  double max_stops = 0.0;
  // Its colour temperature, drawn log-uniformly within [min_kelvin,
  // max_kelvin]; both 0: the recorded white balance.
  double min_kelvin = 0.0;
  double max_kelvin = 0.0;

  static constexpr double kMostStops = 3.0;

  bool enabled() const { return max_stops > 0.0 || max_kelvin > 0.0; }
  // Empty when usable, otherwise why not (naming the field).
  std::string validationError() const;
};

// The light drawn for one training image from 64 random bits (the caller's
// stream for that image), so the same bits give the same light everywhere.
PhotometricChange drawLight(const LightAugmentation& augmentation, uint64_t random_bits);

}  // namespace relocalizer
