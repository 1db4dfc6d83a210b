// TEMPORARY (issue 25, node side): a minimal PlaceSet so that the node can be
// built and tested before the lead's implementation lands. It relocalizes with
// every place in turn and answers with the first success; no screening. The
// lead replaces this whole file when merging.

#include "relocalizer/relocalize/place_set.h"

#include <algorithm>
#include <chrono>

namespace relocalizer {

std::string PlaceSearchParams::validationError() const {
  if (screen_samples < 1) return "screen_samples must be at least 1";
  if (screen_hypotheses < 1) return "screen_hypotheses must be at least 1";
  if (screen_max_leaves < 1) return "screen_max_leaves must be at least 1";
  if (max_solved < 1) return "max_solved must be at least 1";
  return {};
}

PlaceSet::PlaceSet(PlaceSearchParams params) : params_(std::move(params)) {}

Expected<Place> PlaceSet::load(const std::string& name, const std::string& model_path,
                               const std::string& map_frame, const RelocalizerParams& params) {
  Expected<std::unique_ptr<Relocalizer>> loaded = makeError("not loaded");
  try {
    loaded = Relocalizer::fromFile(model_path, params);
  } catch (const std::exception& e) {
    return makeError("place '" + name + "': " + model_path + ": cannot be loaded: " + e.what());
  }
  if (!loaded) return makeError("place '" + name + "': " + loaded.error());
  if (std::string why = (*loaded)->validationError(); !why.empty())
    return makeError("place '" + name + "': " + model_path + ": " + why);
  Place place;
  place.name = name;
  place.map_frame = map_frame;
  place.source = model_path;
  place.relocalizer = std::move(*loaded);
  return place;
}

Status PlaceSet::put(Place place) {
  if (place.name.empty()) return makeError("a place needs a name");
  if (place.map_frame.empty()) return makeError("place '" + place.name + "' has no map frame");
  if (!place.relocalizer) return makeError("place '" + place.name + "' has no model");
  if (std::string why = place.relocalizer->validationError(); !why.empty())
    return makeError("place '" + place.name + "': " + why);
  auto shared = std::make_shared<const Place>(std::move(place));
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& existing : places_)
    if (existing->name == shared->name) {
      existing = shared;
      return okStatus();
    }
  places_.push_back(shared);
  return okStatus();
}

bool PlaceSet::remove(const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = std::find_if(places_.begin(), places_.end(),
                         [&](const auto& place) { return place->name == name; });
  if (it == places_.end()) return false;
  places_.erase(it);
  return true;
}

std::vector<PlaceFigures> PlaceSet::list() const {
  std::vector<PlaceFigures> figures;
  for (const auto& place : snapshot()) figures.push_back(placeFigures(*place));
  return figures;
}

std::vector<std::string> PlaceSet::names() const {
  std::vector<std::string> names;
  for (const auto& place : snapshot()) names.push_back(place->name);
  return names;
}

size_t PlaceSet::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return places_.size();
}

std::vector<std::shared_ptr<const Place>> PlaceSet::snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return places_;
}

PlaceAnswer PlaceSet::relocalize(const RgbdFrame& frame) const {
  PlaceAnswer answer;
  answer.relocalization.message = "no place loaded";
  std::string reasons;
  for (const auto& place : snapshot()) {
    PlaceAttempt attempt;
    attempt.place = place->name;
    attempt.solved = true;
    Relocalization solved = place->relocalizer->relocalize(frame);
    attempt.success = solved.success;
    attempt.message = solved.message;
    answer.attempts.push_back(attempt);
    if (solved.success && answer.place.empty()) {
      answer.place = place->name;
      answer.map_frame = place->map_frame;
      answer.relocalization = std::move(solved);
      break;
    }
    reasons += (reasons.empty() ? "" : "; ") + place->name + ": " + solved.message;
    answer.relocalization = std::move(solved);
    answer.relocalization.message = reasons;
  }
  return answer;
}

// TEMPORARY copy of online's modelBytes, which the lead moves to
// forest/model_io.h (relocalize may not link online: the shared libraries
// refuse the undefined symbol).
static size_t temporaryModelBytes(const Model& model) {
  size_t bytes = model.surface.elements().size() * sizeof(SurfaceElement);
  for (const Forest* forest : {&model.points, &model.lines})
    for (const Tree& tree : forest->trees)
      bytes += tree.nodes.size() * sizeof(SplitNode) + tree.modes.size() * sizeof(LeafMode) +
               tree.descriptors.size() * sizeof(Descriptor);
  return bytes;
}

PlaceFigures placeFigures(const Place& place) {
  PlaceFigures figures;
  figures.name = place.name;
  figures.map_frame = place.map_frame;
  figures.source = place.source;
  const Model& model = place.relocalizer->model();
  figures.point_trees = static_cast<int>(model.points.trees.size());
  figures.line_trees = static_cast<int>(model.lines.trees.size());
  figures.modes = static_cast<long>(model.points.modeCount() + model.lines.modeCount());
  figures.surface_voxels = static_cast<long>(model.surface.elements().size());
  figures.training_frames = model.summary.images;
  figures.model_bytes = temporaryModelBytes(model);
  return figures;
}

}  // namespace relocalizer
