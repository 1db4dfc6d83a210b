#pragma once
// The key frames an online learner has seen, compressed and capped, so that a
// long run stops growing: every retrain reads them all, and a place carried
// over to the next run is its key frames (the model is derived from them).
//
// Colour is kept as JPEG (quality 95 loses nothing measurable for training,
// docs/online_learning.md) and depth as 16-bit PNG millimetres: about 185 KB a
// Kinect frame instead of 2.1 MB raw. When the store is full, the key frame
// most redundant by pose (keyFrameDistance, key_frame_rule.h) goes: the older
// of the two closest key frames, so the place keeps its coverage and a changed
// place is refreshed.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/file_io.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/forest/training.h"

namespace relocalizer {

struct StoredKeyFrame {
  int id = -1;  // frame id (dataset) or sequence number (node)
  double stamp = 0.0;
  CameraIntrinsics camera;
  Pose pose = Pose::Identity();  // camera-to-world
  std::vector<uint8_t> colour_jpeg;
  std::vector<uint8_t> depth_png;  // CV_16UC1 millimetres
  size_t bytes() const { return colour_jpeg.size() + depth_png.size() + sizeof(*this); }
};

// Compresses a posed frame; fails on frames that cannot be relocalized
// (frameValidationError) or cannot be encoded.
Expected<StoredKeyFrame> compressKeyFrame(const RgbdFrame& frame, const Pose& camera_to_world,
                                          int jpeg_quality = 95);
// Back to a training image (colour BGR8, depth float metres with NaN).
Expected<TrainingImage> decompressKeyFrame(const StoredKeyFrame& key_frame);

class KeyFrameStore {
 public:
  using Entry = std::shared_ptr<const StoredKeyFrame>;

  explicit KeyFrameStore(int capacity) : capacity_(capacity) {}

  // Adds at the end; when over capacity evicts the most redundant key frame
  // and returns true.
  bool add(Entry key_frame);
  const std::vector<Entry>& entries() const { return entries_; }
  size_t size() const { return entries_.size(); }
  size_t bytes() const;
  int capacity() const { return capacity_; }

 private:
  int capacity_;
  std::vector<Entry> entries_;  // in arrival order
};

// The key-frame file beside a model (`<model>.keyframes`): magic "PLKEYFRM",
// uint32 version, uint32 count, uint64 body length, uint32 CRC-32 of the body,
// then the body: (version 2) the identity of the model file saved with it,
// then per key frame id, stamp, intrinsics, the 3x4 pose and both images'
// bytes. Version 1 (no model identity) still loads.
//
// The identity binds the pair: a save killed between its two renames leaves
// new key frames beside the old model, and only the identity tells.
constexpr std::string_view kKeyFrameMagic{"PLKEYFRM", 8};
constexpr uint32_t kKeyFrameFormatVersion = 2;

// A model file as the key frames saved with it know it.
struct ModelFileId {
  uint32_t crc = 0;   // CRC-32 of the whole file
  uint64_t size = 0;  // bytes
  bool operator==(const ModelFileId& o) const { return crc == o.crc && size == o.size; }
  bool operator!=(const ModelFileId& o) const { return !(*this == o); }
};
ModelFileId modelFileId(const std::vector<uint8_t>& model_file);

struct KeyFrameFile {
  std::vector<StoredKeyFrame> key_frames;
  std::optional<ModelFileId> model;  // absent in version-1 files
  // Whether they were saved with the model file `id`, so that the two are one
  // saved place; version-1 files name no model and go with any.
  bool savedWith(const ModelFileId& id) const { return !model || *model == id; }
};

std::string keyFramesPath(const std::string& model_path);
std::vector<uint8_t> serializeKeyFrames(const std::vector<KeyFrameStore::Entry>& key_frames,
                                        const ModelFileId& model);
// A key-frame file's bytes (serializeKeyFrames's, or a copy of a file) as a
// replacement of `path` (core/file_io.h).
FileReplacement keyFrameFileReplacement(const std::string& path, std::vector<uint8_t> bytes);
Expected<KeyFrameFile> loadKeyFrames(const std::string& path);
// How a key-frame file is read (core/file_io.h): its header first, then
// the body length it names, which must be the rest of the file.
FileFormat keyFrameFileFormat();

}  // namespace relocalizer
