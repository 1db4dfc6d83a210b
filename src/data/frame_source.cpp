#include "relocalizer/data/frame_source.h"

#include <vector>

#include "relocalizer/core/id_ranges.h"

namespace relocalizer {

std::string FrameSource::usedIds() const {
  std::vector<int> ids;
  for (size_t i = 0; i < size(); ++i) ids.push_back(id(i));
  return formatIdRanges(ids);
}

std::string DatasetFrameSource::formatDescription() const { return formatName(reader().format()); }
bool DatasetFrameSource::integerStamps() const {
  return reader().format() == DatasetFormat::SevenScenesFolder ||
         reader().format() == DatasetFormat::SevenScenesScene ||
         reader().format() == DatasetFormat::TwelveScenes;
}

Expected<std::unique_ptr<FrameSource>> openDatasetSource(const std::string& path,
                                                         const DatasetOptions& options) {
  auto opened = openDataset(path, options);
  if (!opened) return makeError(opened.error());
  return std::unique_ptr<FrameSource>(new DatasetFrameSource(std::move(*opened), path));
}

}  // namespace relocalizer
