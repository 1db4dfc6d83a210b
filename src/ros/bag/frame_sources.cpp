#include "frame_sources.h"

#include "relocalizer/core/key_frame_rule.h"

namespace relocalizer_ros {

using relocalizer::makeError;

std::string BagFrameSource::formatDescription() const {
  return "rosbag (" + reader().poseSource() + ")";
}
bool BagFrameSource::integerStamps() const { return false; }

Expected<std::unique_ptr<relocalizer::FrameSource>> openFrameSource(
    const FrameSourceRequest& request) {
  if (request.dataset.empty() == request.bag.empty())
    return makeError(request.dataset.empty() ? "one of --dataset or --bag is required"
                                             : "--dataset and --bag exclude each other");
  if (!request.bag.empty()) {
    BagOptions options = request.bag_options;
    if (!request.min_motion.empty()) {
      auto motion = relocalizer::parseMinMotion(request.min_motion);
      if (!motion) return makeError(motion.error());
      options.min_translation = motion->metres;
      options.min_rotation_degrees = motion->degrees;
    }
    auto opened = BagDataset::open(request.bag, options);
    if (!opened) return makeError(opened.error());
    return std::unique_ptr<relocalizer::FrameSource>(
        new BagFrameSource(std::move(*opened), request.bag));
  }
  return relocalizer::openDatasetSource(request.dataset, request.dataset_options);
}

}  // namespace relocalizer_ros
