#include "relocalizer/forest/model_io.h"

#include "relocalizer/core/byte_io.h"
#include "relocalizer/core/file_io.h"
#include "relocalizer/core/json_fields.h"
#include "relocalizer/core/version.h"
#include "training_params_json.h"
#include "tree_streams.h"

#include <zlib.h>

#include <tbb/parallel_for.h>
#include <algorithm>
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
                      [&](size_t t) { packed[t] = detail::packTree(forest->trees[t]); });
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
  if (!detail::readTrees(b, model.points, version, why) ||
      !detail::readTrees(b, model.lines, version, why))
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
      bytes += tree.nodes.size() * sizeof(SplitNode) + tree.modes.size() * sizeof(PackedMode) +
               tree.descriptors.size() * sizeof(Descriptor);
  return bytes;
}

}  // namespace relocalizer
