// parseSubmapManifest on arbitrary text: the manifest.json of a folder of
// learned submaps (`model:=FOLDER`, `evaluate --model FOLDER`), which a user
// may have edited or a crash may have cut. Every outcome must be a value or
// an Error naming the file, in printable UTF-8 whatever bytes the text holds;
// an accepted manifest must survive serializeSubmapManifest and be read back
// the same, name indices and key-frame ids within their bounds, and load as a
// folder (its files absent) to an Error, never an exception: an index of
// 2147483647 once overflowed the loader's `index + 1` (std::length_error,
// the node aborted) and 10,000,000 sized its containers (+840 MB).

#include <cstdint>
#include <cstdlib>
#include <string>

#include "fuzz_support.h"
#include "relocalizer/core/outside_text.h"
#include "relocalizer/online/submap_archive.h"
#include "relocalizer/online/submap_folder.h"

using namespace relocalizer;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto manifest = parseSubmapManifest(text, "fuzz/manifest.json");
  if (!manifest) {
    if (manifest.error().rfind("fuzz/manifest.json: ", 0) != 0) std::abort();
    if (!printableText(manifest.error())) std::abort();
    return 0;
  }
  const std::string written = serializeSubmapManifest(*manifest);
  auto again = parseSubmapManifest(written, "fuzz/manifest.json");
  if (!again || serializeSubmapManifest(*again) != written) std::abort();
  for (const SubmapEntry& entry : again->submaps) {
    if (entry.keyframes.find('/') != std::string::npos ||
        entry.model.find('/') != std::string::npos)
      std::abort();
    if (entry.index < 0 || entry.index > kMaxSubmapIndex) std::abort();
    for (const SubmapKeyFrame& k : entry.keyframe_poses)
      if (k.id < 0 || k.id > kMaxKeyFrameId) std::abort();
  }
  // As a folder whose submap files are missing: each is skipped (or the
  // settings refused), never thrown for.
  const std::string folder = fuzz::scratchDir() + "/set";
  fuzz::makeDirs(folder);
  fuzz::writeFile(submapManifestPath(folder), text);
  auto loaded = loadSavedSubmaps(folder, "fuzz", "map", {});
  if (loaded.ok() || loaded.error().find(folder + ": cannot be loaded: ") != std::string::npos)
    std::abort();
  return 0;
}
