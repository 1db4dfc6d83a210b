// dataset_info: opens a dataset as train and evaluate would and prints what it found.

#include "cli_support.h"
#include "relocalizer/dataset.h"

using namespace relocalizer;

int main(int argc, char** argv) {
  CLI::App app{
      "Opens a dataset folder (7-Scenes, 12-Scenes, TUM or synthesize output) the way train and "
      "evaluate do, prints its summary and checks that the first and last selected frames load.",
      "dataset_info"};
  std::string dataset_path, format_name = "auto", frames, split = "all";
  app.add_option("-d,--dataset", dataset_path, "Dataset folder")->required();
  app.add_option("--format", format_name, "auto | 7scenes | 12scenes | tum")->capture_default_str();
  app.add_option("--frames", frames, "Frame ids, e.g. 0-99,200-299 (default: all)");
  app.add_option("--split", split, "train | test | all (7-Scenes scenes)")->capture_default_str();
  if (const int code = cli::parse(app, argc, argv); code >= 0) return code;

  auto format = parseDatasetFormat(format_name);
  if (!format) return cli::fail(app, format.error());
  DatasetOptions options;
  options.format = *format;
  options.frames = frames;
  options.split = split;
  auto dataset = openDataset(dataset_path, options);
  if (!dataset) return cli::fail(app, dataset.error());
  const Dataset& data = **dataset;
  std::printf("%s\n", data.summary().c_str());
  for (size_t i : {size_t{0}, data.size() - 1}) {
    auto frame = data.load(i);
    if (!frame) return cli::fail(app, frame.error());
    std::printf("frame %d: %dx%d, %d pixels with depth, %s ground truth\n", frame->id,
                frame->depth.cols, frame->depth.rows, countValidDepth(frame->depth),
                frame->ground_truth ? "with" : "without");
  }
  return 0;
}
