// dataset_info: opens a dataset folder or a rosbag as train and evaluate would and
// prints what it found.

#include "source_arguments.h"

using namespace relocalizer;

int main(int argc, char** argv) {
  cli::App app{
      "Opens a dataset folder (7-Scenes, 12-Scenes, TUM or synthesize output) or a rosbag the way "
      "train and evaluate do, prints its summary and checks that the first and last selected "
      "frames load.",
      "dataset_info"};
  cli::SourceOptions arguments;
  arguments.add(app, "Dataset folder", "Frame ids, e.g. 0-99,200-299 (default: all)");
  if (const cli::Exit done = app.parse(argc, argv)) return *done;

  auto source = arguments.open();
  if (!source) return cli::fail(app, source.error());
  const FrameSource& data = **source;
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
