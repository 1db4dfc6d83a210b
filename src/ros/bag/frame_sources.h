#pragma once
// The one place a tool's --dataset or --bag becomes a FrameSource
// (relocalizer/data/frame_source.h): a folder through the dataset readers, a
// rosbag through BagDataset. It lives in the ROS layer because a bag needs
// rosbag; a tool that links no ROS opens folders with openDatasetSource.

#include <memory>
#include <string>

#include "bag_dataset.h"
#include "relocalizer/data/frame_source.h"

namespace relocalizer_ros {

// A rosbag (bag_dataset.h) as a FrameSource.
class BagFrameSource : public relocalizer::ReaderFrameSource<BagDataset> {
 public:
  using ReaderFrameSource::ReaderFrameSource;
  std::string formatDescription() const override;
  bool integerStamps() const override;
};

// What the command line asked for: exactly one of `dataset` and `bag`.
struct FrameSourceRequest {
  std::string dataset;
  relocalizer::DatasetOptions dataset_options;
  std::string bag;
  BagOptions bag_options;
  // Key frames among a bag's frames, "METRES,DEGREES" (core/key_frame_rule.h); "" keeps every
  // frame.
  std::string min_motion;
};

// The opened source, or a one-line reason.
Expected<std::unique_ptr<relocalizer::FrameSource>> openFrameSource(
    const FrameSourceRequest& request);

}  // namespace relocalizer_ros
