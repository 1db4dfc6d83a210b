#include "relocalizer/relocalize/place_set.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <numeric>

namespace relocalizer {

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

int inliersOf(const Relocalization& answer) { return answer.point_inliers + answer.line_inliers; }

// The hint for a place: only a place in the hint's frame hears it.
const PoseHint* hintFor(const Place& place, const PoseHint* hint) {
  return hint && hint->frame == place.map_frame ? hint : nullptr;
}

// What a place's evidence counts for against another place: its hint's factor
// at the pose (the largest, 1 + hint_weight, for a screen that has no pose).
// Float, as the ratios it meets are: without a hint every comparison is the
// one made before hints existed.
float hintFactor(const Place& place, const PoseHint* hint, const Pose* pose) {
  const PoseHint* heard = hintFor(place, hint);
  if (!heard) return 1.0f;
  const double weight = place.relocalizer->params().solver.hint_weight;
  if (!pose) return static_cast<float>(1.0 + weight);
  const Expected<HintPrior> prior = HintPrior::make(*heard);
  return prior ? static_cast<float>(prior->factor(*pose, weight)) : 1.0f;
}

// The places, best screened first (ties: the order they were added).
std::vector<size_t> rankByScreen(const std::vector<PlaceAttempt>& attempts,
                                 const std::vector<float>& factors) {
  std::vector<size_t> order(attempts.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return attempts[a].screen_inliers * factors[a] > attempts[b].screen_inliers * factors[b];
  });
  return order;
}

std::string ambiguityMessage(const std::string& a, const Relocalization& answer_a,
                             const std::string& b, const Relocalization& answer_b) {
  char buffer[400];
  std::snprintf(buffer, sizeof buffer,
                "ambiguous place: the frame fits %s (%d inliers) and %s (%d inliers) alike",
                a.c_str(), inliersOf(answer_a), b.c_str(), inliersOf(answer_b));
  return buffer;
}

}  // namespace

std::string PlaceSearchParams::validationError() const {
  if (screen.samples < 3 || screen.hypotheses < 1 || screen.max_leaves < 1)
    return "screen.samples must be >= 3, screen.hypotheses and screen.max_leaves >= 1";
  if (max_solved < 1) return "max_solved must be >= 1";
  if (!(runner_up_ratio >= 0 && runner_up_ratio <= 1))
    return "runner_up_ratio must be a share between 0 and 1";
  if (!(ambiguity_ratio > 0 && ambiguity_ratio <= 1))
    return "ambiguity_ratio must be a share in (0, 1]";
  return {};
}

PlaceFigures placeFigures(const Place& place) {
  PlaceFigures figures;
  figures.name = place.name;
  figures.map_frame = place.map_frame;
  figures.source = place.source;
  if (!place.relocalizer) return figures;
  const Model& model = place.relocalizer->model();
  figures.point_trees = static_cast<int>(model.points.trees.size());
  figures.line_trees = static_cast<int>(model.lines.trees.size());
  figures.modes = static_cast<long>(model.points.modeCount() + model.lines.modeCount());
  figures.surface_voxels = static_cast<long>(model.surface.elements().size());
  figures.training_frames = model.summary.images;
  figures.model_bytes = modelBytes(model);
  return figures;
}

PlaceSet::PlaceSet(PlaceSearchParams params) : params_(std::move(params)) {}

Expected<Place> PlaceSet::load(const std::string& name, const std::string& model_path,
                               const std::string& map_frame, const RelocalizerParams& params) {
  Expected<std::unique_ptr<Relocalizer>> relocalizer = makeError("not loaded");
  try {
    relocalizer = Relocalizer::fromFile(model_path, params);
  } catch (const std::exception& e) {
    // Whatever the loader throws (std::bad_alloc on a corrupt size) refuses
    // this place only.
    return makeError("place " + name + ": " + model_path + ": cannot be loaded: " + e.what());
  }
  if (!relocalizer) return makeError("place " + name + ": " + relocalizer.error());
  Place place;
  place.name = name;
  place.map_frame = map_frame;
  place.source = model_path;
  place.relocalizer = std::move(*relocalizer);
  return place;
}

Status PlaceSet::put(Place place) {
  if (place.name.empty()) return makeError("a place needs a name");
  if (place.map_frame.empty()) return makeError("place " + place.name + ": no map frame");
  if (!place.relocalizer) return makeError("place " + place.name + ": no model");
  if (std::string why = place.relocalizer->validationError(); !why.empty())
    return makeError("place " + place.name + ": " + why);
  auto shared = std::make_shared<const Place>(std::move(place));
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& existing : places_)
    if (existing->name == shared->name) {
      existing = std::move(shared);
      return okStatus();
    }
  places_.push_back(std::move(shared));
  return okStatus();
}

bool PlaceSet::remove(const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = std::find_if(places_.begin(), places_.end(),
                                  [&](const auto& place) { return place->name == name; });
  if (found == places_.end()) return false;
  places_.erase(found);
  return true;
}

std::vector<std::shared_ptr<const Place>> PlaceSet::snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return places_;
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

