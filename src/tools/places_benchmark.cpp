// places_benchmark: what many places cost and how well the set picks the
// place. Loads each --place (recording the resident memory it adds), then
// times the first --test's frames against the first n places for each n of
// --counts (one thread by default, the counts taking turns frame by frame),
// and relocalizes every --test's frames against the whole set, counting
// answers from another place than the one the frames were taken in.

#include <malloc.h>

#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "cli_support.h"
#include "place_arguments.h"
#include "relocalizer/data/frame_source.h"
#include "relocalizer/eval/latency_benchmark.h"
#include "relocalizer/eval/place_benchmark.h"
#include "relocalizer/online/place_files.h"

using namespace relocalizer;

namespace {

struct TestSet {
  std::string place;
  std::vector<RgbdFrame> frames;
};

// NAME=DATASET or NAME=DATASET@FRAMES: the frames of place NAME.
Expected<TestSet> loadTestSet(const cli::NamedPath& argument) {
  std::string path = argument.path, frames;
  if (const size_t at = path.rfind('@'); at != std::string::npos) {
    frames = path.substr(at + 1);
    path = path.substr(0, at);
  }
  DatasetOptions options;
  options.frames = frames;
  auto dataset = openDatasetSource(path, options);
  if (!dataset) return makeError("--test " + argument.name + ": " + dataset.error());
  auto loaded = loadAllFrames(**dataset);
  if (!loaded) return makeError("--test " + argument.name + ": " + loaded.error());
  TestSet set{argument.name, {}};
  for (RgbdFrame& frame : *loaded)
    if (frame.ground_truth) set.frames.push_back(std::move(frame));
  if (set.frames.empty())
    return makeError("--test " + argument.name + ": " + path + ": no selected frame has a pose");
  return set;
}

// Resident memory after returning freed heap pages to the system (glibc): a
// loader's freed file buffer would otherwise count against the next place, or hide it.
ResidentMemory trimmedResidentMemory() {
  malloc_trim(0);
  return residentMemory();
}

Expected<std::vector<int>> parseCounts(const std::string& text, int places) {
  std::vector<int> counts;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    const int count = item == "all" ? places : std::atoi(item.c_str());
    if (count < 1 || count > places)
      return makeError("--counts: " + item + " is not a place count in 1.." +
                       std::to_string(places) + " (or all)");
    counts.push_back(count);
  }
  if (counts.empty()) return makeError("--counts: no place count given");
  return counts;
}

// The latency table: each place count's median and p95 and its ratio to the first count's.
void printLatency(const std::vector<PlaceCountRun>& runs, const TestSet& timed, int repeat,
                  nlohmann::json& out) {
  std::printf(
      "\nlatency on %s's %zu frames x %d passes (wrong place: not the first place)\n"
      "  places  median ms  p95 ms  x one  within 5cm/5deg  wrong place\n",
      timed.place.c_str(), timed.frames.size(), repeat);
  const double one = stageLatency(runs.front().timings, &StageTimings::total).median_ms;
  for (const PlaceCountRun& run : runs) {
    const LatencySummary total = stageLatency(run.timings, &StageTimings::total);
    std::printf("  %6d  %9.1f  %6.1f  %5.2f  %14.1f %%  %11d\n", run.places, total.median_ms,
                total.p95_ms, total.median_ms / one, 100.0 * run.summary.accuracy.within_5cm_5deg,
                run.summary.wrong_place);
    out["latency"].push_back({{"places", run.places},
                              {"median_ms", total.median_ms},
                              {"p95_ms", total.p95_ms},
                              {"within_5cm_5deg", run.summary.accuracy.within_5cm_5deg},
                              {"wrong_place", run.summary.wrong_place}});
  }
}

