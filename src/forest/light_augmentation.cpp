#include "relocalizer/forest/light_augmentation.h"

#include <cmath>
#include <sstream>

namespace relocalizer {

namespace {

// A value in [0, 1) from 32 of the bits: integer to double is exact, so every
// platform draws the same light (a std:: distribution is not required to).
double unitFrom(uint32_t bits) { return std::ldexp(static_cast<double>(bits), -32); }

}  // namespace

std::string LightAugmentation::validationError() const {
  std::ostringstream why;
  if (!(max_stops >= 0.0 && max_stops <= kMostStops))
    why << "light_augmentation.max_stops: expected [0, " << kMostStops << "], got " << max_stops;
  else if ((min_kelvin != 0.0 || max_kelvin != 0.0) &&
           !(min_kelvin >= PhotometricChange::kMinKelvin && min_kelvin <= max_kelvin &&
             max_kelvin <= PhotometricChange::kMaxKelvin))
    why << "light_augmentation.min_kelvin, max_kelvin: expected both 0 (the recorded white "
           "balance) or "
        << PhotometricChange::kMinKelvin
        << " <= min_kelvin <= max_kelvin <= " << PhotometricChange::kMaxKelvin << ", got "
        << min_kelvin << " and " << max_kelvin;
  return why.str();
}

PhotometricChange drawLight(const LightAugmentation& augmentation, uint64_t random_bits) {
  PhotometricChange light;
  const double level = unitFrom(static_cast<uint32_t>(random_bits));
  const double warmth = unitFrom(static_cast<uint32_t>(random_bits >> 32));
  light.stops = augmentation.max_stops * (2.0 * level - 1.0);
  if (augmentation.max_kelvin > 0.0)
    light.kelvin = augmentation.min_kelvin *
                   std::pow(augmentation.max_kelvin / augmentation.min_kelvin, warmth);
  return light;
}

}  // namespace relocalizer
