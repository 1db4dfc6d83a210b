// The node's ~load_place and ~unload_place as they run without ROS
// (online/place_files.h, relocalize/place_set.h): a name, a model path and a
// map frame from a peer, the path reaching a file or a folder whose bytes
// are the input's. Input: parts split by "=====" lines (fuzz_support.h):
// name, path (inside a scratch folder holding `model` and `set/`), map frame,
// the bytes of `model`, the bytes of `set/manifest.json`, a name to unload.
// Every outcome is an answer: never an exception, and every refusal of a
// path that is not ours reads the same and is printable UTF-8.

#include <cstdint>
#include <cstdlib>
#include <string>

#include "fuzz_support.h"
#include "relocalizer/core/outside_text.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/online/place_files.h"
#include "relocalizer/online/submap_folder.h"

using namespace relocalizer;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::vector<std::string> parts = fuzz::splitParts(data, size);
  // A one-line field: the part without the newline before the next separator.
  const auto field = [&](size_t i, const char* absent) {
    std::string text = fuzz::part(parts, i).value_or(absent);
    if (i + 1 < parts.size() && !text.empty() && text.back() == '\n') text.pop_back();
    return text;
  };
  const std::string name = field(0, "");
  std::string requested = field(1, "model");
  const std::string frame = field(2, "map");
  const std::string root = fuzz::scratchDir() + "/places";
  fuzz::makeDirs(root + "/set");
  fuzz::writeOrRemove(root + "/model", fuzz::part(parts, 3));
  fuzz::writeOrRemove(submapManifestPath(root + "/set"), fuzz::part(parts, 4));
  // Inside the scratch folder (a leading '/' dropped); `..` may still leave
  // it, to read what is there.
  while (!requested.empty() && requested.front() == '/') requested.erase(0, 1);
  const std::string path = root + "/" + requested;

  PlaceSet set;
  const std::string unreadable = unreadablePlaceError(name, path);
  if (!printableText(unreadable)) std::abort();
  if (unreadable.empty()) {
    auto loaded = openPlace(name, path, frame, {});
    if (!loaded) {
      if (!printableText(loaded.error())) std::abort();
    } else {
      const size_t count = loaded->places.size();
      if (putPlaceFiles(set, name, std::move(*loaded)).ok() && set.size() != count) std::abort();
    }
  }
  set.list();
  set.remove(field(5, name.c_str()));
  set.remove(name);
  if (set.size() != 0) std::abort();
  return 0;
}
