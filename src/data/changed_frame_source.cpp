#include "relocalizer/data/changed_frame_source.h"

#include <stdexcept>

namespace relocalizer {

ChangedFrameSource::ChangedFrameSource(std::unique_ptr<FrameSource> recording,
                                       const PhotometricChange& change)
    : recording_(std::move(recording)), change_(change) {
  const std::string invalid = change.validationError();
  if (!invalid.empty()) throw std::invalid_argument("ChangedFrameSource: " + invalid);
}

Expected<RgbdFrame> ChangedFrameSource::load(size_t i) const {
  Expected<RgbdFrame> frame = recording_->load(i);
  if (frame) frame->colour = applyPhotometricChange(frame->colour, change_);
  return frame;
}

std::string ChangedFrameSource::summary() const {
  return recording_->summary() + "changed:      " + change_.describe() +
         " (colour only; depth and poses as recorded)\n";
}

}  // namespace relocalizer
