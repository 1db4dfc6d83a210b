// Node parameters: config/default.yaml is the compiled defaults, bad values are
// errors that name the parameter, and a node that cannot start says why in one
// line and exits non-zero.

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <array>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "../../src/ros/node_params.h"

using relocalizer_ros::loadNodeParams;
using relocalizer_ros::NodeParams;
using relocalizer_ros::nodeParamsToJson;

TEST(NodeParams, DefaultYamlEqualsTheCompiledDefaults) {
  // node_params.test loads config/default.yaml into /configured.
  auto loaded = loadNodeParams(ros::NodeHandle("/configured"));
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  NodeParams defaults;
  defaults.model = loaded->model;
  EXPECT_EQ(nlohmann::json::parse(nodeParamsToJson(*loaded)), nlohmann::json::parse(nodeParamsToJson(defaults)));
  // And every key of the file is one the node reads (no stale entries).
  XmlRpc::XmlRpcValue tree;
  ASSERT_TRUE(ros::NodeHandle().getParam("/configured", tree));
  const auto known = nlohmann::json::parse(nodeParamsToJson(defaults));
  for (auto& entry : tree) EXPECT_TRUE(known.contains(entry.first)) << entry.first;
  for (const auto& [key, value] : known.items()) EXPECT_TRUE(tree.hasMember(key)) << key << " missing from default.yaml";
}

TEST(NodeParams, OverridesReachTheCoreAndFramesLoseLeadingSlashes) {
  ros::NodeHandle nh("/override");
  nh.setParam("model", "m.bin");
  nh.setParam("mode", "continuous");
  nh.setParam("map_frame", "/world");
  nh.setParam("odom_frame", "//odom");
  nh.setParam("max_rate", 5);  // an int where a double is expected is fine
  nh.setParam("relocalizer/solver/hypotheses", 256);
  nh.setParam("relocalizer/use_lines", false);
  auto p = loadNodeParams(nh);
  ASSERT_TRUE(p.ok()) << p.error();
  EXPECT_EQ(p->mode, relocalizer_ros::Mode::Continuous);
  EXPECT_EQ(p->map_frame, "world");
  EXPECT_EQ(p->odom_frame, "odom");
  EXPECT_EQ(p->max_rate, 5.0);
  EXPECT_EQ(p->relocalizer.solver.hypotheses, 256);
  EXPECT_FALSE(p->relocalizer.use_lines);
  EXPECT_EQ(p->relocalizer.point_samples, relocalizer::RelocalizerParams{}.point_samples);
}

TEST(NodeParams, MistakesAreErrorsNamingTheParameter) {
  struct Case {
    std::string ns;
    std::function<void(ros::NodeHandle&)> set;
    std::string error;
  };
  const std::vector<Case> cases = {
      {"/no_model", [](ros::NodeHandle&) {}, "/no_model/model' is not set"},
      {"/typo", [](ros::NodeHandle& nh) { nh.setParam("relocalizer/solver/hypothesis", 10); },
       "unknown parameter 'solver.hypothesis'"},
      {"/wrong_type", [](ros::NodeHandle& nh) { nh.setParam("max_rate", "fast"); },
       "/wrong_type/max_rate' has the wrong type"},
      {"/core_type", [](ros::NodeHandle& nh) { nh.setParam("relocalizer/point_samples", "many"); },
       "point_samples' has the wrong type"},
      {"/mode", [](ros::NodeHandle& nh) { nh.setParam("mode", "sometimes"); }, "expected on_demand or continuous"},
      {"/rate", [](ros::NodeHandle& nh) { nh.setParam("tf_rate", -1.0); }, "tf_rate' must be finite and not negative"},
      {"/queue", [](ros::NodeHandle& nh) { nh.setParam("sync_queue_size", 0); }, "sync_queue_size' must be at least 1"},
      {"/frames", [](ros::NodeHandle& nh) { nh.setParam("odom_frame", "map"); }, "odom_frame' equals map_frame"},
  };
  for (const Case& c : cases) {
    ros::NodeHandle nh(c.ns);
    if (c.ns != "/no_model") nh.setParam("model", "m.bin");
    c.set(nh);
    auto p = loadNodeParams(nh);
    ASSERT_FALSE(p.ok()) << c.ns;
    EXPECT_NE(p.error().find(c.error), std::string::npos) << c.ns << ": " << p.error();
  }
}

TEST(NodeParams, NodeWithAnUnreadableModelExitsNonZeroWithOneLine) {
  const std::string command = std::string(RELOCALIZER_NODE_PATH) +
                              " __name:=broken _model:=/nonexistent/model.bin 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string output;
  std::array<char, 256> buffer{};
  while (fgets(buffer.data(), buffer.size(), pipe)) output += buffer.data();
  const int status = pclose(pipe);
  EXPECT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);
  EXPECT_NE(output.find("/nonexistent/model.bin"), std::string::npos) << output;
  EXPECT_EQ(std::count(output.begin(), output.end(), '\n'), 1) << output;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_params");
  return RUN_ALL_TESTS();
}