// Where each count's calls spend their time: one place alone by its own
// stages, many places by the search's (sampling, screens, full solves and
// their stages summed over the solves of a call).
void printStages(const std::vector<PlaceCountRun>& runs, nlohmann::json& out) {
  auto median = [](std::vector<double> values) {
    if (values.empty()) return 0.0;
    std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
    return 1000.0 * values[values.size() / 2];
  };
  std::printf(
      "\nstages, median ms per call (one place: its relocalization's stages)\n"
      "  places   total  sampling  screens  full screens/call  solving  solves/call  forests  "
      "ransac  refine  surface\n");
  for (const PlaceCountRun& run : runs) {
    std::vector<double> total, sampling, screens, solving, forests, ransac, refine, surface;
    double solves = 0.0, full_screens = 0.0;
    for (size_t k = 0; k < run.timings.size(); ++k) {
      const StageTimings& t = run.timings[k];
      total.push_back(t.total);
      if (run.places == 1) {
        sampling.push_back(t.sampling_and_forests);  // with its forests: one pass here
        solving.push_back(t.ransac + t.refinement + t.surface);
        forests.push_back(t.sampling_and_forests);
        ransac.push_back(t.ransac);
        refine.push_back(t.refinement);
        surface.push_back(t.surface);
        solves += 1.0;
        continue;
      }
      const PlaceSearchTimings& s = run.search[k];
      sampling.push_back(s.sampling);
      screens.push_back(s.screening);
      solving.push_back(s.solving);
      forests.push_back(s.forest);
      ransac.push_back(s.ransac);
      refine.push_back(s.refinement);
      surface.push_back(s.surface);
      solves += s.solves;
      full_screens += s.full_screens;
    }
    const double calls = std::max<size_t>(1, run.timings.size());
    const double per_call = solves / calls;
    std::printf("  %6d  %6.2f  %8.2f  %7.2f  %17.2f  %7.2f  %11.2f  %7.2f  %6.2f  %6.2f  %7.2f\n",
                run.places, median(total), median(sampling), median(screens), full_screens / calls,
                median(solving), per_call, median(forests), median(ransac), median(refine),
                median(surface));
    out["stages"].push_back({{"places", run.places},
                             {"total_ms", median(total)},
                             {"sampling_ms", median(sampling)},
                             {"screens_ms", median(screens)},
                             {"full_screens_per_call", full_screens / calls},
                             {"solving_ms", median(solving)},
                             {"solves_per_call", per_call},
                             {"forests_ms", median(forests)},
                             {"ransac_ms", median(ransac)},
                             {"refinement_ms", median(refine)},
                             {"surface_ms", median(surface)}});
  }
}

// Every test set against the whole set; returns the wrong-place answers in all.
// Submaps of one group are one place: an answer by any of them is the group's.
int printPlaceChoice(const PlaceSet& all, const std::vector<TestSet>& tests, nlohmann::json& out) {
  std::map<std::string, std::string> group_of;
  for (const auto& place : all.places())
    if (!place->group.empty()) group_of[place->name] = place->group;
  std::printf(
      "\nagainst all %zu places\n  frames of    frames  own place  wrong place  no pose  "
      "within 5cm/5deg\n",
      all.size());
  int wrong_total = 0;
  for (const TestSet& test : tests) {
    std::vector<EvaluationRecord> records = relocalizeAgainstPlaces(all, test.frames);
    for (EvaluationRecord& record : records)
      if (const auto group = group_of.find(record.place); group != group_of.end())
        record.place = group->second;
    const EvaluationSummary summary = summarizeEvaluation(records, test.place);
    const int answered = summary.accuracy.frames_with_pose;
    wrong_total += summary.wrong_place;
    std::printf("  %-10s %7d  %9d  %11d  %7d  %14.1f %%\n", test.place.c_str(),
                summary.accuracy.frames, answered - summary.wrong_place, summary.wrong_place,
                summary.accuracy.frames - answered, 100.0 * summary.accuracy.within_5cm_5deg);
    out["choice"].push_back({{"place", test.place},
                             {"frames", summary.accuracy.frames},
                             {"own_place", answered - summary.wrong_place},
                             {"wrong_place", summary.wrong_place},
                             {"no_pose", summary.accuracy.frames - answered},
                             {"within_5cm_5deg", summary.accuracy.within_5cm_5deg}});
  }
  return wrong_total;
}

