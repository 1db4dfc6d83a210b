#pragma once
// How the "no pose" gates (solver.min_inliers, solver.min_inlier_ratio,
// surface.min_agreement) trade correct answers for false relocalizations:
// frames of the model's scene and of other scenes are relocalized with every
// gate open, then each gate's threshold is swept over the answers (the
// `threshold_curves` tool's figures).

#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/data/frame_source.h"
#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer {

// What the solver answered with the gates open.
struct GateAnswer {
  bool in_scene = false;
  bool has_pose = false;  // the solver produced a pose at all
  bool correct = false;   // within kCorrectPose (metrics.h; in-scene only)
  int inliers = 0;
  float score = 0.0f;
  float agreement = -1.0f;  // share of the depth on the scene surface; < 0: not checked
};

// The gates as configured, which each sweep keeps for the others.
struct GateSettings {
  int min_inliers = 0;
  float min_inlier_ratio = 0.0f;
  float min_agreement = 0.0f;
};
GateSettings gateSettings(const RelocalizerParams& params);
// `params` with every gate open, so every pose the solver finds is kept.
RelocalizerParams withGatesOpen(RelocalizerParams params);

// Relocalizes every frame of `source` with `relocalizer` (gates open).
Expected<std::vector<GateAnswer>> answerFrames(const Relocalizer& relocalizer,
                                               const FrameSource& source, bool in_scene);

// Writes curves.csv/png (min_inlier_ratio), agreement_curves.csv/png
// (min_agreement, when the answers checked a surface) and curves.json, with
// `extra_json` (an object) merged in, into `folder`. Returns the printed report.
Expected<std::string> writeThresholdCurves(const std::vector<GateAnswer>& answers,
                                           const GateSettings& configured,
                                           const std::string& folder,
                                           const std::string& extra_json);

}  // namespace relocalizer
