#pragma once
// /diagnostics through diagnostic_updater: one status for the node
// ("NODE: relocalization") and, while it holds several places, one per place
// ("NODE: place NAME"), hardware_id "relocalizer: NODE". The level and message
// follow the rules of node_health.h; the figures come from the answers as
// users see them (NodeOutput's listener), the inputs' activity, the places
// and the node's counters as ~result carries them.
//
// Threads: the listener runs on the publishing threads (worker, service
// calls); the statuses are made on a wall timer of the node's queue.

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "diagnostic_settings.h"
#include "input_settings.h"
#include "node_health.h"
#include "node_inputs.h"
#include "node_output.h"
#include "node_places.h"

namespace relocalizer_ros {

class NodeDiagnostics {
 public:
  struct Sources {
    NodePlaces* places = nullptr;
    std::function<std::string()> no_place;  // why nothing is usable (learn: no model yet)
    std::function<void(NodeOutput::ResultMsg&)> counters;  // as ~result carries them
    std::function<NodeInputs::Activity()> inputs;
  };

  // Listens to `output` at once (before any frame can arrive); makes no status
  // before start(). `inputs`: the mode it reports and input_timeout, after
  // which the inputs count as stopped.
  NodeDiagnostics(ros::NodeHandle nh, ros::NodeHandle private_nh, const InputSettings& inputs,
                  const DiagnosticSettings& settings, Sources sources, NodeOutput& output);
  ~NodeDiagnostics() { stop(); }
  NodeDiagnostics(const NodeDiagnostics&) = delete;
  NodeDiagnostics& operator=(const NodeDiagnostics&) = delete;

  // Publishes a first status now and then every diagnostic_period; call once
  // every source can answer.
  void start();
  // No status is made after this returns (roscpp waits for one in progress).
  void stop() { timer_.stop(); }

 private:
  // One place's answers since it was loaded.
  struct PlaceTally {
    uint64_t screened = 0;  // frames it was compared with
    uint64_t solved = 0;    // of those, fully relocalized against it
    uint64_t answers = 0;   // poses it gave
    int64_t last_answer_ns = 0;
  };

  void onPublished(const NodeOutput::Published& published);
  void update();
  // One task per place while there are several, none with one.
  void followPlaces();
  void nodeStatus(diagnostic_updater::DiagnosticStatusWrapper& status);
  void addInputs(diagnostic_updater::DiagnosticStatusWrapper& status,
                 const NodeInputs::Activity& inputs, int64_t now_ns);
  void placeStatus(const std::string& name, diagnostic_updater::DiagnosticStatusWrapper& status);

  const DiagnosticSettings& settings_;
  const Mode mode_;
  const Sources sources_;
  const HealthLimits limits_;
  ros::NodeHandle nh_;
  std::unique_ptr<diagnostic_updater::Updater> updater_;
  ros::WallTimer timer_;

  // The answers as published; guarded by mutex_.
  std::mutex mutex_;
  int failures_in_a_row_ = 0;
  std::string last_failure_;
  int64_t last_failure_ns_ = 0;
  int64_t last_pose_ns_ = 0;
  std::string last_place_;
  std::map<std::string, PlaceTally> tallies_;

  // The timer's own: the places at this update, the tasks made for them, and
  // the message counts of the last few seconds, which the input rates span.
  struct CountSample {
    int64_t ns = 0;
    std::array<uint64_t, 3> messages{};
  };
  std::vector<relocalizer::PlaceFigures> places_;
  std::vector<std::string> place_tasks_;
  std::deque<CountSample> rate_samples_;
};

}  // namespace relocalizer_ros
