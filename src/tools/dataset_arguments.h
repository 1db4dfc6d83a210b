#pragma once
// The dataset arguments the folder tools share (-d/--dataset, --format,
// --frames, --split) and opening the dataset they name, so that every tool
// parses them, and reports their mistakes, the same way. source_arguments.h
// adds --bag for the tools that read rosbags too.

#include <memory>
#include <string>

#include "cli_support.h"
#include "relocalizer/data/dataset.h"

namespace relocalizer::cli {

struct DatasetArguments {
  std::string path, format = "auto", frames, split = "all";
  // Set by add(), for options that exclude or need them.
  Option* path_option = nullptr;
  Option* format_option = nullptr;
  Option* split_option = nullptr;

  // -d/--dataset (required unless another source may replace it) and the
  // selection options, with the tool's help texts.
  void add(App& app, const std::string& dataset_help, const std::string& frames_help,
           bool required = true) {
    path_option = app.addOption("-d,--dataset", path, dataset_help);
    if (required) path_option->required();
    format_option =
        app.addOption("--format", format, "auto | 7scenes | 12scenes | tum")->showDefault();
    app.addOption("--frames", frames, frames_help);
    split_option =
        app.addOption("--split", split, "train | test | all (7-Scenes scenes)")->showDefault();
  }

  // `register_colour` false: depth-only tools skip the colour resampling.
  Expected<DatasetOptions> options(bool register_colour = true) const {
    auto parsed_format = parseDatasetFormat(format);
    if (!parsed_format) return makeError(parsed_format.error());
    DatasetOptions options;
    options.format = *parsed_format;
    options.frames = frames;
    options.split = split;
    options.register_colour = register_colour;
    return options;
  }

  Expected<std::unique_ptr<Dataset>> open(bool register_colour = true) const {
    auto opened = options(register_colour);
    if (!opened) return makeError(opened.error());
    return openDataset(path, *opened);
  }
};

}  // namespace relocalizer::cli
