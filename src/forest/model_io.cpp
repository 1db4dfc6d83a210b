#include "relocalizer/forest/model_io.h"

#include "relocalizer/core/byte_io.h"
#include "relocalizer/core/file_io.h"
#include "relocalizer/core/json_fields.h"
#include "relocalizer/core/version.h"
#include "training_params_json.h"

#include <zlib.h>

#include <tbb/parallel_for.h>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <type_traits>

namespace relocalizer {

namespace {

using detail::checkedNumber;
using detail::readField;

using nlohmann::json;

constexpr size_t kPreambleSize = 8 + 4 + 4 + 8 + 4;

// Versions 1 and 2 stored leaves as an index into a range array and 92-byte
// modes with their descriptor, support and log-determinant inline.
namespace v1 {
struct LeafMode {
  float mean[3];
  float support;
  float information[6];
  float log_det_covariance;
  Descriptor descriptor;
};
static_assert(sizeof(LeafMode) == 92, "version-1 mode layout");
}  // namespace v1
static_assert(sizeof(LeafRange) == 8, "LeafRange layout is part of the model format");
static_assert(sizeof(SurfaceElement) == 24, "SurfaceElement layout is part of the model format");

json vec3Json(const Eigen::Vector3f& v) { return {v.x(), v.y(), v.z()}; }
Eigen::Vector3f vec3From(const json& j, const std::string& name) {
  if (!j.is_array() || j.size() != 3)
    throw std::out_of_range("'" + name + "' must be 3 numbers, got " + detail::quoted(j));
  return Eigen::Vector3f(checkedNumber<float>(j[0], name), checkedNumber<float>(j[1], name),
                         checkedNumber<float>(j[2], name));
}

json headerJson(const Model& m) {
  const auto& s = m.summary;
  return {{"format_version", kModelFormatVersion},
          {"params", detail::trainingParamsJson(m.params)},
          {"training_set",
           {{"dataset", s.dataset},
            {"format", s.format},
            {"frames", s.frames},
            {"images", s.images},
            {"seconds", s.seconds},
            {"threads", s.threads},
            {"scene_min", vec3Json(s.scene_min)},
            {"scene_max", vec3Json(s.scene_max)},
            {"light_chromaticity", vec3Json(s.light_chromaticity)},
            {"software_version", s.software_version}}},
          {"forests",
           {{"points",
             {{"trees", m.points.trees.size()},
              {"nodes", m.points.nodeCount()},
              {"leaves", m.points.leafCount()},
              {"modes", m.points.modeCount()}}},
            {"lines",
             {{"trees", m.lines.trees.size()},
              {"nodes", m.lines.nodeCount()},
              {"leaves", m.lines.leafCount()},
              {"modes", m.lines.modeCount()}}}}},
          {"surface",
           {{"elements", m.surface.elements().size()}, {"voxel_size", m.surface.voxelSize()}}}};
}

// A tree's arrays as version 2 stores them: each array byte plane by byte
// plane (byte 0 of every element, then byte 1, ...), so that the bytes that
// change little from one element to the next (float exponents, the high bytes
// of indices, the same descriptor coefficient of every mode) sit together,
// where deflate finds them; then deflated, one stream per tree.
void appendPlanes(std::vector<uint8_t>& out, const void* data, size_t count, size_t size) {
  const auto* bytes = static_cast<const uint8_t*>(data);
  const size_t base = out.size();
  out.resize(base + count * size);
  for (size_t b = 0; b < size; ++b)
    for (size_t i = 0; i < count; ++i) out[base + b * count + i] = bytes[i * size + b];
}

void readPlanes(const uint8_t* planes, void* data, size_t count, size_t size) {
  auto* bytes = static_cast<uint8_t*>(data);
  for (size_t b = 0; b < size; ++b)
    for (size_t i = 0; i < count; ++i) bytes[i * size + b] = planes[b * count + i];
}

size_t treeBytes(size_t nodes, size_t modes) {
  return nodes * sizeof(SplitNode) + modes * (sizeof(LeafMode) + sizeof(Descriptor));
}

// Writing ends train and every submap freeze: level 6 took 1.9 s of train's
// 31 s for a file 5 % smaller than level 1's (docs/benchmarks.md).
constexpr int kDeflateLevel = 1;

// The deflated stream of one tree: uint32 nodes, uint32 modes, uint64 stored
// size, then the stream.
std::vector<uint8_t> packTree(const Tree& t) {
  std::vector<uint8_t> raw;
  raw.reserve(treeBytes(t.nodes.size(), t.modes.size()));
  appendPlanes(raw, t.nodes.data(), t.nodes.size(), sizeof(SplitNode));
  appendPlanes(raw, t.modes.data(), t.modes.size(), sizeof(LeafMode));
  appendPlanes(raw, t.descriptors.data(), t.descriptors.size(), sizeof(Descriptor));
  uLongf stored = compressBound(static_cast<uLong>(raw.size()));
  std::vector<uint8_t> packed(16 + stored);
  if (compress2(packed.data() + 16, &stored, raw.data(), static_cast<uLong>(raw.size()),
                kDeflateLevel) != Z_OK)
    throw std::runtime_error("zlib could not deflate a tree");
  packed.resize(16 + stored);
  const uint32_t nodes = static_cast<uint32_t>(t.nodes.size()),
                 modes = static_cast<uint32_t>(t.modes.size());
  const uint64_t stored_size = stored;
  std::memcpy(packed.data(), &nodes, 4);
  std::memcpy(packed.data() + 4, &modes, 4);
  std::memcpy(packed.data() + 8, &stored_size, 8);
  return packed;
}

// Structural checks, so a model that passed the checksum but was written by a
// buggy trainer cannot make prediction read out of bounds.
std::string validateTree(const Tree& t) {
  if (t.nodes.empty()) return "a tree has no nodes";
  if (t.descriptors.size() != t.modes.size()) return "modes and descriptors differ in number";
  for (size_t i = 0; i < t.nodes.size(); ++i) {
    const SplitNode& n = t.nodes[i];
    if (n.isLeaf()) {
      const LeafRange range = n.leafModes();
      if (static_cast<uint64_t>(range.first_mode) + range.mode_count > t.modes.size())
        return "leaf mode range out of bounds";
      continue;
    }
    if (static_cast<size_t>(n.left) <= i || static_cast<size_t>(n.left) + 1 >= t.nodes.size())
      return "child index out of range";
    // evaluateFeature indexes BGR pixels with the channels unchecked.
    const PixelFeature& f = n.feature;
    if (f.type != FeatureType::Colour && f.type != FeatureType::Depth)
      return "unknown feature type " + std::to_string(static_cast<int>(f.type));
    if (f.channel_p > 2 || f.channel_q > 2) return "colour channel out of range";
  }
  return {};
}

bool readTreeCount(ByteReader& r, uint32_t& trees, std::string& why) {
  if (!r.value(trees)) return false;
  if (trees > kMaxTrees) {
    why = "forest has " + std::to_string(trees) + " trees, more than " + std::to_string(kMaxTrees);
    return false;
  }
  return true;
}

// Reads the tree streams of one forest (the counts and stored sizes first, so
// that the streams can be inflated in parallel).
bool readTrees(ByteReader& r, Forest& forest, std::string& why) {
  uint32_t trees = 0;
  if (!readTreeCount(r, trees, why)) return false;
  struct Stream {
    uint32_t nodes = 0, modes = 0;
    uint64_t stored = 0;
    const uint8_t* data = nullptr;
  };
  std::vector<Stream> streams(trees);
  for (Stream& s : streams) {
    if (!r.value(s.nodes) || !r.value(s.modes) || !r.value(s.stored) || s.stored > r.remaining())
      return false;
    // Deflate expands at most 1032:1, so larger claimed sizes are corrupt (and
    // would make a small hostile file allocate gigabytes).
    if (treeBytes(s.nodes, s.modes) > 1032 * s.stored + 64) {
      why = "a tree's size does not match its compressed data";
      return false;
    }
    s.data = r.position();
    r.skip(s.stored);
  }
  forest.trees.assign(trees, Tree{});
  std::vector<std::string> errors(trees);
  tbb::parallel_for(size_t{0}, streams.size(), [&](size_t k) {
    const Stream& s = streams[k];
    Tree& t = forest.trees[k];
    std::vector<uint8_t> raw(treeBytes(s.nodes, s.modes));
    uLongf size = static_cast<uLongf>(raw.size());
    if (uncompress(raw.data(), &size, s.data, static_cast<uLong>(s.stored)) != Z_OK ||
        size != raw.size()) {
      errors[k] = "a tree's compressed data is corrupt";
      return;
    }
    t.nodes.resize(s.nodes);
    t.modes.resize(s.modes);
    t.descriptors.resize(s.modes);
    const uint8_t* planes = raw.data();
    readPlanes(planes, t.nodes.data(), s.nodes, sizeof(SplitNode));
    planes += s.nodes * sizeof(SplitNode);
    readPlanes(planes, t.modes.data(), s.modes, sizeof(LeafMode));
    planes += s.modes * sizeof(LeafMode);
    readPlanes(planes, t.descriptors.data(), s.modes, sizeof(Descriptor));
    errors[k] = validateTree(t);
  });
  for (const std::string& error : errors)
    if (!error.empty()) {
      why = error;
      return false;
    }
  return true;
}

// A version-1 or -2 forest, converted: each leaf's range moves into its node, each
// mode's descriptor into the descriptor array; support and log-determinant,
// which nothing reads, are dropped.
bool readTreesV1(ByteReader& r, Forest& forest, std::string& why) {
  uint32_t trees = 0;
  if (!readTreeCount(r, trees, why)) return false;
  forest.trees.resize(trees);
  std::vector<LeafRange> leaves;
  std::vector<v1::LeafMode> modes;
  for (Tree& t : forest.trees) {
    if (!r.array(t.nodes) || !r.array(leaves) || !r.array(modes)) return false;
    for (SplitNode& n : t.nodes) {
      if (!n.isLeaf()) continue;
      // -(left + 1) in 64 bits: left may be INT32_MIN.
      const int64_t leaf = -(static_cast<int64_t>(n.left) + 1);
      if (leaf >= static_cast<int64_t>(leaves.size())) {
        why = "leaf index out of range";
        return false;
      }
      n = SplitNode::leaf(leaves[leaf]);
    }
    t.modes.resize(modes.size());
    t.descriptors.resize(modes.size());
    for (size_t m = 0; m < modes.size(); ++m) {
      std::memcpy(t.modes[m].mean.data(), modes[m].mean, sizeof modes[m].mean);
      std::memcpy(t.modes[m].information.data(), modes[m].information, sizeof modes[m].information);
      t.descriptors[m] = modes[m].descriptor;
    }
    why = validateTree(t);
    if (!why.empty()) return false;
  }
  return true;
}

void writeSurface(ByteWriter& w, const SurfaceModel& surface) {
  w.value(surface.voxelSize());
  w.array(surface.elements());
}

bool readSurface(ByteReader& r, SurfaceModel& surface, std::string& why) {
  float voxel_size = 0.0f;
  std::vector<SurfaceElement> elements;
  if (!r.value(voxel_size) || !r.array(elements)) return false;
  if (!(voxel_size > 0.0f && std::isfinite(voxel_size))) {
    why = "surface voxel size " + std::to_string(voxel_size) + " is not a positive number";
    return false;
  }
  for (const SurfaceElement& e : elements)
    if (!e.point.allFinite() || !(std::abs(e.normal.norm() - 1.0f) < 1e-3f)) {
      why = "a surface element has a non-finite point or a normal that is not unit length";
      return false;
    }
  surface = SurfaceModel(voxel_size, std::move(elements));
  return true;
}

// Why the preamble (magic, version, body length, CRC) at `data` (`size`
// bytes of a file of `total` bytes) is not a model's, with the fields read
// when it is: the check loadModel makes on a file's first bytes before
// reading the rest, and deserializeModel makes again.
std::string preambleError(const uint8_t* data, size_t size, uint64_t total, uint32_t& version,
                          uint64_t& body_size, uint32_t& crc) {
  if (size < kModelMagic.size() || std::memcmp(data, kModelMagic.data(), kModelMagic.size()) != 0)
    return "not a relocalizer model (wrong magic number; expected a file written by `train`)";
  ByteReader r(data, size);
  char magic[8];
  uint32_t reserved = 0;
  if (!r.bytes(magic, 8) || !r.value(version) || !r.value(reserved) || !r.value(body_size) ||
      !r.value(crc))
    return "truncated model file (header incomplete)";
  if (version < 1 || version > kModelFormatVersion)
    return "model format version " + std::to_string(version) +
           " is not supported (this build reads versions 1 to " +
           std::to_string(kModelFormatVersion) + "); retrain or use a matching build";
  if (body_size > total - kPreambleSize)
    return "truncated model file (" + std::to_string(total - kPreambleSize) + " of " +
           std::to_string(body_size) + " body bytes present)";
  return {};
}

bool readViewLights(ByteReader& r, std::vector<LightGrid>& view_lights, std::string& why) {
  if (!r.array(view_lights)) return false;
  for (const LightGrid& grid : view_lights)
    for (float light : grid)
      if (!(light >= 0.0f && light <= 1.0f)) {
        why = "a cell's mean linear light is not in 0..1";
        return false;
      }
  return true;
}

}  // namespace

std::string modelHeaderJson(const Model& model, int indent) {
  return headerJson(model).dump(indent);
}

std::vector<uint8_t> serializeModel(const Model& model) {
  std::vector<uint8_t> body;
  ByteWriter w(body);
  const std::string header = headerJson(model).dump();
  w.value(static_cast<uint32_t>(header.size()));
  w.bytes(header.data(), header.size());
  for (const Forest* forest : {&model.points, &model.lines}) {
    // Deflating is most of saving: the trees in parallel, in order.
    std::vector<std::vector<uint8_t>> packed(forest->trees.size());
    tbb::parallel_for(size_t{0}, packed.size(),
                      [&](size_t t) { packed[t] = packTree(forest->trees[t]); });
    w.value(static_cast<uint32_t>(forest->trees.size()));
    for (const auto& tree : packed) w.bytes(tree.data(), tree.size());
  }
  writeSurface(w, model.surface);
  w.array(model.summary.view_lights);

  std::vector<uint8_t> out;
  out.reserve(kPreambleSize + body.size());
  ByteWriter p(out);
  p.bytes(kModelMagic.data(), kModelMagic.size());
  p.value(kModelFormatVersion);
  p.value(static_cast<uint32_t>(0));
  p.value(static_cast<uint64_t>(body.size()));
  p.value(crc32Of(body.data(), body.size()));
  out.insert(out.end(), body.begin(), body.end());
  return out;
}

Expected<Model> deserializeModel(const uint8_t* data, size_t size, const std::string& source) {
  const std::string where = source + ": ";
  uint64_t body_size = 0;
  uint32_t version = 0, crc = 0;
  if (std::string why = preambleError(data, size, size, version, body_size, crc); !why.empty())
    return makeError(where + why);
  const uint8_t* body = data + kPreambleSize;
  if (crc32Of(body, body_size) != crc)
    return makeError(where + "checksum mismatch: the model file is corrupt");

  ByteReader b(body, body_size);
  uint32_t header_size = 0;
  if (!b.value(header_size) || header_size > b.remaining())
    return makeError(where + "truncated model file (header JSON)");
  std::string header(header_size, '\0');
  b.bytes(header.data(), header_size);
  Model model;
  try {
    const json j = json::parse(header);
    detail::readTrainingParams(j.at("params"), model.params);
    const json& s = j.at("training_set");
    model.summary.dataset = s.at("dataset");
    model.summary.format = s.at("format");
    model.summary.frames = s.at("frames");
    readField(s, "training_set.", "images", model.summary.images);
    readField(s, "training_set.", "seconds", model.summary.seconds);
    readField(s, "training_set.", "threads", model.summary.threads);
    model.summary.scene_min = vec3From(s.at("scene_min"), "training_set.scene_min");
    model.summary.scene_max = vec3From(s.at("scene_max"), "training_set.scene_max");
    if (s.contains("light_chromaticity"))  // kept since 2026-11-29
      model.summary.light_chromaticity =
          vec3From(s.at("light_chromaticity"), "training_set.light_chromaticity");
    model.summary.software_version = s.at("software_version");
  } catch (const std::exception& e) {
    return makeError(where + "model header is not valid: " + detail::jsonErrorReason(e));
  }
  std::string why;
  const auto read = version <= 2 ? readTreesV1 : readTrees;
  if (!read(b, model.points, why) || !read(b, model.lines, why))
    return makeError(
        where + (why.empty() ? "truncated model file (forest data)" : "invalid forest: " + why));
  if (version >= 2 && !readSurface(b, model.surface, why))
    return makeError(
        where + (why.empty() ? "truncated model file (surface data)" : "invalid surface: " + why));
  if (version >= 4 && !readViewLights(b, model.summary.view_lights, why))
    return makeError(where + (why.empty() ? "truncated model file (view lights)"
                                          : "invalid view lights: " + why));
  if (b.remaining() != 0)
    return makeError(where + "unexpected bytes after the forests, surface and view lights");
  return model;
}

uint32_t crc32Of(const uint8_t* data, size_t size) {
  uLong crc = crc32(0L, Z_NULL, 0);
  for (size_t offset = 0; offset < size;) {
    const uInt chunk = static_cast<uInt>(std::min<size_t>(size - offset, 1u << 30));
    crc = crc32(crc, data + offset, chunk);
    offset += chunk;
  }
  return static_cast<uint32_t>(crc);
}

FileReplacement modelFileReplacement(const std::string& path, std::vector<uint8_t> serialized) {
  return FileReplacement{path, kModelMagic, "relocalizer model file", std::move(serialized)};
}

Status saveModel(const Model& model, const std::string& path) {
  return replaceFiles({modelFileReplacement(path, serializeModel(model))});
}

FileFormat modelFileFormat(const std::string& what) {
  FileFormat format;
  format.what = what;
  format.head_bytes = kPreambleSize;
  format.length = [](const std::vector<uint8_t>& head, uint64_t file_size) -> Expected<uint64_t> {
    uint32_t version = 0, crc = 0;
    uint64_t body_size = 0;
    if (std::string why =
            preambleError(head.data(), head.size(), file_size, version, body_size, crc);
        !why.empty())
      return makeError(why);
    return kPreambleSize + body_size;
  };
  return format;
}

Expected<Model> loadModel(const std::string& path) {
  auto bytes = readRegularFile(path, modelFileFormat("model file"));
  if (!bytes) return makeError(bytes.error());
  return deserializeModel(bytes->data(), bytes->size(), path);
}

size_t modelBytes(const Model& model) {
  size_t bytes = model.surface.elements().size() * sizeof(SurfaceElement);
  for (const Forest* forest : {&model.points, &model.lines})
    for (const Tree& tree : forest->trees)
      bytes += tree.nodes.size() * sizeof(SplitNode) + tree.modes.size() * sizeof(LeafMode) +
               tree.descriptors.size() * sizeof(Descriptor);
  return bytes;
}

}  // namespace relocalizer
