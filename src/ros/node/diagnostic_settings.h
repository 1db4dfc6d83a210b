#pragma once
// How often /diagnostics reports and when failures in a row warn
// (node_diagnostics.h); inputs count as stopped after input_timeout
// (input_settings.h).

#include "param_reading.h"

namespace relocalizer_ros {

struct DiagnosticSettings {
  double diagnostic_period = 1.0;     // seconds between statuses (diagnostic_updater's name)
  int diagnostics_max_failures = 10;  // relocalized frames in a row without a pose: WARN (0: never)
};

// Faster than 10 Hz floods the aggregators for nothing; a status older than a
// minute says nothing about the node now.
constexpr double kMinDiagnosticPeriod = 0.1, kMaxDiagnosticPeriod = 60.0;

inline void readDiagnosticSettings(ParamReader& reader, DiagnosticSettings& diagnostics) {
  reader.read("diagnostic_period", diagnostics.diagnostic_period);
  reader.readInt("diagnostics_max_failures", diagnostics.diagnostics_max_failures, 0);
  if (reader.ok())
    reader.bound("diagnostic_period", diagnostics.diagnostic_period, kMinDiagnosticPeriod,
                 kMaxDiagnosticPeriod, "s");
}

}  // namespace relocalizer_ros
