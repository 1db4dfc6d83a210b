#pragma once
// A recording's frames seen under other light (core/photometric_change.h):
// the colour images changed, depth, poses and everything else as recorded, so
// a benchmark asks how the relocalizer copes with a world that changed after
// training without recording it again.

#include <memory>

#include "relocalizer/core/photometric_change.h"
#include "relocalizer/data/frame_source.h"

namespace relocalizer {

class ChangedFrameSource : public FrameSource {
 public:
  // `change` must be valid (PhotometricChange::validationError empty).
  ChangedFrameSource(std::unique_ptr<FrameSource> recording, const PhotometricChange& change);

  size_t size() const override { return recording_->size(); }
  int id(size_t i) const override { return recording_->id(i); }
  double stamp(size_t i) const override { return recording_->stamp(i); }
  const std::optional<Pose>& groundTruth(size_t i) const override {
    return recording_->groundTruth(i);
  }
  Expected<RgbdFrame> load(size_t i) const override;
  const CameraIntrinsics& camera() const override { return recording_->camera(); }
  // The recording's, and the change.
  std::string summary() const override;
  const std::string& path() const override { return recording_->path(); }
  std::string formatDescription() const override { return recording_->formatDescription(); }
  bool integerStamps() const override { return recording_->integerStamps(); }

 private:
  std::unique_ptr<FrameSource> recording_;
  PhotometricChange change_;
};

}  // namespace relocalizer
