#pragma once
// The dataset arguments the folder tools share (-d/--dataset, --format,
// --frames, --split) and opening the dataset they name, so that every tool
// parses them, and reports their mistakes, the same way.

#include <memory>
#include <string>

#include "cli_support.h"
#include "relocalizer/data/dataset.h"

namespace relocalizer::cli {

struct DatasetArguments {
  std::string path, format = "auto", frames, split = "all";

  // A required -d/--dataset and the selection options, with the tool's help texts.
  void add(CLI::App& app, const std::string& dataset_help, const std::string& frames_help) {
    app.add_option("-d,--dataset", path, dataset_help)->required();
    app.add_option("--format", format, "auto | 7scenes | 12scenes | tum")->capture_default_str();
    app.add_option("--frames", frames, frames_help);
    app.add_option("--split", split, "train | test | all (7-Scenes scenes)")->capture_default_str();
  }

  // `register_colour` false: depth-only tools skip the colour resampling.
  Expected<std::unique_ptr<Dataset>> open(bool register_colour = true) const {
    auto parsed_format = parseDatasetFormat(format);
    if (!parsed_format) return makeError(parsed_format.error());
    DatasetOptions options;
    options.format = *parsed_format;
    options.frames = frames;
    options.split = split;
    options.register_colour = register_colour;
    return openDataset(path, options);
  }
};

}  // namespace relocalizer::cli
