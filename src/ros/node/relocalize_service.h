#pragma once
// ~relocalize: a call waits (at most kMaxServiceWaitSeconds, counted from its
// arrival) for the latest or the next synchronised frame and relocalizes it.
// Calls that pick the same frame share one relocalization (the core is
// deterministic per frame), so concurrent calls get the same, well-defined
// answer cheaply. A failure is an answer (success false), never a service error.

#include <relocalizer/Relocalize.h>
#include <ros/ros.h>

#include <functional>
#include <future>
#include <map>
#include <mutex>

#include "frame_buffer.h"
#include "frame_input.h"
#include "input_settings.h"
#include "node_output.h"
#include "relocalizer/pose/pose_hint.h"
#include "service_call_queue.h"
#include "throttled_log.h"

namespace relocalizer_ros {

class RelocalizeService {
 public:
  using ResultMsg = NodeOutput::ResultMsg;
  struct Sources {
    FrameBuffer<FrameInputPtr>* frames;  // what calls wait on
    // Relocalize and publish one frame, with a call's own hint (or null).
    std::function<ResultMsg(const FrameInput&, const relocalizer::PoseHint*)> process;
    // A call's hint in a place's map frame, or why not (node_hints.h).
    std::function<relocalizer::Expected<relocalizer::PoseHint>(
        const geometry_msgs::PoseWithCovarianceStamped&)>
        read_hint;
    std::function<std::string()> input_status;  // why no frame came
    NodeOutput* output;                         // reports of calls without a frame
  };

  RelocalizeService(ros::NodeHandle private_nh, const InputSettings& params, Sources sources,
                    ServiceCallQueue& calls);
  std::string name() const { return server_.getService(); }
  void shutdown() { server_.shutdown(); }

 private:
  bool onRelocalize(relocalizer::Relocalize::Request& request,
                    relocalizer::Relocalize::Response& response);
  // Whether the request can wait at all: NaN and infinity are refused at once.
  ResultMsg call(const relocalizer::Relocalize::Request& request);
  // Buffer entry `seq`'s relocalization, shared with any concurrent call that picked it.
  ResultMsg processShared(uint64_t seq, const FrameInputPtr& input);
  // A call with its own hint relocalizes on its own; a hint that cannot be
  // read is the call's failure.
  ResultMsg processHinted(const relocalizer::Relocalize::Request& request,
                          const FrameInputPtr& input);

  const InputSettings& params_;
  const Sources sources_;
  ThrottledLog log_;
  std::mutex shared_mutex_;
  std::map<uint64_t, std::shared_future<ResultMsg>> in_flight_;
  ros::ServiceServer server_;
};

}  // namespace relocalizer_ros
