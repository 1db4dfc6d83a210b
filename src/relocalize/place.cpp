#include "relocalizer/relocalize/place.h"

#include <cstdio>
#include <fstream>
#include <vector>

#include "relocalizer/forest/model_io.h"

namespace relocalizer {

std::string modelFileIdentity(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  const std::streamoff size = in.tellg();
  if (!in || size < 0) return {};
  std::vector<uint8_t> bytes(static_cast<size_t>(size));
  in.seekg(0);
  if (!in.read(reinterpret_cast<char*>(bytes.data()), size)) return {};
  return modelIdentity(crc32Of(bytes.data(), bytes.size()), bytes.size());
}

std::string modelIdentity(uint32_t crc32, uint64_t bytes) {
  char id[64];
  std::snprintf(id, sizeof id, "crc32 %08x, %llu bytes", crc32,
                static_cast<unsigned long long>(bytes));
  return id;
}

PlaceFigures placeFigures(const Place& place) {
  PlaceFigures figures;
  figures.name = place.name;
  figures.map_frame = place.map_frame;
  figures.source = place.source;
  figures.group = place.group;
  if (!place.relocalizer) return figures;
  const Model& model = place.relocalizer->model();
  figures.point_trees = static_cast<int>(model.points.trees.size());
  figures.line_trees = static_cast<int>(model.lines.trees.size());
  figures.modes = static_cast<long>(model.points.modeCount() + model.lines.modeCount());
  figures.surface_voxels = static_cast<long>(model.surface.elements().size());
  figures.training_frames = model.summary.images;
  figures.model_bytes = modelBytes(model);
  return figures;
}

}  // namespace relocalizer
