// A 12-Scenes folder (info.txt + data/) holding one tiny valid frame, whose
// info.txt and data/frame-000000.pose.txt come from the input (two parts
// separated by a "=====" line; see fuzz_support.h).

#include <cstdint>

#include "fuzz_dataset_common.h"
#include "fuzz_support.h"

using namespace relocalizer;
using namespace relocalizer::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string root = [] {
    const std::string dir = scratchDir() + "/twelve";
    makeDirs(dir + "/data");
    writeFile(dir + "/data/frame-000000.color.png", tinyColourPng());
    writeFile(dir + "/data/frame-000000.depth.png", tinyDepthPng());
    return dir;
  }();
  const auto parts = splitParts(data, size);
  writeOrRemove(root + "/info.txt", part(parts, 0));
  writeOrRemove(root + "/data/frame-000000.pose.txt", part(parts, 1));
  openAndLoad(root, DatasetFormat::TwelveScenes);
  return 0;
}
