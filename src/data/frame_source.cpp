#include "relocalizer/data/frame_source.h"

#include <vector>

#include "relocalizer/core/id_ranges.h"

namespace relocalizer {

std::string FrameSource::usedIds() const {
  std::vector<int> ids;
  for (size_t i = 0; i < size(); ++i) ids.push_back(id(i));
  return formatIdRanges(ids);
}

DatasetFrameSource::DatasetFrameSource(std::unique_ptr<Dataset> data, std::string path)
    : data_(std::move(data)), path_(std::move(path)) {}
size_t DatasetFrameSource::size() const { return data_->size(); }
int DatasetFrameSource::id(size_t i) const { return data_->id(i); }
double DatasetFrameSource::stamp(size_t i) const { return data_->stamp(i); }
const std::optional<Pose>& DatasetFrameSource::groundTruth(size_t i) const {
  return data_->groundTruth(i);
}
Expected<RgbdFrame> DatasetFrameSource::load(size_t i) const { return data_->load(i); }
const CameraIntrinsics& DatasetFrameSource::camera() const { return data_->camera(); }
std::string DatasetFrameSource::summary() const { return data_->summary(); }
const std::string& DatasetFrameSource::path() const { return path_; }
std::string DatasetFrameSource::formatDescription() const { return formatName(data_->format()); }
bool DatasetFrameSource::integerStamps() const {
  return data_->format() == DatasetFormat::SevenScenesFolder ||
         data_->format() == DatasetFormat::SevenScenesScene ||
         data_->format() == DatasetFormat::TwelveScenes;
}

Expected<std::unique_ptr<FrameSource>> openDatasetSource(const std::string& path,
                                                         const DatasetOptions& options) {
  auto opened = openDataset(path, options);
  if (!opened) return makeError(opened.error());
  return std::unique_ptr<FrameSource>(new DatasetFrameSource(std::move(*opened), path));
}

}  // namespace relocalizer
