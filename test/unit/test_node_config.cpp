// config/default.yaml's `relocalizer:` section is the node's copy of the core's
// defaults; it must hold every key, and the same values, as RelocalizerParams{}.

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "relocalizer/relocalize/relocalizer.h"

using nlohmann::json;

namespace {

// Compares a YAML tree with the JSON of the compiled defaults, key by key.
void expectSame(const YAML::Node& yaml, const json& expected, const std::string& path) {
  if (expected.is_object()) {
    ASSERT_TRUE(yaml.IsMap()) << path << " should be a mapping";
    for (const auto& [key, value] : expected.items()) {
      ASSERT_TRUE(yaml[key]) << path + key << " is missing from config/default.yaml";
      expectSame(yaml[key], value, path + key + ".");
    }
    for (const auto& entry : yaml)
      EXPECT_TRUE(expected.contains(entry.first.as<std::string>()))
          << path + entry.first.as<std::string>() << " is not a relocalizer parameter";
    return;
  }
  if (expected.is_boolean()) {
    EXPECT_EQ(yaml.as<bool>(), expected.get<bool>()) << path;
  } else if (expected.is_number_integer()) {
    EXPECT_EQ(yaml.as<long long>(), expected.get<long long>()) << path;
  } else {
    // Floats in the core are single precision: 0.15f is 0.15000000596 in JSON.
    const double want = expected.get<double>();
    EXPECT_NEAR(yaml.as<double>(), want, 1e-6 * std::max(1.0, std::abs(want))) << path;
  }
}

}  // namespace

TEST(NodeConfig, RelocalizerSectionEqualsTheCompiledDefaults) {
  const YAML::Node root =
      YAML::LoadFile(std::string(RELOCALIZER_SOURCE_DIR) + "/config/default.yaml");
  ASSERT_TRUE(root["relocalizer"]) << "config/default.yaml has no relocalizer: section";
  expectSame(root["relocalizer"], json::parse(relocalizer::relocalizerParamsToJson({})),
             "relocalizer.");
}

TEST(NodeConfig, TheCoreReaderAcceptsTheFile) {
  auto params = relocalizer::loadRelocalizerParams(std::string(RELOCALIZER_SOURCE_DIR) +
                                                   "/config/default.yaml");
  ASSERT_TRUE(params.ok()) << params.error();
  EXPECT_EQ(json::parse(relocalizer::relocalizerParamsToJson(*params)),
            json::parse(relocalizer::relocalizerParamsToJson({})));
}

// The preset the README uses to compare with published numbers switches the
// surface stage off and nothing else.
TEST(NodeConfig, SurfaceOffPresetChangesOnlyTheSurfaceSwitch) {
  auto params = relocalizer::loadRelocalizerParams(std::string(RELOCALIZER_SOURCE_DIR) +
                                                   "/config/surface_off.yaml");
  ASSERT_TRUE(params.ok()) << params.error();
  EXPECT_FALSE(params->surface.enabled);
  relocalizer::RelocalizerParams expected;
  expected.surface.enabled = false;
  EXPECT_EQ(json::parse(relocalizer::relocalizerParamsToJson(*params)),
            json::parse(relocalizer::relocalizerParamsToJson(expected)));
}
