// A 7-Scenes folder holding one tiny valid frame, whose text files come from
// the input: pose.txt, camera-intrinsics.txt, colour-registration.txt (parts
// separated by a "=====" line; see fuzz_support.h). Opened with format
// detection and loaded, so fuzzed intrinsics and registration reach the
// colour-to-depth resampling.

#include <cstdint>

#include "fuzz_dataset_common.h"
#include "fuzz_support.h"

using namespace relocalizer;
using namespace relocalizer::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string root = [] {
    const std::string dir = scratchDir() + "/seq-fuzz";
    makeDirs(dir);
    writeFile(dir + "/frame-000000.color.png", tinyColourPng());
    writeFile(dir + "/frame-000000.depth.png", tinyDepthPng());
    return dir;
  }();
  const auto parts = splitParts(data, size);
  writeOrRemove(root + "/frame-000000.pose.txt", part(parts, 0));
  writeOrRemove(root + "/camera-intrinsics.txt", part(parts, 1));
  writeOrRemove(root + "/colour-registration.txt", part(parts, 2));
  openAndLoad(root, DatasetFormat::Auto);
  return 0;
}