// --submaps GROUP=FOLDER: the saved submaps as `places` (submap `lead`
// first, the one timed alone) and as one group of `all`.
Status loadSubmaps(const cli::NamedPath& submaps, int lead, const RelocalizerParams& params,
                   std::vector<Place>& places, PlaceSet& all) {
  const auto& [group, folder] = submaps;
  const ResidentMemory before = trimmedResidentMemory();
  auto opened = openPlace(group, folder, group, params);
  if (!opened) return makeError(opened.error());
  if (!opened->folder)
    return makeError("--submaps " + folder + ": not a folder of learned submaps");
  for (const std::string& warning : opened->warnings) std::printf("warning: %s\n", warning.c_str());
  std::printf("submaps %s: %zu of %s, %.1f MiB resident\n", group.c_str(), opened->places.size(),
              folder.c_str(), (trimmedResidentMemory().current - before.current) / 1048576.0);
  places = std::move(opened->places);
  const std::string lead_name = group + "/" + std::to_string(lead);
  const auto first = std::find_if(places.begin(), places.end(),
                                  [&](const Place& place) { return place.name == lead_name; });
  if (first == places.end()) return makeError("--lead: no submap " + lead_name);
  std::rotate(places.begin(), first, first + 1);
  return all.putGroup(group, places);
}

// Each --place NAME=PATH (a model file, or a folder of learned submaps as
// one group), in map frame NAME, into `places` and `all`, with the resident
// memory it adds.
Status loadPlaces(const std::vector<cli::NamedPath>& named, const RelocalizerParams& params,
                  std::vector<Place>& places, PlaceSet& all, nlohmann::json& out) {
  for (const auto& [name, path] : named) {
    const ResidentMemory before = trimmedResidentMemory();
    auto opened = openPlace(name, path, name, params);
    if (!opened) return makeError(opened.error());
    const ResidentMemory after = trimmedResidentMemory();
    for (const std::string& warning : opened->warnings)
      std::printf("warning: %s\n", warning.c_str());
    const std::vector<Place> of_path = opened->places;
    if (Status added = putPlaceFiles(all, name, std::move(*opened)); !added) return added;
    uint64_t model_bytes = 0;
    long modes = 0;
    int training_frames = 0;
    for (const Place& place : of_path) {
      const PlaceFigures figures = placeFigures(place);
      model_bytes += figures.model_bytes;
      modes += figures.modes;
      training_frames += static_cast<int>(figures.training_frames);
    }
    std::printf("place %-12s %6.1f MiB resident (model %.1f MiB), %ld modes, %d training frames\n",
                name.c_str(), (after.current - before.current) / 1048576.0, model_bytes / 1048576.0,
                modes, training_frames);
    out["places"].push_back({{"name", name},
                             {"model", path},
                             {"resident_bytes", after.current - before.current},
                             {"model_bytes", model_bytes}});
    places.insert(places.end(), of_path.begin(), of_path.end());
  }
  return okStatus();
}

