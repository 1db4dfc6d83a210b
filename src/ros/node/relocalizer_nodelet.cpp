// The node as a nodelet, for zero-copy images from a camera driver nodelet in
// the same manager: relocalizer/RelocalizerNodelet.

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "relocalizer_node.h"

namespace relocalizer_ros {

class RelocalizerNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    auto node = RelocalizerNode::create(getNodeHandle(), getPrivateNodeHandle());
    if (!node) {
      // A nodelet cannot end its manager's process; it stays inert and says why.
      NODELET_FATAL("relocalizer: %s", node.error().c_str());
      return;
    }
    node_ = std::move(*node);
  }

  std::unique_ptr<RelocalizerNode> node_;
};

}  // namespace relocalizer_ros

PLUGINLIB_EXPORT_CLASS(relocalizer_ros::RelocalizerNodelet, nodelet::Nodelet)
