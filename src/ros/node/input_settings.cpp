#include "input_settings.h"

#include <string>

namespace relocalizer_ros {

namespace {

// Colour, depth and camera_info stamped more than 10 s apart are not one frame
// (0 already means no limit).
constexpr double kMaxSyncInterval = 10.0;
// Fewer than one relocalization in 1000 s is on_demand mode's job; one a
// millisecond is far beyond a relocalization's ~20 ms, so more is "0: no limit".
constexpr double kMinMaxRate = 0.001, kMaxMaxRate = 1000.0;
// The watchdog reports a silence; after an hour the report helps nobody (0: off).
constexpr double kMaxInputTimeout = 3600.0;

}  // namespace

const char* modeName(Mode mode) { return mode == Mode::OnDemand ? "on_demand" : "continuous"; }

void readInputSettings(ParamReader& reader, InputSettings& inputs) {
  std::string mode = modeName(inputs.mode);
  reader.read("mode", mode);
  reader.read("approx_sync", inputs.approx_sync);
  reader.readInt("sync_queue_size", inputs.sync_queue_size, 1);
  reader.read("max_interval", inputs.max_interval);
  reader.read("max_rate", inputs.max_rate);
  reader.read("process_all", inputs.process_all);
  reader.read("service_timeout", inputs.service_timeout);
  reader.read("input_timeout", inputs.input_timeout);
  if (!reader.ok()) return;
  if (mode == "on_demand")
    inputs.mode = Mode::OnDemand;
  else if (mode == "continuous")
    inputs.mode = Mode::Continuous;
  else
    return reader.fail(reader.quoted("mode") + " is '" + mode +
                       "'; expected on_demand or continuous");
  reader.bound("max_interval", inputs.max_interval, 0.0, kMaxSyncInterval, "s");
  reader.bound("max_rate", inputs.max_rate, kMinMaxRate, kMaxMaxRate, "Hz", "no limit");
  reader.bound("service_timeout", inputs.service_timeout, 0.0, kMaxServiceWaitSeconds, "s");
  reader.bound("input_timeout", inputs.input_timeout, 0.0, kMaxInputTimeout, "s");
}

}  // namespace relocalizer_ros
