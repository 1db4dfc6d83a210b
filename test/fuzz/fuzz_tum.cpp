// A TUM RGB-D folder holding rgb/1.png and depth/1.png (a tiny valid frame),
// whose rgb.txt, depth.txt and groundtruth.txt come from the input (three
// parts separated by a "=====" line; see fuzz_support.h). Inputs naming files
// outside the folder (absolute names, "..") are skipped, so a run does not
// depend on what else is on the machine.

#include <cstdint>

#include "fuzz_dataset_common.h"
#include "fuzz_support.h"

using namespace relocalizer;
using namespace relocalizer::fuzz;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string root = [] {
    // The folder name picks the freiburg1 calibration, as for a real sequence.
    const std::string dir = scratchDir() + "/rgbd_dataset_freiburg1_fuzz";
    makeDirs(dir + "/rgb");
    makeDirs(dir + "/depth");
    writeFile(dir + "/rgb/1.png", tinyColourPng());
    writeFile(dir + "/depth/1.png", tinyDepthPng());
    return dir;
  }();
  const auto parts = splitParts(data, size);
  for (const std::string& text : parts)
    if (escapesFolder(text)) return 0;
  writeOrRemove(root + "/rgb.txt", part(parts, 0));
  writeOrRemove(root + "/depth.txt", part(parts, 1));
  writeOrRemove(root + "/groundtruth.txt", part(parts, 2));
  openAndLoad(root, DatasetFormat::Tum);
  return 0;
}
