// searchPlaces: one frame searched across the places (place_search.h says
// how it chooses): shared samples, every place screened, the best solved with
// its close runners-up, and the answers judged.

#include "relocalizer/relocalize/place_search.h"

#include "place_rules.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numeric>
#include <optional>

namespace relocalizer {

namespace {

using detail::ambiguityMessage;
using detail::disagreementMessage;
using detail::hintFactor;
using detail::hintFor;
using detail::inliersOf;
using detail::oneMap;
using detail::otherPart;

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Places `first` to `last` of a ranking put best screened first: the fully
// screened ones, then those that had the first look only (ties keep their order).
void sortByScreen(std::vector<size_t>::iterator first, std::vector<size_t>::iterator last,
                  const std::vector<PlaceAttempt>& attempts, const std::vector<float>& factors) {
  std::stable_sort(first, last, [&](size_t a, size_t b) {
    if (attempts[a].screened_fully != attempts[b].screened_fully) return attempts[a].screened_fully;
    return attempts[a].screen_inliers * factors[a] > attempts[b].screen_inliers * factors[b];
  });
}

// The frame screened: every place's screen, the hint's factor it was weighed
// by, whether it got the full screen, and the order they rank in.
struct Screened {
  std::vector<ScreenResult> results;
  std::vector<float> factors;
  std::vector<char> full;     // got the full screen (else the first look only)
  std::vector<size_t> order;  // best screened first
  // Each place's one-leaf predictions of the shared samples, for a later, fuller screen.
  std::vector<std::vector<Prediction>> predicted;
  double seconds = 0.0;
};

// A place that answered: its index among the places and its answer.
using Answered = std::pair<size_t, Relocalization>;

struct Solves {
  std::vector<Answered> answered;  // in rank order
  Relocalization first_failure;    // the best screened place's, when it failed
  // Per place: the place that answered whose screen it agreed with, when it
  // was not solved for that reason (SIZE_MAX: none).
  std::vector<size_t> skipped_for;
};

// A full solve's stages into the search's sums (its forests on shared samples:
// sampling_and_forests is their wall time).
void count(const StageTimings& solve, PlaceSearchTimings& timings) {
  ++timings.solves;
  timings.forest += solve.sampling_and_forests;
  timings.ransac += solve.ransac;
  timings.refinement += solve.refinement;
  timings.surface += solve.surface;
}

// A runner-up screened close enough to the best to be solved too. A place
// left at its first look was judged far from the best there.
bool closeRunnerUp(const PlaceAttempt& attempt, float factor, float best_screen,
                   const PlaceSearchParams& params) {
  return attempt.screened_fully && attempt.screen_inliers > 0 &&
         attempt.screen_inliers * factor >= params.runner_up_ratio * best_screen;
}

// The best screened place failed: the places of its map left at their first
// look get the full screen (reusing its predictions) and the ranking behind the
// best is made again, so that the neighbour fallback (solveRanked) chooses by
// it: a submap holding only the furniture moved since a survey beside it got
// no inlier among the first look's 50 samples and 43-61 among 200.
void screenNeighboursFully(const std::vector<std::shared_ptr<const Place>>& places,
                           const FrameSamples& samples, const PlaceSearchParams& params,
                           Screened& screened, std::vector<PlaceAttempt>& attempts,
                           PlaceSearchTimings& timings) {
  const auto start = Clock::now();
  const Place& best = *places[screened.order.front()];
  std::vector<size_t> unscreened;
  for (size_t i : screened.order)
    if (!screened.full[i] && places[i].get() != &best && oneMap(best, *places[i]))
      unscreened.push_back(i);
  if (unscreened.empty()) return;
  tbb::parallel_for(size_t{0}, unscreened.size(), [&](size_t k) {
    const size_t i = unscreened[k];
    screened.results[i] =
        places[i]->relocalizer->screen(samples, params.screen, &screened.predicted[i]);
  });
  for (size_t i : unscreened) {
    screened.full[i] = 1;
    attempts[i].screen_inliers = screened.results[i].inliers;
    attempts[i].screened_fully = true;
  }
  sortByScreen(screened.order.begin() + 1, screened.order.end(), attempts, screened.factors);
  timings.full_screens += static_cast<int>(unscreened.size());
  timings.screening += secondsSince(start);
}

// The places solveRanked solves when the best screened place answers (the
// usual case), known from the screens alone: the best, and the close
// runners-up that are not one map with it at its screen pose, up to
// max_solved.
std::vector<size_t> solvedIfBestAnswers(const std::vector<std::shared_ptr<const Place>>& places,
                                        const Screened& screened, const PlaceSearchParams& params,
                                        const std::vector<PlaceAttempt>& attempts) {
  const size_t best = screened.order.front();
  const float best_screen = attempts[best].screen_inliers * screened.factors[best];
  std::vector<size_t> solved{best};
  for (size_t rank = 1;
       rank < screened.order.size() && static_cast<int>(solved.size()) < params.max_solved;
       ++rank) {
    const size_t i = screened.order[rank];
    if (!closeRunnerUp(attempts[i], screened.factors[i], best_screen, params)) continue;
    if (oneMap(*places[best], *places[i]) &&
        posesAgree(screened.results[best].pose, screened.results[i].pose,
                   params.screen_agreement_metres, params.screen_agreement_degrees))
      continue;
    solved.push_back(i);
  }
  return solved;
}

// A place that answered has a newer part of its map (Place::part) none of
// whose places was solved yet, and place `i` is that part's best screened
// place with any inlier: it is asked too, so that the two parts' answers are
// compared (judge). A SLAM map reset leaves the room in both parts, and the
// first look can screen the part SLAM now uses at 3 inliers where the old one
// has 16. An older part is not asked after a newer one answered: the newer
// is the map SLAM uses.
bool unaskedPart(const std::vector<std::shared_ptr<const Place>>& places, const Solves& solves,
                 const std::vector<PlaceAttempt>& attempts, size_t i) {
  if (solves.answered.empty() || attempts[i].screen_inliers <= 0) return false;
  const Place& lead = *places[solves.answered.front().first];
  const Place& place = *places[i];
  if (!otherPart(lead, place) || place.part < lead.part) return false;
  for (size_t k = 0; k < places.size(); ++k)
    if (attempts[k].solved && places[k]->part == place.part && oneMap(*places[k], place))
      return false;
  return true;
}

// Full solves for the best screened place and the runners-up that screened
// close to it: a look-alike place must not win by being asked alone. A place
// that screened far below the best is not asked even when the best fails: its
// full solve would be the likeliest way to a wrong-place answer; except a part
// of the best's own map, which can only answer in the right frame. A runner-up
// of one map with a place that answered, screened at the same pose, is not
// solved: it could only agree (and then a full solve of it is wasted).
Solves solveRanked(const std::vector<std::shared_ptr<const Place>>& places, Screened& screened,
                   const PlaceSearchParams& params, const RgbdFrame& frame,
                   const FrameSamples& shared, const PoseHint* hint,
                   std::vector<PlaceAttempt>& attempts, PlaceSearchTimings& timings) {
  Solves solves;
  solves.skipped_for.assign(places.size(), SIZE_MAX);
  // Solve what the rule below will solve if the best answers all at once,
  // each on its own thread: a solve's candidate draw, final refinement and
  // surface check run on one core, so two solves side by side take little
  // more than one. The rule then takes their answers as if it had solved
  // them in turn (a solve depends on nothing but its place and the frame), so
  // the answer is the same; when the best fails, what the rule solves next is
  // solved then, and a place solved ahead that the rule skips is not used.
  std::vector<std::optional<Relocalization>> ahead(places.size());
  if (const std::vector<size_t> likely = solvedIfBestAnswers(places, screened, params, attempts);
      likely.size() > 1) {
    tbb::parallel_for(size_t{0}, likely.size(), [&](size_t k) {
      const Place& place = *places[likely[k]];
      ahead[likely[k]] = place.relocalizer->relocalize(frame, shared, hintFor(place, hint));
    });
    for (size_t i : likely) count(ahead[i]->timings, timings);
  }
  const size_t best = screened.order.front();
  const float best_screen = attempts[best].screen_inliers * screened.factors[best];
  int solved = 0;
  for (size_t rank = 0; rank < screened.order.size() && solved < params.max_solved; ++rank) {
    const size_t i = screened.order[rank];
    PlaceAttempt& attempt = attempts[i];
    const bool close = closeRunnerUp(attempt, screened.factors[i], best_screen, params);
    const Place& place = *places[i];
    // Neighbours as a fallback: while nothing has answered, a place of the
    // best's map (a neighbouring submap, whose area the frame may be in rather
    // than the best screened one's) is solved however weakly it screened. It
    // cannot answer in a wrong frame, and its own evidence thresholds still
    // gate its pose.
    const bool neighbour =
        solves.answered.empty() && attempt.screen_inliers > 0 && oneMap(*places[best], place);
    if (rank > 0 && !close && !neighbour && !unaskedPart(places, solves, attempts, i)) continue;
    if (!solves.answered.empty()) {
      const size_t lead = solves.answered.front().first;
      if (oneMap(*places[lead], place) &&
          posesAgree(screened.results[lead].pose, screened.results[i].pose,
                     params.screen_agreement_metres, params.screen_agreement_degrees)) {
        solves.skipped_for[i] = lead;
        continue;
      }
    }
    Relocalization full;
    if (ahead[i]) {
      full = std::move(*ahead[i]);
    } else {
      full = place.relocalizer->relocalize(frame, shared, hintFor(place, hint));
      count(full.timings, timings);
    }
    ++solved;
    attempt.solved = true;
    attempt.success = full.success;
    attempt.message = full.message;
    if (full.success) {
      solves.answered.emplace_back(i, std::move(full));
    } else if (rank == 0) {
      solves.first_failure = std::move(full);
      screenNeighboursFully(places, shared, params, screened, attempts, timings);
    }
  }
  return solves;
}

// The answer from the places that answered: the strongest (inliers weighed by
// the hint: a place in its frame, answering near it, counts up), unless
// another comes within ambiguity_ratio of it and is a rival: of another map,
// or of the same map at another pose. Then "no pose".
void judge(const std::vector<std::shared_ptr<const Place>>& places, Solves& solves,
           const std::vector<size_t>& order, const PoseHint* hint, const PlaceSearchParams& params,
           PlaceAnswer& answer) {
  std::vector<Answered>& answered = solves.answered;
  if (answered.empty()) {
    answer.relocalization = std::move(solves.first_failure);
    const PlaceAttempt& best = answer.attempts[order.front()];
    answer.relocalization.message = "no place fits; best screened " + best.place + ": " +
                                    (best.message.empty() ? "not solved" : best.message);
    return;
  }
  auto weighed = [&](const Answered& a) {
    return inliersOf(a.second) * hintFactor(*places[a.first], hint, &a.second.pose);
  };
  std::stable_sort(answered.begin(), answered.end(),
                   [&](const auto& a, const auto& b) { return weighed(a) > weighed(b); });
  const auto& [winner, winning] = answered.front();
  const Place& place = *places[winner];
  std::string rivalry;
  for (size_t k = 1; k < answered.size(); ++k) {
    const auto& [other, answer_other] = answered[k];
    const bool agrees = oneMap(place, *places[other]) &&
                        posesAgree(winning.pose, answer_other.pose, params.agreement_metres,
                                   params.agreement_degrees);
    answer.attempts[other].agrees = agrees;
    if (agrees || !rivalry.empty()) continue;
    // An answer of a newer part of the map (the one SLAM uses since its map
    // moved) that disagrees is always a rival of an older part's.
    const bool newer_part = otherPart(place, *places[other]) && places[other]->part > place.part;
    if (weighed(answered[k]) < params.ambiguity_ratio * weighed(answered.front()) && !newer_part)
      continue;
    rivalry = oneMap(place, *places[other])
                  ? disagreementMessage(place.name, winning, places[other]->name, answer_other)
                  : ambiguityMessage(place.name, winning, places[other]->name, answer_other);
  }
  for (size_t i = 0; i < places.size(); ++i)
    if (solves.skipped_for[i] == winner) answer.attempts[i].agrees = true;
  if (!rivalry.empty()) {
    answer.relocalization = winning;
    answer.relocalization.success = false;
    answer.relocalization.message = rivalry;
    return;
  }
  answer.place = place.name;
  answer.map_frame = place.map_frame;
  answer.relocalization = std::move(answered.front().second);
}

// Every place screened on `samples` (the shared point samples): the first
// look, then the full screen where it came close.
void screenPlaces(const std::vector<std::shared_ptr<const Place>>& places, const RgbdFrame& frame,
                  const FrameSamples& samples, const PlaceSearchParams& params,
                  Screened& screened) {
  const auto screen_start = Clock::now();
  screened.predicted.resize(places.size());
  std::vector<char> shared_recipe(places.size());
  for (size_t i = 0; i < places.size(); ++i)
    shared_recipe[i] = samples.recipe.sameAs(places[i]->relocalizer->samplingRecipe());
  // A place whose recipe differs screens fully, on samples of its own.
  auto screenPlace = [&](size_t i, const ScreenParams& budget) {
    const Relocalizer& relocalizer = *places[i]->relocalizer;
    if (shared_recipe[i]) {
      screened.results[i] = relocalizer.screen(samples, budget, &screened.predicted[i]);
    } else if (Expected<FrameSamples> sampled = relocalizer.sample(frame)) {
      screened.results[i] = relocalizer.screen(*sampled, params.screen);
    }
  };
  if (params.first_look.samples > 0) {
    tbb::parallel_for(size_t{0}, places.size(), [&](size_t i) {
      if (shared_recipe[i]) screenPlace(i, params.first_look);
    });
    float best = 0.0f;
    for (size_t i = 0; i < places.size(); ++i)
      if (shared_recipe[i])
        best = std::max(best, screened.results[i].inliers * screened.factors[i]);
    if (best >= params.rescreen_all_below)
      for (size_t i = 0; i < places.size(); ++i)
        screened.full[i] =
            !shared_recipe[i] ||
            (screened.results[i].inliers > 0 &&
             screened.results[i].inliers * screened.factors[i] >= params.rescreen_ratio * best);
  }
  std::vector<size_t> rescreened;
  for (size_t i = 0; i < places.size(); ++i)
    if (screened.full[i]) rescreened.push_back(i);
  // The lead alone came close: its full screen could change nothing (it
  // ranks first and no runner-up is close), so the first look stands.
  if (rescreened.size() == 1 && shared_recipe[rescreened.front()] &&
      params.first_look.samples > 0) {
    screened.full[rescreened.front()] = 0;
    rescreened.clear();
  }
  tbb::parallel_for(size_t{0}, rescreened.size(),
                    [&](size_t k) { screenPlace(rescreened[k], params.screen); });
  screened.seconds = secondsSince(screen_start);
}

}  // namespace

std::string PlaceSearchParams::validationError() const {
  if (screen.samples < 3 || screen.hypotheses < 1 || screen.sampling_attempts < 1 ||
      screen.max_leaves < 1)
    return "screen.samples must be >= 3, screen.hypotheses, screen.sampling_attempts and "
           "screen.max_leaves >= 1";
  if (first_look.samples != 0 &&
      (first_look.samples < 3 || first_look.hypotheses < 1 || first_look.sampling_attempts < 1 ||
       first_look.max_leaves != screen.max_leaves || first_look.samples > screen.samples))
    return "first_look.samples must be 0 (no first look) or in 3..screen.samples, "
           "first_look.hypotheses and first_look.sampling_attempts >= 1, and first_look.max_leaves "
           "equal to screen.max_leaves (the screen reuses its predictions)";
  if (!(rescreen_ratio >= 0 && rescreen_ratio <= 1))
    return "rescreen_ratio must be a share between 0 and 1";
  if (max_solved < 1) return "max_solved must be >= 1";
  if (!(runner_up_ratio >= 0 && runner_up_ratio <= 1))
    return "runner_up_ratio must be a share between 0 and 1";
  if (!(ambiguity_ratio > 0 && ambiguity_ratio <= 1))
    return "ambiguity_ratio must be a share in (0, 1]";
  if (!(agreement_metres >= 0 && agreement_degrees >= 0))
    return "agreement_metres and agreement_degrees must be >= 0";
  if (std::isnan(screen_agreement_metres) || std::isnan(screen_agreement_degrees))
    return "screen_agreement_metres and screen_agreement_degrees must be numbers";
  return {};
}

PlaceAnswer searchPlaces(const std::vector<std::shared_ptr<const Place>>& places,
                         const RgbdFrame& frame, const PoseHint* hint,
                         const PlaceSearchParams& params) {
  const auto start = Clock::now();
  PlaceAnswer answer;
  if (places.empty()) {
    answer.relocalization.message = "no place is loaded";
    answer.relocalization.timings.total = secondsSince(start);
    return answer;
  }
  if (places.size() == 1) {
    // Nothing to rank: the one-place path, with its line branch beside the point forest.
    const Place& place = *places.front();
    Relocalization alone = place.relocalizer->relocalize(frame, hintFor(place, hint));
    answer.attempts.push_back({place.name, -1, true, alone.success, alone.message});
    if (alone.success) {
      answer.place = place.name;
      answer.map_frame = place.map_frame;
    }
    answer.relocalization = std::move(alone);
    return answer;
  }

  // Sample once; a place whose recipe differs samples for itself (relocalize()).
  // The screens need the point samples only: they run while LSD draws the
  // line samples beside them.
  Screened screened;
  screened.results.resize(places.size());
  screened.factors.resize(places.size());
  for (size_t i = 0; i < places.size(); ++i)
    screened.factors[i] = hintFactor(*places[i], hint, nullptr);
  screened.full.assign(places.size(), 1);
  Expected<FrameSamples> shared = places.front()->relocalizer->sample(
      frame,
      [&](const FrameSamples& samples) { screenPlaces(places, frame, samples, params, screened); });
  // The samples' own time: what the call waited for besides the screens.
  answer.search.sampling = secondsSince(start) - screened.seconds;
  if (!shared) {
    answer.relocalization.message = shared.error();
    answer.relocalization.timings.total = secondsSince(start);
    return answer;
  }
  answer.attempts.resize(places.size());
  for (size_t i = 0; i < places.size(); ++i) {
    answer.attempts[i].place = places[i]->name;
    answer.attempts[i].screen_inliers = screened.results[i].inliers;
    answer.attempts[i].screened_fully = screened.full[i];
    answer.search.full_screens += screened.full[i];
  }
  screened.order.resize(places.size());
  std::iota(screened.order.begin(), screened.order.end(), 0);
  sortByScreen(screened.order.begin(), screened.order.end(), answer.attempts, screened.factors);

  answer.search.screening = screened.seconds;
  const auto solve_start = Clock::now();
  Solves solves =
      solveRanked(places, screened, params, frame, *shared, hint, answer.attempts, answer.search);
  // Less the screens of neighbours after the best failed (in screening).
  answer.search.solving = secondsSince(solve_start) - (answer.search.screening - screened.seconds);
  judge(places, solves, screened.order, hint, params, answer);
  // Move the attempts into rank order for the reader.
  std::vector<PlaceAttempt> ranked;
  for (size_t i : screened.order) ranked.push_back(std::move(answer.attempts[i]));
  answer.attempts = std::move(ranked);
  answer.relocalization.timings.screening = answer.search.screening;
  answer.relocalization.timings.total = secondsSince(start);
  return answer;
}

}  // namespace relocalizer