// --test's frames, each set taken in its place.
Expected<std::vector<TestSet>> loadTestSets(const std::vector<cli::NamedPath>& named) {
  std::vector<TestSet> tests;
  for (const cli::NamedPath& argument : named) {
    auto test = loadTestSet(argument);
    if (!test) return makeError(test.error());
    tests.push_back(std::move(*test));
  }
  return tests;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Measures many places: the resident memory each place adds, the latency of relocalizing "
      "the first --test's frames against the first n places for each n of --counts (medians, "
      "measured side by side), and, against the whole set, the share of each --test's frames "
      "answered by its own place, answered by another (wrong place) or without a pose.",
      "places_benchmark"};
  std::vector<std::string> place_arguments, test_arguments;
  std::string counts_text = "1,2,all", json_path, config;
  int repeat = 1, threads = 1;
  std::string submaps_argument;
  auto* place_option =
      app.addOption("--place", place_arguments,
                    "NAME=PATH (a model file, or a folder of learned submaps as one group), "
                    "repeated; the first is the place whose frames are timed");
  app.addOption("--submaps", submaps_argument,
                "NAME=FOLDER: a saved folder of learned submaps as the places, one group NAME "
                "(places NAME/i in folder order; the first --test is taken in NAME)")
      ->excludes(place_option);
  int lead = 0;
  app.addOption("--lead", lead,
                "With --submaps: the submap (its number in the folder) that goes first, so the "
                "one timed alone (count 1): the one the timed frames are in")
      ->showDefault();
  app.addOption("--test", test_arguments,
                "NAME=DATASET or NAME=DATASET@FRAMES: frames taken in place NAME, repeated; "
                "the first is timed")
      ->required();
  app.addOption("--counts", counts_text, "Place counts to time, comma-separated ('all')")
      ->showDefault();
  app.addOption("-c,--config", config, "YAML with a 'relocalizer:' section");
  app.addOption("--repeat", repeat, "Timed passes over the frames")->range(1, 100)->showDefault();
  app.addOption("-j,--threads", threads, "Worker threads inside each call")
      ->range(1, 1024)
      ->showDefault();
  app.addOption("--json", json_path, "Write the figures to this JSON file");
  if (const cli::Exit done = app.parse(argc, argv)) return *done;

  RelocalizerParams params;
  if (!config.empty()) {
    auto loaded = loadRelocalizerParams(config);
    if (!loaded) return cli::fail(app, loaded.error());
    params = *loaded;
  }
  if (place_arguments.empty() && submaps_argument.empty())
    return cli::fail(app, "give --place NAME=MODEL (repeated) or --submaps NAME=FOLDER");
  auto named_places = cli::parseNamedPaths(
      submaps_argument.empty() ? place_arguments : std::vector<std::string>{submaps_argument},
      submaps_argument.empty() ? "--place" : "--submaps");
  if (!named_places) return cli::fail(app, named_places.error());
  auto named_tests = cli::parseNamedPaths(test_arguments, "--test");
  if (!named_tests) return cli::fail(app, named_tests.error());
  if (named_tests->front().name != named_places->front().name)
    return cli::fail(app, "the first --test must be taken in the first --place (" +
                              named_places->front().name + "), whose frames are timed");

  nlohmann::json out;
  out["cpu"] = cpuModel();
  out["threads"] = threads;
  std::printf("CPU: %s; %d thread(s)\n", cpuModel().c_str(), threads);
  std::vector<Place> places;
  PlaceSet all;
  if (Status loaded = submaps_argument.empty()
                          ? loadPlaces(*named_places, params, places, all, out)
                          : loadSubmaps(named_places->front(), lead, params, places, all);
      !loaded)
    return cli::fail(app, loaded.error());
  auto counts = parseCounts(counts_text, static_cast<int>(places.size()));
  if (!counts) return cli::fail(app, counts.error());
  auto tests = loadTestSets(*named_tests);
  if (!tests) return cli::fail(app, tests.error());
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);

  const std::vector<PlaceCountRun> runs =
      timePlaceCounts(places, tests->front().frames, *counts, repeat);
  printLatency(runs, tests->front(), repeat, out);
  printStages(runs, out);
  const int wrong_total = printPlaceChoice(all, *tests, out);
  const ResidentMemory end = residentMemory();
  std::printf("wrong-place answers in all: %d; peak resident memory %.0f MiB\n", wrong_total,
              end.peak / 1048576.0);
  out["wrong_place"] = wrong_total;
  out["peak_resident_bytes"] = end.peak;
  if (!json_path.empty()) {
    std::ofstream file(json_path);
    file << out.dump(2) << "\n";
    if (!file) return cli::fail(app, json_path + ": cannot write", 1);
  }
  return 0;
}
