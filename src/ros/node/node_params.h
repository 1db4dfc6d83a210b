#pragma once
// The node's parameters: each part's settings (*_settings.h), read by that
// part's own reader, and what only the node itself takes (the core's
// parameters, its threads). The defaults are the ones in
// config/default.yaml; a rostest checks that the two agree, so a rosrun
// without the launch file behaves like the documented configuration.

#include <ros/node_handle.h>

#include <string>
#include <vector>

#include "diagnostic_settings.h"
#include "handoff_settings.h"
#include "hint_settings.h"
#include "input_settings.h"
#include "learn_settings.h"
#include "place_settings.h"
#include "relocalizer/core/expected.h"
#include "relocalizer/relocalize/relocalizer.h"
#include "tf_settings.h"

namespace relocalizer_ros {

// Every part's settings under their parameters' names (params.map_frame), so
// a part takes its own struct and the node hands each the whole.
struct NodeParams : PlaceSettings,
                    InputSettings,
                    TfSettings,
                    HintSettings,
                    HandoffSettings,
                    LearnSettings,
                    DiagnosticSettings {
  int threads = 0;  // TBB threads inside a relocalization (0: every core)
  relocalizer::RelocalizerParams relocalizer;
};

// Reads every parameter from the private node handle. A parameter of the wrong
// type, an unknown `relocalizer/` key or a value out of range is an error that
// names it, its value and the allowed range (param_reading.h).
relocalizer::Expected<NodeParams> loadNodeParams(const ros::NodeHandle& private_nh);

// The parameters as JSON, keyed as in config/default.yaml, for the start-up
// log and for the test that compares the compiled defaults with that file.
std::string nodeParamsToJson(const NodeParams& params);

}  // namespace relocalizer_ros
