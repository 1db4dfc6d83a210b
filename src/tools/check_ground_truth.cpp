// check_ground_truth: compares the ground-truth motion between consecutive
// frames with the motion their depth images show (depth_alignment.h), and
// lists the pairs where the reference poses jump, so benchmark numbers can be
// read knowing which test frames are scored against a displaced reference.

#include <tbb/parallel_for.h>

#include <fstream>
#include <vector>

#include "relocalizer/core/statistics.h"
#include "relocalizer/data/depth_alignment.h"
#include "source_arguments.h"

using namespace relocalizer;

int main(int argc, char** argv) {
  cli::App app{
      "Aligns the depth of each pair of consecutive selected frames (projective point-to-plane "
      "ICP from the ground-truth motion) and reports the pairs whose ground-truth motion "
      "disagrees with the depth images. Exit code 0 either way; flagged pairs are listed.",
      "check_ground_truth"};
  cli::SourceOptions arguments;
  std::string output;
  int threads = 0;
  MotionCheckThresholds thresholds;
  arguments.add(app, "Dataset folder", "Frame ids, e.g. 100-199 (default: all)");
  app.addOption("-o,--output", output, "CSV file with every pair");
  app.addOption("--max-translation", thresholds.translation,
                "Flag pairs whose motions differ by more (metres)")
      ->showDefault()
      ->positive();
  app.addOption("--max-rotation", thresholds.rotation_deg,
                "Flag pairs whose motions differ by more (degrees)")
      ->showDefault()
      ->positive();
  app.addOption("-j,--threads", threads, "Worker threads (0 = every core)")
      ->showDefault()
      ->range(0, 1024);
  if (const cli::Exit done = app.parse(argc, argv)) return *done;

  auto source = arguments.open(/*register_colour=*/false);  // depth only
  if (!source) return cli::fail(app, source.error());
  const FrameSource& data = **source;

  // Pairs of selected frames adjacent in id (a gap in the selection is no pair).
  std::vector<size_t> pairs;
  for (size_t i = 0; i + 1 < data.size(); ++i)
    if (data.id(i + 1) == data.id(i) + 1 && data.groundTruth(i) && data.groundTruth(i + 1))
      pairs.push_back(i);
  if (pairs.empty()) return cli::fail(app, "no consecutive frames with ground truth selected");

  tbb::global_control control(tbb::global_control::max_allowed_parallelism,
                              static_cast<size_t>(cli::resolveThreads(threads)));
  std::vector<MotionCheck> checks(pairs.size());
  std::vector<std::string> errors(pairs.size());
  tbb::parallel_for(size_t{0}, pairs.size(), [&](size_t k) {
    const size_t i = pairs[k];
    auto from = data.load(i);
    auto to = data.load(i + 1);
    if (!from || !to) {
      errors[k] = from ? to.error() : from.error();
      return;
    }
    checks[k] =
        checkMotion(from->depth, *from->ground_truth, to->depth, *to->ground_truth, data.camera());
    checks[k].from_id = from->id;
    checks[k].to_id = to->id;
  });
  for (const std::string& e : errors)
    if (!e.empty()) return cli::fail(app, e, 1);

  if (!output.empty()) {
    std::ofstream csv(output);
    if (!csv) return cli::fail(app, "cannot write " + output, 1);
    csv << "from,to,gt_translation_m,gt_rotation_deg,depth_translation_m,depth_rotation_deg,"
           "disagreement_m,disagreement_deg,rms_at_gt_m,rms_aligned_m,aligned,flagged\n";
    for (const MotionCheck& c : checks)
      csv << c.from_id << ',' << c.to_id << ',' << c.ground_truth_motion.translation << ','
          << c.ground_truth_motion.rotation_deg << ',' << c.depth_motion.translation << ','
          << c.depth_motion.rotation_deg << ',' << c.disagreement.translation << ','
          << c.disagreement.rotation_deg << ',' << c.rms_at_ground_truth << ',' << c.rms_aligned
          << ',' << c.aligned << ',' << thresholds.flags(c) << '\n';
  }

  int flagged = 0, unaligned = 0;
  std::vector<double> translation, rotation;
  for (const MotionCheck& c : checks) {
    if (!c.aligned) {
      ++unaligned;
      continue;
    }
    translation.push_back(c.disagreement.translation);
    rotation.push_back(c.disagreement.rotation_deg);
    if (!thresholds.flags(c)) continue;
    if (flagged++ == 0)
      std::printf("pairs whose ground-truth motion disagrees with the depth images:\n");
    std::printf(
        "  %d -> %d: ground truth %.1f mm / %.2f deg, depth %.1f mm / %.2f deg, disagreement "
        "%.1f mm / %.2f deg (depth RMS %.1f mm at the ground truth, %.1f mm aligned)\n",
        c.from_id, c.to_id, 1000 * c.ground_truth_motion.translation,
        c.ground_truth_motion.rotation_deg, 1000 * c.depth_motion.translation,
        c.depth_motion.rotation_deg, 1000 * c.disagreement.translation, c.disagreement.rotation_deg,
        1000 * c.rms_at_ground_truth, 1000 * c.rms_aligned);
  }
  std::printf(
      "%zu pairs checked, %d flagged (> %.1f mm or > %.2f deg), %d not aligned; median "
      "disagreement %.1f mm / %.2f deg\n",
      checks.size(), flagged, 1000 * thresholds.translation, thresholds.rotation_deg, unaligned,
      1000 * median(translation), median(rotation));
  return 0;
}
