#include "relocalizer/forest/packed_mode.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace relocalizer {

namespace {

constexpr float kGridSteps = 65535.0f;

static_assert(sizeof(Eigen::half) == 2, "a half is 16 bits");

uint16_t halfBits(float value) {
  const Eigen::half h(value);
  uint16_t bits;
  std::memcpy(&bits, &h, sizeof bits);
  return bits;
}

float halfValue(uint16_t bits) {
  Eigen::half h;
  std::memcpy(static_cast<void*>(&h), &bits, sizeof bits);
  return static_cast<float>(h);
}

}  // namespace

ModeGrid modeGridOf(const std::vector<LeafMode>& modes) {
  Eigen::Vector3f low = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f high = -low;
  bool any = false;
  for (const LeafMode& mode : modes) {
    if (!mode.mean.allFinite()) continue;  // packs as the origin (only hostile files have one)
    low = low.cwiseMin(mode.mean);
    high = high.cwiseMax(mode.mean);
    any = true;
  }
  ModeGrid grid;
  if (!any) return grid;
  grid.origin = {low.x(), low.y(), low.z()};
  // A step of at least a micrometre: a tree whose means all coincide still has a grid.
  grid.step = std::max((high - low).maxCoeff() / kGridSteps, 1e-6f);
  return grid;
}

PackedMode packMode(const LeafMode& mode, const ModeGrid& grid) {
  PackedMode packed;
  for (int k = 0; k < 3; ++k) {
    const float steps = (mode.mean[k] - grid.origin[k]) / grid.step;
    packed.mean[k] = std::isfinite(steps)
                         ? static_cast<uint16_t>(std::clamp(std::round(steps), 0.0f, kGridSteps))
                         : 0;
  }
  const Eigen::LLT<Eigen::Matrix3f> llt(mode.informationMatrix());
  if (llt.info() != Eigen::Success) return packed;
  const Eigen::Matrix3f u = llt.matrixU();
  packed.cholesky = {halfBits(u(0, 0)), halfBits(u(0, 1)), halfBits(u(0, 2)),
                     halfBits(u(1, 1)), halfBits(u(1, 2)), halfBits(u(2, 2))};
  return packed;
}

LeafMode unpackMode(const PackedMode& packed, const ModeGrid& grid) {
  LeafMode mode;
  for (int k = 0; k < 3; ++k) mode.mean[k] = grid.origin[k] + grid.step * packed.mean[k];
  const float u00 = halfValue(packed.cholesky[0]), u01 = halfValue(packed.cholesky[1]),
              u02 = halfValue(packed.cholesky[2]), u11 = halfValue(packed.cholesky[3]),
              u12 = halfValue(packed.cholesky[4]), u22 = halfValue(packed.cholesky[5]);
  // U^T U, upper triangle.
  mode.information = {u00 * u00,
                      u00 * u01,
                      u00 * u02,
                      u01 * u01 + u11 * u11,
                      u01 * u02 + u11 * u12,
                      u02 * u02 + u12 * u12 + u22 * u22};
  return mode;
}

void packModes(const std::vector<LeafMode>& modes, ModeGrid& grid,
               std::vector<PackedMode>& packed) {
  grid = modeGridOf(modes);
  packed.resize(modes.size());
  for (size_t m = 0; m < modes.size(); ++m) packed[m] = packMode(modes[m], grid);
}

}  // namespace relocalizer
