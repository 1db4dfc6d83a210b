// Regression tests for the bugs the libFuzzer targets (test/fuzz/) and the
// sanitizers found; docs/reliability.md lists each finding. Each test feeds the
// smallest input of its kind and checks the clear error that replaced the
// crash or undefined behaviour.

#include <gtest/gtest.h>
#include <zlib.h>

#include <climits>
#include <cstdint>
#include <cstring>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "relocalizer/core/config.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/forest/training_config.h"
#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer {
namespace {

using nlohmann::json;

constexpr size_t kBodySizeOffset = 16;
constexpr size_t kCrcOffset = 24;
constexpr size_t kBodyOffset = 28;

// One split node with two leaves, each leaf one mode.
Model smallModel() {
  Model model;
  Tree tree;
  SplitNode root;
  root.left = 1;
  root.feature.channel_p = 2;
  root.feature.channel_q = 0;
  tree.nodes = {root, SplitNode::leaf({0, 1}), SplitNode::leaf({1, 1})};
  tree.modes = {PackedMode{}, PackedMode{}};
  tree.descriptors = {Descriptor{}, Descriptor{}};
  model.points.trees = {tree};
  return model;
}

Expected<Model> roundTrip(const Model& model) {
  const std::vector<uint8_t> bytes = serializeModel(model);
  return deserializeModel(bytes.data(), bytes.size(), "test.model");
}

// The model's bytes with the header JSON edited and the body length and
// CRC-32 made to match, as a hand-edited or hostile file would have them.
std::vector<uint8_t> withHeader(const Model& model, const std::function<void(json&)>& edit) {
  const std::vector<uint8_t> bytes = serializeModel(model);
  uint32_t header_size = 0;
  std::memcpy(&header_size, bytes.data() + kBodyOffset, sizeof header_size);
  const auto header_begin = bytes.begin() + kBodyOffset + sizeof header_size;
  json header = json::parse(std::string(header_begin, header_begin + header_size));
  edit(header);
  const std::string text = header.dump();

  std::vector<uint8_t> body(sizeof(uint32_t));
  const uint32_t text_size = static_cast<uint32_t>(text.size());
  std::memcpy(body.data(), &text_size, sizeof text_size);
  body.insert(body.end(), text.begin(), text.end());
  body.insert(body.end(), header_begin + header_size, bytes.end());

  std::vector<uint8_t> out(bytes.begin(), bytes.begin() + kBodyOffset);
  const uint64_t body_size = body.size();
  std::memcpy(out.data() + kBodySizeOffset, &body_size, sizeof body_size);
  const uint32_t crc =
      static_cast<uint32_t>(crc32(0L, body.data(), static_cast<uInt>(body.size())));
  std::memcpy(out.data() + kCrcOffset, &crc, sizeof crc);
  out.insert(out.end(), body.begin(), body.end());
  return out;
}

std::string loadError(const std::vector<uint8_t>& bytes) {
  auto model = deserializeModel(bytes.data(), bytes.size(), "edited.model");
  return model ? std::string("(loaded)") : model.error();
}

// fuzz_model: UBSan, memcpy(nullptr, src, 0) when a tree array is empty.
TEST(FuzzRegressionModel, EmptyForestArraysLoad) {
  Model model;
  Tree tree;
  tree.nodes = {SplitNode::leaf({0, 0})};  // a leaf without modes: modes is empty
  model.points.trees = {tree};
  auto loaded = roundTrip(model);
  ASSERT_TRUE(loaded) << loaded.error();
  EXPECT_TRUE(loaded->points.trees[0].modes.empty());
}

// fuzz_model: UBSan, signed overflow in SplitNode::leafIndex() (-INT32_MIN)
// while the loader validated leaf indices. Version 2 has no leaf index (any
// negative `left` is a leaf holding its mode range); version-1 files still
// have them, and test_forest checks INT32_MIN there.
TEST(FuzzRegressionModel, LeafCodeInt32MinIsALeaf) {
  Model model = smallModel();
  model.points.trees[0].nodes[1].left = INT32_MIN;
  auto loaded = roundTrip(model);
  ASSERT_TRUE(loaded) << loaded.error();
  EXPECT_TRUE(loaded->points.trees[0].nodes[1].isLeaf());
  EXPECT_EQ(loaded->points.trees[0].nodes[1].leafModes().mode_count, 1u);
}

TEST(FuzzRegressionModel, LeafModeRangeOutOfBoundsIsRejected) {
  for (const LeafRange range :
       {LeafRange{1, 2}, LeafRange{UINT32_MAX, 2}, LeafRange{0, UINT32_MAX}}) {
    Model model = smallModel();
    model.points.trees[0].nodes[2] = SplitNode::leaf(range);
    auto loaded = roundTrip(model);
    ASSERT_FALSE(loaded);
    EXPECT_EQ(loaded.error(), "test.model: invalid forest: leaf mode range out of bounds");
  }
}

// fuzz_model: ASan, heap-buffer-overflow in evaluateFeature: the loader let a
// colour channel above 2 through, and prediction indexes BGR pixels with it.
TEST(FuzzRegressionModel, ColourChannelOutOfRangeIsRejected) {
  for (int which = 0; which < 2; ++which) {
    Model model = smallModel();
    PixelFeature& feature = model.points.trees[0].nodes[0].feature;
    (which == 0 ? feature.channel_p : feature.channel_q) = 3;
    auto loaded = roundTrip(model);
    ASSERT_FALSE(loaded) << "channel " << (which == 0 ? "p" : "q");
    EXPECT_EQ(loaded.error(), "test.model: invalid forest: colour channel out of range");
  }
}

TEST(FuzzRegressionModel, UnknownFeatureTypeIsRejected) {
  Model model = smallModel();
  model.points.trees[0].nodes[0].feature.type = static_cast<FeatureType>(7);
  auto loaded = roundTrip(model);
  ASSERT_FALSE(loaded);
  EXPECT_EQ(loaded.error(), "test.model: invalid forest: unknown feature type 7");
}

TEST(FuzzRegressionModel, ValidModelStillLoads) {
  auto loaded = roundTrip(smallModel());
  ASSERT_TRUE(loaded) << loaded.error();
  EXPECT_EQ(loaded->points.trees[0].nodes.size(), 3u);
}

// fuzz_model: UBSan, "-1e+300 is outside the range of representable values of
// type 'int'": header numbers were converted to their fields unchecked.
TEST(FuzzRegressionModel, HeaderNumbersMustFitTheirFields) {
  const Model model = smallModel();
  EXPECT_EQ(loadError(withHeader(model, [](json& h) { h["training_set"]["images"] = 1e300; })),
            "edited.model: model header is not valid: 'training_set.images' must be an integer "
            "from -2147483648 to 2147483647, got 1e+300");
  EXPECT_EQ(loadError(withHeader(model, [](json& h) { h["params"]["points"]["trees"] = -1e300; })),
            "edited.model: model header is not valid: 'points.trees' must be an integer from "
            "-2147483648 to 2147483647, got -1e+300");
  EXPECT_EQ(loadError(withHeader(model, [](json& h) { h["params"]["lines"]["max_depth"] = 1.5; })),
            "edited.model: model header is not valid: 'lines.max_depth' must be an integer from "
            "-2147483648 to 2147483647, got 1.5");
  EXPECT_EQ(loadError(withHeader(model, [](json& h) { h["params"]["seed"] = -1; })),
            "edited.model: model header is not valid: 'seed' must be an integer from 0 to "
            "18446744073709551615, got -1");
  EXPECT_EQ(loadError(withHeader(
                model, [](json& h) { h["params"]["points"]["mean_shift"]["bandwidth"] = 1e300; })),
            "edited.model: model header is not valid: 'points.mean_shift.bandwidth' must be a "
            "finite number, got 1e+300");
  const auto two_numbers = [](json& h) { h["training_set"]["scene_min"] = {1, 2}; };
  EXPECT_EQ(loadError(withHeader(model, two_numbers)),
            "edited.model: model header is not valid: 'training_set.scene_min' must be 3 numbers, "
            "got [1,2]");
  EXPECT_EQ(loadError(withHeader(model, [](json& h) { h["params"]["train_lines"] = 1; })),
            "edited.model: model header is not valid: 'train_lines' must be true or false, got 1");
  // The unedited header still loads through the same path.
  EXPECT_EQ(loadError(withHeader(model, [](json&) {})), "(loaded)");
}

// fuzz_config: std::terminate, a YAML key that is not a scalar made
// YAML::Node::as<std::string>() throw out of mergeYamlOntoJson.
TEST(FuzzRegressionConfig, NonScalarKeysAreErrors) {
  auto top = parseTrainingParams("? [a, b]\n: 1\n", "bad.yaml");
  ASSERT_FALSE(top);
  EXPECT_EQ(top.error(), "bad.yaml: '(top level)' has a key that is not a plain name");
  auto nested = parseTrainingParams("points:\n  ? {x: 1}\n  : 2\n", "bad.yaml");
  ASSERT_FALSE(nested);
  EXPECT_EQ(nested.error(), "bad.yaml: 'points' has a key that is not a plain name");
  auto null_key = parseTrainingParams("? \n: 1\n", "bad.yaml");
  ASSERT_FALSE(null_key);
  EXPECT_EQ(null_key.error(), "bad.yaml: '(top level)' has a key that is not a plain name");
}

// fuzz_config (round-trip property): `.nan`, `.inf` or 1e300 were accepted,
// then written as null into model headers, which then failed to load; a too
// large integer was silently truncated to int.
TEST(FuzzRegressionConfig, NonFiniteAndOutOfRangeNumbersAreErrors) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"points:\n  mean_shift:\n    bandwidth: .nan\n",
       "bad.yaml: 'points.mean_shift.bandwidth' must be a finite number (got '.nan')"},
      {"line_sampling:\n  lsd_scale: -.inf\n",
       "bad.yaml: 'line_sampling.lsd_scale' must be a finite number (got '-.inf')"},
      {"points:\n  max_offset: 1e300\n",
       "bad.yaml: 'points.max_offset' must be a finite number (got '1e300')"},
      // Range is checked where the JSON becomes TrainingParams, which knows
      // each field's type.
      {"lines:\n  trees: 99999999999\n",
       "bad.yaml: training parameters: 'lines.trees' must be an integer from -2147483648 to "
       "2147483647, got 99999999999"},
  };
  for (const auto& [yaml, message] : cases) {
    auto params = parseTrainingParams(yaml, "bad.yaml");
    ASSERT_FALSE(params) << yaml;
    EXPECT_EQ(params.error(), message);
  }
  // The node's `relocalizer:` section goes through the same merge.
  auto merged = mergeYamlOntoJson("solver:\n  inlier_chi2: .inf\n",
                                  relocalizerParamsToJson(RelocalizerParams{}), "node.yaml");
  ASSERT_FALSE(merged);
  EXPECT_EQ(merged.error(), "node.yaml: 'solver.inlier_chi2' must be a finite number (got '.inf')");
  // Limits themselves are fine, and accepted values survive the model header.
  auto edge =
      parseTrainingParams("points:\n  max_depth: 2147483647\n  max_offset: 3.0e38\n", "ok.yaml");
  ASSERT_TRUE(edge) << edge.error();
  EXPECT_EQ(edge->points.max_depth, 2147483647);
  auto again = trainingParamsFromJson(trainingParamsToJson(*edge));
  ASSERT_TRUE(again) << again.error();
  EXPECT_EQ(again->points.max_offset, edge->points.max_offset);
}

}  // namespace
}  // namespace relocalizer

TEST(FuzzRegressions, RelocalizerParametersOutOfRangeAreErrorsNotTruncations) {
  nlohmann::json j = nlohmann::json::parse(relocalizer::relocalizerParamsToJson({}));
  j["point_samples"] = 99999999999LL;
  auto huge = relocalizer::relocalizerParamsFromJson(j.dump());
  ASSERT_FALSE(huge.ok());
  EXPECT_NE(huge.error().find("'point_samples' must be an integer"), std::string::npos)
      << huge.error();
  j = nlohmann::json::parse(relocalizer::relocalizerParamsToJson({}));
  j["solver"]["inlier_chi2"] = 1e300;
  auto far = relocalizer::relocalizerParamsFromJson(j.dump());
  ASSERT_FALSE(far.ok());
  EXPECT_NE(far.error().find("'solver.inlier_chi2' must be a finite number"), std::string::npos)
      << far.error();
}
