#include "relocalizer/online/keyframe_store.h"

#include "relocalizer/core/byte_io.h"
#include "relocalizer/core/file_io.h"
#include "relocalizer/core/key_frame_rule.h"
#include "relocalizer/forest/model_io.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/imgcodecs.hpp>

namespace relocalizer {

namespace {

constexpr size_t kHeaderBytes = 8 + 4 + 4 + 8 + 4;
// The fixed part of one key frame (id, stamp, fx fy cx cy, width, height, the
// 3x4 pose, both images' lengths): a count in the header, which the CRC does
// not cover, can claim no more key frames than the body has room for.
constexpr size_t kMinKeyFrameBytes = 4 + 8 + 4 * 8 + 4 + 4 + 12 * 8 + 4 + 4;

}  // namespace

Expected<StoredKeyFrame> compressKeyFrame(const RgbdFrame& frame, const Pose& camera_to_world,
                                          int jpeg_quality) {
  if (const std::string why = frameValidationError(frame); !why.empty())
    return makeError("key frame " + std::to_string(frame.id) + ": " + why);
  StoredKeyFrame key_frame;
  key_frame.id = frame.id;
  key_frame.stamp = frame.stamp;
  key_frame.camera = frame.camera;
  key_frame.pose = camera_to_world;
  if (!cv::imencode(".jpg", frame.colour, key_frame.colour_jpeg,
                    {cv::IMWRITE_JPEG_QUALITY, jpeg_quality}) ||
      !cv::imencode(".png", depthToMillimetres(frame.depth), key_frame.depth_png,
                    {cv::IMWRITE_PNG_COMPRESSION, 1}))
    return makeError("key frame " + std::to_string(frame.id) + ": image encoding failed");
  return key_frame;
}

Expected<TrainingImage> decompressKeyFrame(const StoredKeyFrame& key_frame) {
  TrainingImage image;
  image.colour = cv::imdecode(key_frame.colour_jpeg, cv::IMREAD_COLOR);
  const cv::Mat depth_mm = cv::imdecode(key_frame.depth_png, cv::IMREAD_ANYDEPTH);
  const std::string name = "key frame " + std::to_string(key_frame.id);
  if (image.colour.empty() || depth_mm.type() != CV_16UC1)
    return makeError(name + ": stored colour or depth image does not decode");
  if (image.colour.size() != depth_mm.size() || image.colour.cols != key_frame.camera.width ||
      image.colour.rows != key_frame.camera.height)
    return makeError(name + ": stored image size disagrees with its intrinsics");
  auto metres = depthToMetres(depth_mm, 1000.0);
  if (!metres) return makeError(name + ": " + metres.error());
  image.depth = *metres;
  image.camera = key_frame.camera;
  image.pose = key_frame.pose;
  return image;
}

bool KeyFrameStore::add(Entry key_frame) {
  entries_.push_back(std::move(key_frame));
  if (static_cast<int>(entries_.size()) <= std::max(capacity_, 1)) return false;
  // O(n^2) over at most a few hundred poses, once per key frame: negligible
  // beside compressing the frame.
  double best = std::numeric_limits<double>::infinity();
  size_t evict = 0;
  for (size_t i = 0; i < entries_.size(); ++i)
    for (size_t j = i + 1; j < entries_.size(); ++j) {
      const double d = keyFrameDistance(entries_[i]->pose, entries_[j]->pose);
      if (d < best) {
        best = d;
        evict = i;  // the older of the pair
      }
    }
  entries_.erase(entries_.begin() + static_cast<std::ptrdiff_t>(evict));
  return true;
}

size_t KeyFrameStore::bytes() const {
  size_t total = 0;
  for (const Entry& e : entries_) total += e->bytes();
  return total;
}

std::string keyFramesPath(const std::string& model_path) { return model_path + ".keyframes"; }

ModelFileId modelFileId(const std::vector<uint8_t>& model_file) {
  return {crc32Of(model_file.data(), model_file.size()), model_file.size()};
}

FileReplacement keyFrameFileReplacement(const std::string& path, std::vector<uint8_t> bytes) {
  return FileReplacement{path, kKeyFrameMagic, "relocalizer key-frame file", std::move(bytes)};
}

std::vector<uint8_t> serializeKeyFrames(const std::vector<KeyFrameStore::Entry>& key_frames,
                                        const ModelFileId& model) {
  std::vector<uint8_t> body;
  ByteWriter b(body);
  b.value(model.crc);
  b.value(model.size);
  for (const auto& k : key_frames) {
    b.value(static_cast<int32_t>(k->id));
    b.value(k->stamp);
    for (double v : {k->camera.fx, k->camera.fy, k->camera.cx, k->camera.cy}) b.value(v);
    b.value(static_cast<int32_t>(k->camera.width));
    b.value(static_cast<int32_t>(k->camera.height));
    const Eigen::Matrix<double, 3, 4> m = k->pose.matrix().topRows<3>();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) b.value(m(r, c));
    b.array(k->colour_jpeg);
    b.array(k->depth_png);
  }
  std::vector<uint8_t> file(kKeyFrameMagic.begin(), kKeyFrameMagic.end());
  ByteWriter f(file);
  f.value(kKeyFrameFormatVersion);
  f.value(static_cast<uint32_t>(key_frames.size()));
  f.value(static_cast<uint64_t>(body.size()));
  f.value(crc32Of(body.data(), body.size()));
  f.bytes(body.data(), body.size());
  return file;
}

