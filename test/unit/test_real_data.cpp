// A reduced run of the redkitchen-dev protocol on the real 7-Scenes frames in
// ../shared/data: smaller forests (3 + 3 trees, depth 20, 150 images and 1000
// samples per image per tree) and every 4th test frame, so it fits in CI (about
// a minute on 2 cores). Its floor catches regressions, not small changes: the
// full protocol numbers are in the README. Skipped, saying so, without the data.

#include <gtest/gtest.h>

#include <tbb/parallel_for.h>

#include "relocalizer/data/dataset.h"
#include "relocalizer/eval/metrics.h"
#include "relocalizer/forest/model_builder.h"
#include "relocalizer/relocalize/relocalizer.h"
#include "support.h"

using namespace relocalizer;

TEST(RealData, ReducedRedkitchenDevProtocolStaysAboveItsFloor) {
  RELOCALIZER_REQUIRE_REDKITCHEN(dir);
  DatasetOptions train_options;
  train_options.frames = "0-99,200-299,400-499";
  auto train_set = openDataset(dir, train_options);
  ASSERT_TRUE(train_set.ok()) << train_set.error();
  std::vector<std::optional<RgbdFrame>> loaded((*train_set)->size());
  tbb::parallel_for(size_t{0}, loaded.size(), [&](size_t i) {
    auto frame = (*train_set)->load(i);
    if (frame) loaded[i] = std::move(*frame);
  });
  TrainingParams params;
  for (ForestParams* f : {&params.points, &params.lines}) {
    f->trees = 3;
    f->max_depth = 20;
    f->images_per_tree = 150;
    f->samples_per_image = 1000;
  }
  ModelBuilder builder(params);
  for (auto& frame : loaded) {
    ASSERT_TRUE(frame.has_value());
    ASSERT_TRUE(builder.add(*frame));
  }
  loaded.clear();
  ASSERT_EQ(builder.size(), 300u);
  auto model = builder.build({});
  ASSERT_TRUE(model.ok()) << model.error();
  const Relocalizer relocalizer(std::move(*model));

  std::string frames;
  for (int i = 100; i < 400; i += 4)
    if (i < 200 || i >= 300) frames += (frames.empty() ? "" : ",") + std::to_string(i);
  DatasetOptions test_options;
  test_options.frames = frames;
  auto test_set = openDataset(dir, test_options);
  ASSERT_TRUE(test_set.ok()) << test_set.error();
  std::vector<FrameError> errors;
  std::vector<std::optional<Pose>> estimates;
  std::vector<Pose> truths;
  for (size_t i = 0; i < (*test_set)->size(); ++i) {
    auto frame = (*test_set)->load(i);
    ASSERT_TRUE(frame.ok()) << frame.error();
    const Relocalization r = relocalizer.relocalize(*frame);
    if (r.success) {
      EXPECT_GE(r.surface_agreement, relocalizer.params().surface.min_agreement);
    }
    std::optional<Pose> estimate;
    if (r.success) estimate = r.pose;
    errors.push_back(frameError(frame->id, estimate, *frame->ground_truth));
    estimates.push_back(estimate);
    truths.push_back(*frame->ground_truth);
  }
  const AccuracySummary s = summarizeAccuracy(errors, estimates, truths);
  std::printf(
      "reduced redkitchen-dev: %d frames, %.1f%% within 5 cm / 5 deg, %.1f%% within 2 cm / "
      "2 deg, median %.2f cm / %.2f deg\n",
      s.frames, 100 * s.within_5cm_5deg, 100 * s.within_2cm_2deg, 100 * s.median_translation_m,
      s.median_rotation_deg);
  // Measured 80% and 1.7 cm / 0.66 deg when written; the baseline BTBRF reaches 41%.
  EXPECT_EQ(s.frames, 50);
  EXPECT_GE(s.within_5cm_5deg, 0.65);
  EXPECT_LE(s.median_translation_m, 0.03);
  EXPECT_LE(s.median_rotation_deg, 1.5);
}
