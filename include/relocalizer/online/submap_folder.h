#pragma once
// The folder a set of learned submaps is saved as (issue 26): each submap's
// model and key frames as the pair OnlineLearner::save writes
// (`submap-0003.model` + `submap-0003.model.keyframes`), and `manifest.json`,
// written last, which names them. The manifest also holds every submap's
// key-frame poses, so a resumed run knows which areas are covered without
// reading a key-frame file (12 MB a full submap).
//
// The manifest is nlohmann's ordered_json dumped with an indent of 2, so it
// starts with kSubmapManifestMagic: replaceFiles (core/file_io.h) then
// overwrites only a manifest.json of ours, never a user's file of that name.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/key_frame_rule.h"
#include "relocalizer/online/keyframe_store.h"
#include "relocalizer/online/submap_rule.h"

namespace relocalizer {

constexpr std::string_view kSubmapManifestMagic{"{\n  \"format\": \"relocalizer learned submaps\""};
constexpr const char* kSubmapManifestName = "manifest.json";
constexpr int kSubmapFormatVersion = 1;
// What a manifest may name, so that a damaged or hostile one cannot make a
// reader allocate by it: the set's containers are by index (a learner that
// made 100,000 submaps would hold terabytes of models first), key-frame ids
// are saved as int32, and 64 MiB is some 120,000 key-frame poses (the
// 18-submap redkitchen set's manifest is 1.1 MB).
constexpr int kMaxSubmapIndex = 99999;
constexpr std::int64_t kMaxKeyFrameId = 2147483646;
constexpr std::uint64_t kMaxSubmapManifestBytes = std::uint64_t{64} << 20;

// One submap as the manifest names it.
struct SubmapEntry {
  int index = 0;
  std::string name;  // the place it answers as (`<place_name>/<index>`)
  bool frozen = true;
  // File names inside the folder. `model` is empty for an active submap saved
  // before its first retrain (its key frames alone were written).
  std::string model;
  std::string keyframes;
  ModelFileId model_id;  // of the model file (none when `model` is empty)
  // The submap's key frames (SubmapIndex ids and camera-to-world poses); the
  // manifest's keyframe_count is their number.
  std::vector<SubmapKeyFrame> keyframe_poses;
};

struct SubmapManifest {
  std::string place_name = "learned";
  std::string map_frame = "map";
  std::string software_version;
  // The settings the set was learned with (for the reader; a resumed run
  // learns with its own).
  KeyFrameMotion min_motion;
  int max_keyframes = 0;
  SubmapParams submap_params;
  int active = -1;                   // the active submap's index; -1 when none
  std::vector<SubmapEntry> submaps;  // by index, ascending
};

// `submap-0003.model`: the model file name of submap `index`.
std::string submapFileName(int index);
// `learned/3`: the place name of submap `index` of place `place`.
std::string submapPlaceName(const std::string& place, int index);
// `<folder>/manifest.json`.
std::string submapManifestPath(const std::string& folder);

// Where a save a peer asks for (~save_model's `path`), or the node's
// save_on_exit, may write: the folder `requested` names, relative ones inside
// `root`, resolved without symbolic links; an error unless it lies inside
// `root` (not `root` itself) and is new, empty, or a saved set (our
// manifest.json, or only submap files).
// `root` is created when missing (it is the operator's). The error quotes
// `requested` only when it is printable text.
Expected<std::string> confinedSaveFolder(const std::string& root, const std::string& requested);

std::string serializeSubmapManifest(const SubmapManifest& manifest);
// The manifest as a replacement of `<folder>/manifest.json` (core/file_io.h).
FileReplacement submapManifestReplacement(const std::string& folder,
                                          const SubmapManifest& manifest);
// Reads `<folder>/manifest.json` (neither a symbolic link nor larger than
// kMaxSubmapManifestBytes). Errors name the file and, for a bad field, the
// field (`submaps[2].keyframe_poses[5].pose`).
Expected<SubmapManifest> readSubmapManifest(const std::string& folder);
// The same from the manifest's text; `path` names it in errors.
Expected<SubmapManifest> parseSubmapManifest(const std::string& text, const std::string& path);

}  // namespace relocalizer
