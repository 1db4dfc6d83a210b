#pragma once
// What every dataset target does with a folder once its files are written:
// open it as a user would, and use everything the Dataset offers.

#include <algorithm>
#include <string>

#include "relocalizer/data/dataset.h"

namespace relocalizer::fuzz {

inline void openAndLoad(const std::string& root, DatasetFormat format) {
  DatasetOptions options;
  options.format = format;
  auto dataset = openDataset(root, options);
  if (!dataset) return;
  const Dataset& d = **dataset;
  (void)d.summary();
  (void)d.camera();
  for (size_t i = 0; i < std::min<size_t>(d.size(), 3); ++i) {
    (void)d.id(i);
    (void)d.stamp(i);
    (void)d.groundTruth(i);
    (void)d.load(i);
  }
  (void)d.load(d.size());  // out of range: an Error, not an exception
}

}  // namespace relocalizer::fuzz
