#pragma once
// Which frames the node takes in and which it relocalizes: the mode (on a
// ~relocalize call, or continuously up to max_rate), how colour, depth and
// camera_info are synchronised (node_inputs.h), how long a call waits for a
// frame (relocalize_service.h) and the inputs' watchdog.

#include "param_reading.h"

namespace relocalizer_ros {

// The longest a ~relocalize call may wait for a frame (longer asks wait this
// long), and so the bound of service_timeout: a waiting call holds a thread,
// and a caller that waits longer has long given up.
constexpr double kMaxServiceWaitSeconds = 60.0;

enum class Mode {
  OnDemand,   // keep the latest synchronised frame; relocalize on a service call
  Continuous  // relocalize incoming frames in a worker thread, up to max_rate
};

const char* modeName(Mode mode);

struct InputSettings {
  Mode mode = Mode::OnDemand;
  bool approx_sync = true;
  int sync_queue_size = 5;
  double max_interval = 0.05;    // seconds between colour, depth and info stamps (0: no limit)
  double max_rate = 2.0;         // Hz, continuous mode (0: as fast as frames come)
  bool process_all = false;      // continuous mode: queue every frame instead of dropping
  double service_timeout = 2.0;  // seconds a call waits for a frame when it asks for <= 0
  double input_timeout =
      3.0;  // seconds of images without a synchronised frame before it is reported
};

// mode, approx_sync, sync_queue_size, max_interval, max_rate, process_all,
// service_timeout, input_timeout.
void readInputSettings(ParamReader& reader, InputSettings& inputs);

}  // namespace relocalizer_ros