PlaceAnswer PlaceSet::relocalize(const RgbdFrame& frame, const PoseHint* hint) const {
  const auto start = Clock::now();
  const std::vector<std::shared_ptr<const Place>> places = snapshot();
  PlaceAnswer answer;
  if (places.empty()) {
    answer.relocalization.message = "no place is loaded";
    answer.relocalization.timings.total = secondsSince(start);
    return answer;
  }
  auto answerWith = [&](const Place& place, Relocalization relocalization) {
    answer.place = place.name;
    answer.map_frame = place.map_frame;
    answer.relocalization = std::move(relocalization);
  };
  if (places.size() == 1) {
    // Nothing to rank: the one-place path, with its line branch beside the point forest.
    const Place& place = *places.front();
    Relocalization alone = place.relocalizer->relocalize(frame, hintFor(place, hint));
    answer.attempts.push_back({place.name, -1, true, alone.success, alone.message});
    if (alone.success)
      answerWith(place, std::move(alone));
    else
      answer.relocalization = std::move(alone);
    return answer;
  }

  // Sample once; a place whose recipe differs samples for itself (relocalize()).
  Expected<FrameSamples> shared = places.front()->relocalizer->sample(frame);
  if (!shared) {
    answer.relocalization.message = shared.error();
    answer.relocalization.timings.total = secondsSince(start);
    return answer;
  }
  const auto screen_start = Clock::now();
  answer.attempts.resize(places.size());
  tbb::parallel_for(size_t{0}, places.size(), [&](size_t i) {
    const Relocalizer& relocalizer = *places[i]->relocalizer;
    PlaceAttempt& attempt = answer.attempts[i];
    attempt.place = places[i]->name;
    if (shared->recipe.sameAs(relocalizer.samplingRecipe())) {
      attempt.screen_inliers = relocalizer.screen(*shared, params_.screen).inliers;
    } else if (Expected<FrameSamples> own = relocalizer.sample(frame)) {
      attempt.screen_inliers = relocalizer.screen(*own, params_.screen).inliers;
    }
  });
  const double screen_seconds = secondsSince(screen_start);
  std::vector<float> screen_factors(places.size());
  for (size_t i = 0; i < places.size(); ++i)
    screen_factors[i] = hintFactor(*places[i], hint, nullptr);
  const std::vector<size_t> order = rankByScreen(answer.attempts, screen_factors);

  // Full solves for the best screened place and the runners-up that screened
  // close to it: a look-alike place must not win by being asked alone. A place
  // that screened far below the best is not asked even when the best fails:
  // its full solve would be the likeliest way to a wrong-place answer.
  const float best_screen =
      answer.attempts[order.front()].screen_inliers * screen_factors[order.front()];
  std::vector<std::pair<size_t, Relocalization>> answered;
  Relocalization first_failure;
  for (size_t rank = 0; rank < order.size() && static_cast<int>(rank) < params_.max_solved;
       ++rank) {
    PlaceAttempt& attempt = answer.attempts[order[rank]];
    const float weighed = attempt.screen_inliers * screen_factors[order[rank]];
    const bool close =
        attempt.screen_inliers > 0 && weighed >= params_.runner_up_ratio * best_screen;
    if (rank > 0 && !close) break;
    const Place& place = *places[order[rank]];
    Relocalization full = place.relocalizer->relocalize(frame, *shared, hintFor(place, hint));
    attempt.solved = true;
    attempt.success = full.success;
    attempt.message = full.message;
    if (full.success)
      answered.emplace_back(order[rank], std::move(full));
    else if (rank == 0)
      first_failure = std::move(full);
  }

  if (answered.empty()) {
    answer.relocalization = std::move(first_failure);
    const PlaceAttempt& best = answer.attempts[order.front()];
    answer.relocalization.message = "no place fits; best screened " + best.place + ": " +
                                    (best.message.empty() ? "not solved" : best.message);
  } else {
    // Weighed by the hint: a place in its frame, answering near it, counts up.
    auto weighed = [&](const std::pair<size_t, Relocalization>& a) {
      return inliersOf(a.second) * hintFactor(*places[a.first], hint, &a.second.pose);
    };
    std::stable_sort(answered.begin(), answered.end(),
                     [&](const auto& a, const auto& b) { return weighed(a) > weighed(b); });
    const auto& [winner, winning] = answered.front();
    if (answered.size() > 1 &&
        weighed(answered[1]) >= params_.ambiguity_ratio * weighed(answered.front())) {
      const std::string why = ambiguityMessage(places[winner]->name, winning,
                                               places[answered[1].first]->name, answered[1].second);
      answer.relocalization = winning;
      answer.relocalization.success = false;
      answer.relocalization.message = why;
    } else {
      answerWith(*places[winner], std::move(answered.front().second));
    }
  }
  // Move the attempts into rank order for the reader.
  std::vector<PlaceAttempt> ranked;
  for (size_t i : order) ranked.push_back(std::move(answer.attempts[i]));
  answer.attempts = std::move(ranked);
  answer.relocalization.timings.screening = screen_seconds;
  answer.relocalization.timings.total = secondsSince(start);
  return answer;
}

}  // namespace relocalizer
