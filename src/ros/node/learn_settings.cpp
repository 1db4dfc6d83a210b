#include "learn_settings.h"

namespace relocalizer_ros {

namespace {

// `learning` and `submaps` from the learn_* texts and numbers; each error
// names the node's parameter, not the learner's field.
void checkLearning(ParamReader& reader, LearnSettings& p) {
  relocalizer::LearningParams learning;
  learning.max_keyframes = p.learn_max_keyframes;
  learning.first_retrain = p.learn_first_retrain;
  learning.retrain_growth = p.learn_retrain_growth;
  learning.surface_gate = p.learn_surface_gate;
  const relocalizer::SettingName name = [&reader](const std::string& field) {
    if (field == "config") return reader.quoted("learn_config");
    if (field == "area_radius") return reader.quoted("learn_submap_radius");
    if (field == "overlap") return reader.quoted("learn_submap_overlap");
    return reader.quoted("learn_" + field);
  };
  learning.slam_check.enabled = p.learn_slam_check;
  if (relocalizer::Status bounds = relocalizer::readSlamCheckBounds(
          p.learn_max_slam_speed, p.learn_slam_disagreement, learning.slam_check, name);
      !bounds)
    return reader.fail(bounds.error());
  auto checked =
      relocalizer::readLearningParams(learning, p.learn_min_motion, p.learn_config, name);
  if (!checked) return reader.fail(checked.error());
  p.learning = *checked;
  p.submaps.area_radius = p.learn_submap_radius;
  p.submaps.overlap = p.learn_submap_overlap;
  p.submaps.cover_steps = p.learn_cover_steps;
  p.submaps.relearn_agreement = p.learn_relearn_agreement;
  reader.fail(relocalizer::submapParamsError(p.submaps, p.learning.max_keyframes, name));
}

}  // namespace

void readLearnSettings(ParamReader& reader, LearnSettings& p) {
  reader.read("learn", p.learn);
  reader.read("save_on_exit", p.save_on_exit);
  reader.read("save_model_folder", p.save_model_folder);
  reader.read("learn_min_motion", p.learn_min_motion);
  reader.readInt("learn_max_keyframes", p.learn_max_keyframes, 2);
  reader.read("learn_submap_radius", p.learn_submap_radius);
  reader.readInt("learn_submap_overlap", p.learn_submap_overlap, 0);
  reader.read("learn_cover_steps", p.learn_cover_steps);
  reader.read("learn_relearn_agreement", p.learn_relearn_agreement);
  reader.readInt("learn_first_retrain", p.learn_first_retrain, 1);
  reader.read("learn_retrain_growth", p.learn_retrain_growth);
  reader.read("learn_surface_gate", p.learn_surface_gate);
  reader.read("learn_slam_check", p.learn_slam_check);
  reader.read("learn_max_slam_speed", p.learn_max_slam_speed);
  reader.read("learn_slam_disagreement", p.learn_slam_disagreement);
  reader.read("learn_config", p.learn_config);
  if (!reader.ok()) return;
  if (!p.learn && !p.save_on_exit.empty())
    return reader.fail(reader.quoted("save_on_exit") +
                       " is set but learn is false: only a learned model is saved");
  if (p.learn) checkLearning(reader, p);
}

}  // namespace relocalizer_ros
