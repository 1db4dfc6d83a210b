#pragma once
// The model file: one point forest, one line forest and the scene surface, with
// everything needed to know how they were made.
//
// Layout (little-endian):
//   char[8]   magic "PLFOREST"
//   uint32    format version (kModelFormatVersion)
//   uint32    reserved, 0
//   uint64    body length in bytes
//   uint32    CRC-32 (zlib) of the body
//   body:
//     uint32 + bytes   header JSON: every training parameter and the training
//                      set summary (human readable with `strings` or `head -c`)
//     forest points, forest lines, each:
//       uint32 trees; per tree:
//         uint32 nodes n, uint32 modes m, ModeGrid (packed_mode.h), uint64
//         length of the zlib stream, the stream of: SplitNode[n],
//         PackedMode[m], Descriptor[m] (the 24 kept coefficients), each array
//         stored byte plane by byte plane (byte 0 of every element, then byte
//         1, ...), where deflate finds what repeats.
//     surface: float voxel size, uint32 n + SurfaceElement[n]
//     view lights: uint32 n + LightGrid[n] (float32), one per training image
// Saving is deterministic: the same model gives the same bytes.
//
// Older versions still load, converted:
//   1 (relocalizer 0.1.0): forests uncompressed, each tree as uint32 n +
//     SplitNode[n] (leaves as indices into the next array), uint32 n +
//     LeafRange[n], uint32 n + 92-byte modes with the descriptor inline; no
//     surface (relocalization then skips the surface fit and check, and says so).
//   2: version 1's forests, then the surface as in version 4.
//   3: version 4 without the view lights.
//   4: trees without a ModeGrid, of SplitNode[n], LeafMode[m] (36 bytes, full
//     precision) and 48-byte descriptors; loading packs the modes and keeps
//     the descriptors' first 24 (as training now does).

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/file_io.h"
#include "relocalizer/core/photometric_change.h"
#include "relocalizer/forest/forest.h"
#include "relocalizer/forest/training.h"

namespace relocalizer {

constexpr uint32_t kModelFormatVersion = 5;
// Every model file starts with it; a save replaces only files that do.
constexpr std::string_view kModelMagic{"PLFOREST", 8};

// CRC-32 (zlib) of any length (zlib's own call takes 32-bit lengths).
uint32_t crc32Of(const uint8_t* data, size_t size);

// What the forests were trained on.
struct TrainingSummary {
  std::string dataset;  // path as given
  std::string format;   // dataset format name
  std::string frames;   // selection expression, empty = all
  int images = 0;
  double seconds = 0.0;  // wall time of training
  int threads = 0;
  Eigen::Vector3f scene_min = Eigen::Vector3f::Zero();  // bounds of the camera centres
  Eigen::Vector3f scene_max = Eigen::Vector3f::Zero();
  // The light the forests learned colour in: the mean of the training images'
  // lightChromaticity (core/photometric_change.h), B, G, R. Zeros: not known
  // (models written before it was kept).
  Eigen::Vector3f light_chromaticity = Eigen::Vector3f::Zero();
  // Where each training image's light fell (lightGrid), in training order:
  // what a frame in other light is matched against (light_retry.h). Empty:
  // not kept (format versions before 4).
  std::vector<LightGrid> view_lights;
  std::string software_version;
};

struct Model {
  TrainingParams params;
  TrainingSummary summary;
  Forest points;
  Forest lines;
  SurfaceModel surface;  // empty for version-1 files and when training built none
};

std::vector<uint8_t> serializeModel(const Model& model);
// `source` names the bytes' origin in error messages.
Expected<Model> deserializeModel(const uint8_t* data, size_t size, const std::string& source);

// The one framing of a model file for writing: `serialized` (serializeModel's
// bytes, which a writer may need too, for modelFileId) as a replacement of
// `path` that only a model file or nothing may stand at (core/file_io.h).
FileReplacement modelFileReplacement(const std::string& path, std::vector<uint8_t> serialized);
// Writes `model` to `path` atomically (replaceFiles): on any failure the old
// file is as it was, no temporary is left, and the error names the path.
Status saveModel(const Model& model, const std::string& path);
// Bytes of a model's forests and surface in memory.
size_t modelBytes(const Model& model);
Expected<Model> loadModel(const std::string& path);
// How a model file is read (core/file_io.h): its 28-byte preamble first (a
// file that is not a model costs that read), then exactly the body length
// the preamble names; `what` names it in messages.
FileFormat modelFileFormat(const std::string& what);

// The header JSON of a model (parameters and summary), for tools and logs.
std::string modelHeaderJson(const Model& model, int indent = 2);

// TrainingParams <-> JSON, shared with the YAML config reader. Reading needs
// every key present (the config reader merges the file onto the defaults).
std::string trainingParamsToJson(const TrainingParams& params);
Expected<TrainingParams> trainingParamsFromJson(const std::string& json_text);

}  // namespace relocalizer
