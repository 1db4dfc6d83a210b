#pragma once
// The facade: a trained model and one RGB-D frame in, a camera pose (or an
// explicit "no pose" with its reason) out. The node and every tool go through
// this class; nothing outside the core reaches into forests or RANSAC.

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/pose/pose_solver.h"
#include "relocalizer/relocalize/frame_samples.h"
#include "relocalizer/surface/surface_fit.h"

namespace relocalizer {

struct RelocalizerParams {
  int point_samples =
      500;  // random pixels with depth per frame (speed-accuracy sweep, docs/benchmarks.md)
  int line_samples = 250;  // line samples per frame (at most)
  int max_leaves =
      4;  // backtracking leaves per tree (8 until 0.2: twice the forest time, no better)
  bool use_points = true;      // use the point forest
  bool use_lines = true;       // use the line forest
  int min_valid_depth = 1000;  // frames with fewer valid depth pixels are refused
  uint32_t seed = 1;           // each call restarts from it: same frame, same answer
  PoseSolverParams solver;
  SurfaceFitParams surface;  // depth ICP and the surface check after the solver
  // A frame without a pose whose light is at least this far from the
  // training light (light_retry.h: the largest |ln| gain of a channel that
  // takes the frame into it, level and colour) is asked once more rebalanced
  // into that light (0 = never; 0.25 is a third of a stop, or between a 4500
  // and a 3500 K lamp for a camera balanced for 5500 K).
  float light_retry_min_cast = 0.25f;
  // An answer whose inlier share is below this is given only when a second
  // draw of the frame (other pixels, another RANSAC stream) answers within
  // core/pose.h's kAnswersAgree of it (second_draw.h; 0 = never asked).
  float confirm_below = 0.25f;
};

// With two or more threads the line branch (LSD, line samples, line forest)
// runs beside the point forest, so the stages can add up to more than `total`;
// `sampling_and_forests` is their wall time.
struct StageTimings {                 // seconds
  double sampling = 0.0;              // sampling_points + sampling_lines
  double sampling_points = 0.0;       // random pixels
  double sampling_lines = 0.0;        // LSD, segment sampling, 3D line fits
  double forest = 0.0;                // forest_points + forest_lines
  double forest_points = 0.0;         // descriptors and point-forest prediction
  double forest_lines = 0.0;          // descriptors and line-forest prediction
  double sampling_and_forests = 0.0;  // wall time of the sampling and forest stages
  double ransac = 0.0;                // hypotheses and preemptive scoring
  double refinement = 0.0;            // Ceres LM, inside the loop and final
  double surface = 0.0;               // depth ICP against the scene surface and the agreement
  double screening = 0.0;             // ranking the places (place_set.h), before the full solve
  double total = 0.0;                 // the whole call
};
// One stage of StageTimings, as a pointer to its member. Spelt with decltype:
// clang-format 11-14 and 19 space the `T::*` declarator differently.
using StageTimingsField = decltype(&StageTimings::total);

struct Relocalization {
  bool success = false;
  std::string message;                         // the reason, when !success
  Pose pose = Pose::Identity();                // camera-to-world (valid when success)
  Matrix6d covariance = Matrix6d::Identity();  // x y z rx ry rz, world frame
  int point_inliers = 0;
  int line_inliers = 0;
  int point_samples = 0;
  int line_samples = 0;
  // Where the inlier samples lie in the world at `pose` (their camera points
  // moved by it), point_inliers and line_inliers of them; set on success only,
  // for those who draw the answer (RViz).
  std::vector<Eigen::Vector3f> point_inlier_world;
  std::vector<Eigen::Vector3f> line_inlier_world;
  float score = 0.0f;  // inlier share of the samples
  // Share of the frame's depth points that are not occluders (in front of the
  // scene surface) which lie on it at the answered pose (SurfaceView::agreement
  // in surface_fit.h); negative when not measured (no surface in the model, the
  // check off, or no solver pose to check).
  float surface_agreement = -1.0f;
  bool surface_refined = false;  // depth ICP moved the solver's pose
  // > 0: the frame was asked again with a change of light of this size taken out
  // (light_retry.h; RelocalizerParams::light_retry_min_cast), and the answer
  // (pose or reason) is the second asking's.
  float light_cast = 0.0f;
  // The evidence was weak (second_draw.h), so the frame was drawn again to
  // confirm it: with success, the second draw agreed.
  bool second_draw = false;
  StageTimings timings;
};

// How good the forests' world-coordinate predictions are on a frame with
// ground truth: the measure of forest quality independent of the pose solver.
// The cheap pass that ranks places (place_set.h): a few of the frame's point
// samples through the point forest and a short Kabsch-only RANSAC.
struct ScreenParams {
  int samples = 200;  // point samples
  // RANSAC hypotheses, and minimal sets tried per hypothesis before the draw
  // gives up. A frame whose one-leaf predictions are mostly wrong has few
  // rigid minimal sets: with 32 and 20 (the full solve's budget) the right
  // learned submap screened 0-2 inliers on 8 of the 6-room walk's 300 test
  // frames (on 5 it drew no hypothesis at all), was never solved and the
  // frame got no pose; with 64 and 80 all 8 are answered. The draw stops at
  // `hypotheses`, so the attempts cost where rigid sets are rare: on the right
  // place in such frames, and on every place the frame is not in (measured on
  // 21 submaps: screen median 3.0 -> 5.4 ms, whole call 11.5 -> 13.8 ms;
  // 32 x 320 and 16 x 320 answer the same frames at more cost, 32 x 80 misses
  // one; docs/online_learning.md, Submaps).
  int hypotheses = 64;
  int sampling_attempts = 80;
  int max_leaves = 1;  // backtracking leaves per tree
};

struct PredictionQuality {
  int samples = 0;
  int chosen_within = 0;             // nearest-descriptor candidate within the radius of the truth
  int any_within = 0;                // some candidate within the radius
  std::vector<float> chosen_errors;  // metres, per sample
};

class Relocalizer {
 public:
  Relocalizer(Model model, RelocalizerParams params = {});
  static Expected<std::unique_ptr<Relocalizer>> fromFile(const std::string& model_path,
                                                         const RelocalizerParams& params = {});

