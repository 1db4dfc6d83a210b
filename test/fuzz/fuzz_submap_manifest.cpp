// parseSubmapManifest on arbitrary text: the manifest.json of a folder of
// learned submaps (`model:=FOLDER`, `evaluate --model FOLDER`), which a user
// may have edited or a crash may have cut. Every outcome must be a value or
// an Error naming the file; an accepted manifest must survive
// serializeSubmapManifest and be read back the same.

#include <cstdint>
#include <cstdlib>
#include <string>

#include "relocalizer/online/submap_folder.h"

using namespace relocalizer;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto manifest = parseSubmapManifest(text, "fuzz/manifest.json");
  if (!manifest) {
    if (manifest.error().rfind("fuzz/manifest.json: ", 0) != 0) std::abort();
    return 0;
  }
  const std::string written = serializeSubmapManifest(*manifest);
  auto again = parseSubmapManifest(written, "fuzz/manifest.json");
  if (!again || serializeSubmapManifest(*again) != written) std::abort();
  for (const SubmapEntry& entry : again->submaps)
    if (entry.keyframes.find('/') != std::string::npos ||
        entry.model.find('/') != std::string::npos)
      std::abort();
  return 0;
}