FileFormat keyFrameFileFormat() {
  FileFormat format;
  format.what = "key-frame file";
  format.head_bytes = kHeaderBytes;
  format.length = [](const std::vector<uint8_t>& head, uint64_t file_size) -> Expected<uint64_t> {
    if (head.size() < kHeaderBytes || std::memcmp(head.data(), kKeyFrameMagic.data(), 8) != 0)
      return makeError("not a key-frame file (bad magic)");
    ByteReader header(head.data() + 8, kHeaderBytes - 8);
    uint32_t version = 0, count = 0;
    uint64_t length = 0;
    header.value(version);
    header.value(count);
    header.value(length);
    if (version < 1 || version > kKeyFrameFormatVersion)
      return makeError("key-frame file version " + std::to_string(version) +
                       " is not supported (this build reads versions 1 to " +
                       std::to_string(kKeyFrameFormatVersion) + ")");
    if (length != file_size - kHeaderBytes)
      return makeError("key-frame file is truncated or has trailing bytes");
    return file_size;
  };
  return format;
}

Expected<KeyFrameFile> loadKeyFrames(const std::string& path) {
  // The head is checked (magic, version, length) before the body is read.
  auto read = readRegularFile(path, keyFrameFileFormat());
  if (!read) return makeError(read.error());
  const std::vector<uint8_t>& file = *read;
  ByteReader header(file.data() + 8, kHeaderBytes - 8);
  uint32_t version = 0, count = 0, crc = 0;
  uint64_t length = 0;
  header.value(version);
  header.value(count);
  header.value(length);
  header.value(crc);
  const uint8_t* body = file.data() + kHeaderBytes;
  if (crc32Of(body, length) != crc)
    return makeError(path + ": key-frame file is corrupt (CRC mismatch)");
  ByteReader r(body, length);
  KeyFrameFile loaded;
  if (version >= 2) {
    ModelFileId model;
    if (!r.value(model.crc) || !r.value(model.size))
      return makeError(path + ": key-frame file ends inside its model identity");
    loaded.model = model;
  }
  if (count > r.remaining() / kMinKeyFrameBytes)
    return makeError(path + ": key-frame file claims " + std::to_string(count) +
                     " key frames, but its " + std::to_string(r.remaining()) +
                     " bytes hold at most " + std::to_string(r.remaining() / kMinKeyFrameBytes) +
                     " (damaged header)");
  std::vector<StoredKeyFrame>& key_frames = loaded.key_frames;
  key_frames.resize(count);
  for (StoredKeyFrame& k : key_frames) {
    int32_t id = 0, width = 0, height = 0;
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    bool ok = r.value(id) && r.value(k.stamp) && r.value(k.camera.fx) && r.value(k.camera.fy) &&
              r.value(k.camera.cx) && r.value(k.camera.cy) && r.value(width) && r.value(height);
    for (int row = 0; ok && row < 3; ++row)
      for (int c = 0; ok && c < 4; ++c) ok = r.value(m(row, c));
    ok = ok && r.array(k.colour_jpeg) && r.array(k.depth_png);
    if (!ok) return makeError(path + ": key-frame file ends inside a key frame");
    k.id = id;
    k.camera.width = width;
    k.camera.height = height;
    auto pose = poseFromMatrix(m);
    if (!pose) return makeError(path + ": key frame " + std::to_string(id) + ": " + pose.error());
    k.pose = *pose;
  }
  if (r.remaining() != 0)
    return makeError(path + ": key-frame file has bytes after its last key frame");
  return loaded;
}

}  // namespace relocalizer
