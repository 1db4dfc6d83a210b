#include "relocalizer/eval/place_benchmark.h"

#include "relocalizer/core/progress.h"

namespace relocalizer {

std::vector<EvaluationRecord> relocalizeAgainstPlaces(const PlaceSet& places,
                                                      const std::vector<RgbdFrame>& frames) {
  std::vector<EvaluationRecord> records;
  for (const RgbdFrame& frame : frames)
    records.push_back(recordAttempt(frame.id, frame.stamp,
                                    frame.ground_truth.value_or(Pose::Identity()),
                                    places.relocalize(frame)));
  return records;
}

std::vector<PlaceCountRun> timePlaceCounts(const std::vector<Place>& places,
                                           const std::vector<RgbdFrame>& frames,
                                           const std::vector<int>& counts, int repeat) {
  std::vector<PlaceCountRun> runs;
  std::vector<std::unique_ptr<PlaceSet>> sets;
  for (int count : counts) {
    auto set = std::make_unique<PlaceSet>();
    for (int i = 0; i < count && i < static_cast<int>(places.size()); ++i) set->put(places[i]);
    runs.push_back({static_cast<int>(set->size()), {}, {}, {}});
    sets.push_back(std::move(set));
  }
  if (frames.empty()) return runs;
  // One untimed call each: the models paged in, TBB's workers awake.
  for (const auto& set : sets) set->relocalize(frames.front());
  std::vector<std::vector<EvaluationRecord>> first_pass(sets.size());
  ProgressBar bar("places", static_cast<size_t>(repeat) * frames.size());
  for (int pass = 0; pass < repeat; ++pass)
    for (const RgbdFrame& frame : frames) {
      bar.advance();
      for (size_t s = 0; s < sets.size(); ++s) {
        const PlaceAnswer answer = sets[s]->relocalize(frame);
        runs[s].timings.push_back(answer.relocalization.timings);
        runs[s].search.push_back(answer.search);
        if (pass == 0)
          first_pass[s].push_back(recordAttempt(
              frame.id, frame.stamp, frame.ground_truth.value_or(Pose::Identity()), answer));
      }
    }
  const std::string expected = places.empty() ? std::string() : places.front().name;
  for (size_t s = 0; s < sets.size(); ++s)
    runs[s].summary = summarizeEvaluation(first_pass[s], expected);
  return runs;
}

}  // namespace relocalizer