  // Thread-safe; concurrent calls do not share scratch memory. A `hint`
  // (pose_hint.h; its frame is not checked here) favours hypotheses near it;
  // an unusable one is the answer's reason for no pose.
  Relocalization relocalize(const RgbdFrame& frame, const PoseHint* hint = nullptr) const;

  // The same answer in two halves, so that many places can share the first.
  // sample(): the frame's samples and descriptors (an error: why the frame is
  // refused). relocalize(frame, samples): forests, pose and surface check on
  // them; the answer equals relocalize(frame) when the samples' recipe is this
  // relocalizer's, and otherwise it samples the frame itself.
  Expected<FrameSamples> sample(const RgbdFrame& frame) const;
  // The same, calling `points_ready` as soon as the point samples and their
  // descriptors are drawn, while the line half (LSD) is still being drawn
  // beside it: work that needs the points only (the place screens) overlaps
  // LSD instead of waiting for it. `points_ready` may read the samples'
  // points, point descriptors, image and recipe, nothing else; it is not
  // called for a refused frame.
  Expected<FrameSamples> sample(const RgbdFrame& frame,
                                const std::function<void(const FrameSamples&)>& points_ready) const;
  Relocalization relocalize(const RgbdFrame& frame, const FrameSamples& samples,
                            const PoseHint* hint = nullptr) const;
  SamplingRecipe samplingRecipe() const;
  // How well the frame fits this place, cheaply: the inliers of a short
  // RANSAC on a few of the samples and its winner's pose in the model's world
  // (0 inliers when the model has no point forest).
  // `predictions` (optional) holds the one-leaf predictions of the first
  // samples made by an earlier screen of this place on the same samples with
  // the same max_leaves: only the samples it lacks are predicted, and added to
  // it, so a first look on a few samples and a fuller screen after it predict
  // each sample once and answer as a screen without it would.
  ScreenResult screen(const FrameSamples& samples, const ScreenParams& params,
                      std::vector<Prediction>* predictions = nullptr) const;

  // Samples the frame as relocalize() does and compares each sample's
  // predictions with its true world coordinate. Needs frame.ground_truth.
  Expected<PredictionQuality> measurePredictions(const RgbdFrame& frame, bool line_forest,
                                                 float radius = 0.1f) const;

  const Model& model() const { return model_; }
  const RelocalizerParams& params() const { return params_; }
  // Empty if the parameters can be used with this model, else why not.
  std::string validationError() const;
  // Empty, or what this model cannot do with these parameters that a current
  // one could (a version-1 model has no scene surface to check poses against),
  // for the node and the tools to warn about at start.
  std::string limitations() const;

 private:
  // Empty when the frame can be relocalized, else why not.
  std::string frameRefusal(const RgbdFrame& frame) const;
  // relocalize() in the frame's own colour, a weak answer confirmed
  // (second_draw.h); the same frame is asked again in the training light
  // when that failed (light_retry.h).
  Relocalization relocalizeAsSeen(const RgbdFrame& frame, const PoseHint* hint) const;
  // Samples the frame with `drawing`'s seed and solves it (no confirmation).
  Relocalization drawAndSolve(const RgbdFrame& frame, const PoseHint* hint,
                              const RelocalizerParams& drawing) const;
  // The rules of light_retry.h and second_draw.h, asked of this place.
  Relocalization askedInTrainingLight(const RgbdFrame& frame, Relocalization first,
                                      const PoseHint* hint) const;
  Relocalization confirmedByASecondDraw(const RgbdFrame& frame, Relocalization first,
                                        const PoseHint* hint) const;
  Relocalization solve(const RgbdFrame& frame, const FrameSamples& samples,
                       const std::vector<Prediction>& point_predictions,
                       const std::vector<Prediction>& line_predictions, Relocalization result,
                       std::chrono::steady_clock::time_point start, const PoseHint* hint) const;
  static Relocalization failed(Relocalization result, std::string message,
                               std::chrono::steady_clock::time_point start);

  Model model_;
  RelocalizerParams params_;
};

// RelocalizerParams <-> JSON, for config files (the `relocalizer:` section of
// config/default.yaml) and result summaries.
std::string relocalizerParamsToJson(const RelocalizerParams& params);
Expected<RelocalizerParams> relocalizerParamsFromJson(const std::string& json_text);
// Reads the `relocalizer:` section of a YAML file (absent keys keep `defaults`).
Expected<RelocalizerParams> loadRelocalizerParams(const std::string& path,
                                                  const RelocalizerParams& defaults = {});

}  // namespace relocalizer
