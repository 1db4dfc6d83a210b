#pragma once
// Where the tools get posed frames: one interface for a dataset folder (here)
// and a rosbag (src/ros/bag/frame_sources.h), so evaluation, benchmarks and
// training treat every recording alike and never name its format.

#include <cstddef>
#include <memory>
#include <optional>
#include <string>

#include "relocalizer/core/camera.h"
#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/data/dataset.h"

namespace relocalizer {

// The selected frames of one recording, in increasing id. Indices, ids,
// stamps and ground truth as Dataset documents them.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual size_t size() const = 0;
  virtual int id(size_t i) const = 0;
  virtual double stamp(size_t i) const = 0;
  virtual const std::optional<Pose>& groundTruth(size_t i) const = 0;
  // Thread-safe.
  virtual Expected<RgbdFrame> load(size_t i) const = 0;
  // Intrinsics of the frames load() returns (a bag: of its first kept frame).
  virtual const CameraIntrinsics& camera() const = 0;
  // Several lines: what was found and selected.
  virtual std::string summary() const = 0;
  // The folder or bag path as given.
  virtual const std::string& path() const = 0;
  // For the model header and summary.json: "7-Scenes folder", "rosbag (TF map -> camera)".
  virtual std::string formatDescription() const = 0;
  // 7-Scenes and 12-Scenes stamps are frame numbers, written as integers.
  virtual bool integerStamps() const = 0;
  // The frames actually used, as a selection expression ("0-3,7,12-20").
  std::string usedIds() const;
};

// A FrameSource over a reader with Dataset's methods (size, id, stamp,
// groundTruth, load, camera, summary): a folder here, a bag in the ROS layer.
template <class Reader>
class ReaderFrameSource : public FrameSource {
 public:
  ReaderFrameSource(std::unique_ptr<Reader> reader, std::string path)
      : reader_(std::move(reader)), path_(std::move(path)) {}
  size_t size() const override { return reader_->size(); }
  int id(size_t i) const override { return reader_->id(i); }
  double stamp(size_t i) const override { return reader_->stamp(i); }
  const std::optional<Pose>& groundTruth(size_t i) const override {
    return reader_->groundTruth(i);
  }
  Expected<RgbdFrame> load(size_t i) const override { return reader_->load(i); }
  const CameraIntrinsics& camera() const override { return reader_->camera(); }
  std::string summary() const override { return reader_->summary(); }
  const std::string& path() const override { return path_; }

 protected:
  const Reader& reader() const { return *reader_; }

 private:
  std::unique_ptr<Reader> reader_;
  std::string path_;
};

// A dataset folder (dataset.h) as a FrameSource.
class DatasetFrameSource : public ReaderFrameSource<Dataset> {
 public:
  using ReaderFrameSource::ReaderFrameSource;
  std::string formatDescription() const override;
  bool integerStamps() const override;
};

// The folder at `path` as a FrameSource; fails as openDataset does.
Expected<std::unique_ptr<FrameSource>> openDatasetSource(const std::string& path,
                                                         const DatasetOptions& options);

}  // namespace relocalizer
