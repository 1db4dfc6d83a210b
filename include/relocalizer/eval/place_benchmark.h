#pragma once
// What many places cost and how well the set picks the place: latency against
// the number of places (one thread, the same frames, measured side by side),
// wrong-place answers over each place's frames, and resident memory per place
// (the `places_benchmark` tool's figures; memory: latency_benchmark.h's residentMemory).

#include <string>
#include <vector>

#include "relocalizer/core/frame.h"
#include "relocalizer/eval/evaluation.h"
#include "relocalizer/relocalize/place_set.h"

namespace relocalizer {

struct PlaceCountRun {
  int places = 0;
  std::vector<StageTimings> timings;       // every call, every pass
  std::vector<PlaceSearchTimings> search;  // the same calls' search stages (zero for one place)
  EvaluationSummary summary;               // the first pass; wrong place against the first place
};

// For each count n, a set of the first n places relocalizes `frames` (taken in
// the first place) `repeat` times; the counts take turns frame by frame, so a
// noisy machine slows them alike. Uses the current TBB parallelism.
std::vector<PlaceCountRun> timePlaceCounts(const std::vector<Place>& places,
                                           const std::vector<RgbdFrame>& frames,
                                           const std::vector<int>& counts, int repeat);

// Each frame (taken in `expected`) relocalized against the whole set: the
// records name the answering place (summarizeEvaluation counts wrong places).
std::vector<EvaluationRecord> relocalizeAgainstPlaces(const PlaceSet& places,
                                                      const std::vector<RgbdFrame>& frames);

}  // namespace relocalizer
