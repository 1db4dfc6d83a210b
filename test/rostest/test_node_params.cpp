// Node parameters: config/default.yaml is the compiled defaults, bad values are
// errors that name the parameter, and a node that cannot start says why in one
// line and exits non-zero.

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <sys/stat.h>

#include <array>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <nlohmann/json.hpp>
#include <vector>

#include "../../src/ros/node/node_params.h"
#include "relocalizer/forest/model_io.h"

using relocalizer_ros::loadNodeParams;
using relocalizer_ros::NodeParams;
using relocalizer_ros::nodeParamsToJson;

TEST(NodeParams, DefaultYamlEqualsTheCompiledDefaults) {
  // node_params.test loads config/default.yaml into /configured.
  auto loaded = loadNodeParams(ros::NodeHandle("/configured"));
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  NodeParams defaults;
  defaults.model = loaded->model;
  EXPECT_EQ(nlohmann::json::parse(nodeParamsToJson(*loaded)),
            nlohmann::json::parse(nodeParamsToJson(defaults)));
  // And every key of the file is one the node reads (no stale entries).
  XmlRpc::XmlRpcValue tree;
  ASSERT_TRUE(ros::NodeHandle().getParam("/configured", tree));
  const auto known = nlohmann::json::parse(nodeParamsToJson(defaults));
  for (auto& entry : tree) EXPECT_TRUE(known.contains(entry.first)) << entry.first;
  for (const auto& [key, value] : known.items())
    EXPECT_TRUE(tree.hasMember(key)) << key << " missing from default.yaml";
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

// The learn_* settings reach the learner's submap rule, not only the dump.
TEST(NodeParams, LearnSubmapSettingsReachTheSubmapRule) {
  ros::NodeHandle nh("/learn_override");
  nh.setParam("learn", true);
  nh.setParam("publish_tf", false);
  nh.setParam("learn_cover_steps", 2.0);
  nh.setParam("learn_relearn_agreement", 0.75);
  auto p = loadNodeParams(nh);
  ASSERT_TRUE(p.ok()) << p.error();
  EXPECT_EQ(p->submaps.cover_steps, 2.0);
  EXPECT_EQ(p->submaps.relearn_agreement, 0.75);
}

namespace {

// A `places` entry as rosparam stores a YAML mapping.
XmlRpc::XmlRpcValue placeEntry(
    const std::vector<std::pair<std::string, XmlRpc::XmlRpcValue>>& fields) {
  XmlRpc::XmlRpcValue entry;
  entry.begin();  // an empty struct even without fields
  for (const auto& [key, value] : fields) entry[key] = value;
  return entry;
}

XmlRpc::XmlRpcValue placeList(const std::vector<XmlRpc::XmlRpcValue>& entries) {
  XmlRpc::XmlRpcValue list;
  list.setSize(static_cast<int>(entries.size()));
  for (size_t i = 0; i < entries.size(); ++i) list[static_cast<int>(i)] = entries[i];
  return list;
}

}  // namespace

TEST(NodeParams, PlacesAndTheModelAreTheStartUpPlaces) {
  ros::NodeHandle nh("/places");
  nh.setParam("model", "/models/kitchen.model");
  nh.setParam("map_frame", "building");
  nh.setParam(
      "places",
      placeList(
          {placeEntry({{"name", "lab"}, {"model", "/models/lab.model"}, {"map_frame", "/lab_map"}}),
           placeEntry({{"name", "hall"}, {"model", "hall.model"}})}));
  auto p = loadNodeParams(nh);
  ASSERT_TRUE(p.ok()) << p.error();
  auto places = relocalizer_ros::startupPlaces(*p, p->learn, p->map_frame);
  ASSERT_EQ(places.size(), 3u);
  EXPECT_EQ(places[0].name, "lab");
  EXPECT_EQ(places[0].map_frame, "lab_map");  // leading slash dropped
  EXPECT_EQ(places[1].name, "hall");
  EXPECT_EQ(places[1].model, "hall.model");
  EXPECT_EQ(places[1].map_frame, "building");  // none given: the node's map_frame
  // The model is one more place, named after its file unless place_name says otherwise.
  EXPECT_EQ(places[2].name, "kitchen");
  EXPECT_EQ(places[2].model, "/models/kitchen.model");
  EXPECT_EQ(places[2].map_frame, "building");
  nh.setParam("place_name", "galley");
  p = loadNodeParams(nh);
  ASSERT_TRUE(p.ok()) << p.error();
  EXPECT_EQ(relocalizer_ros::startupPlaces(*p, p->learn, p->map_frame).back().name, "galley");
  // Places alone need no model.
  nh.deleteParam("model");
  p = loadNodeParams(nh);
  ASSERT_TRUE(p.ok()) << p.error();
  EXPECT_EQ(relocalizer_ros::startupPlaces(*p, p->learn, p->map_frame).size(), 2u);
}

TEST(NodeParams, MistakesAreErrorsNamingTheParameter) {
  struct Case {
    std::string ns;
    std::function<void(ros::NodeHandle&)> set;
    std::string error;
  };
  const std::string form = "{name: NAME, model: FILE, map_frame: FRAME (optional)}";
  const std::vector<Case> cases = {
      {"/no_model", [](ros::NodeHandle&) {}, "/no_model/model' is not set"},
      // Malformed places are refused at start, naming the entry and the form expected.
      {"/places_text", [](ros::NodeHandle& nh) { nh.setParam("places", "lab.model"); },
       "parameter '/places_text/places' must be a list of " + form},
      {"/places_entry",
       [](ros::NodeHandle& nh) { nh.setParam("places", placeList({XmlRpc::XmlRpcValue("lab")})); },
       "'/places_entry/places[0]' must be " + form},
      {"/places_no_name",
       [](ros::NodeHandle& nh) {
         nh.setParam("places", placeList({placeEntry({{"model", "lab.model"}})}));
       },
       "'/places_no_name/places[0]' has no name; expected " + form},
      {"/places_no_model",
       [](ros::NodeHandle& nh) {
         nh.setParam("places", placeList({placeEntry({{"name", "lab"}, {"model", "a.model"}}),
                                          placeEntry({{"name", "hall"}})}));
       },
       "'/places_no_model/places[1]' has no model; expected " + form},
      {"/places_twice",
       [](ros::NodeHandle& nh) {
         nh.setParam("places", placeList({placeEntry({{"name", "lab"}, {"model", "a.model"}}),
                                          placeEntry({{"name", "lab"}, {"model", "b.model"}})}));
       },
       "'/places_twice/places[1]' is named 'lab' like places[0]; place names must be unique"},
      {"/places_type",
       [](ros::NodeHandle& nh) {
         nh.setParam("places", placeList({placeEntry({{"name", "lab"}, {"model", 3}})}));
       },
       "'/places_type/places[0]/model' must be a string"},
      {"/places_key",
       [](ros::NodeHandle& nh) {
         nh.setParam(
             "places",
             placeList({placeEntry({{"name", "lab"}, {"model", "a.model"}, {"frame", "lab"}})}));
       },
       "'/places_key/places[0]' has an unknown key 'frame'; expected " + form},
      // The model's place is named after its file (m.bin: m).
      {"/places_clash",
       [](ros::NodeHandle& nh) {
         nh.setParam("places", placeList({placeEntry({{"name", "m"}, {"model", "a.model"}})}));
       },
       "'/places_clash/places[0]' is named 'm' like the place of model m.bin"},
      {"/typo", [](ros::NodeHandle& nh) { nh.setParam("relocalizer/solver/hypothesis", 10); },
       "unknown parameter 'solver.hypothesis'"},
      {"/wrong_type", [](ros::NodeHandle& nh) { nh.setParam("max_rate", "fast"); },
       "/wrong_type/max_rate' has the wrong type"},
      {"/core_type", [](ros::NodeHandle& nh) { nh.setParam("relocalizer/point_samples", "many"); },
       "point_samples' has the wrong type"},
      {"/mode", [](ros::NodeHandle& nh) { nh.setParam("mode", "sometimes"); },
       "expected on_demand or continuous"},
      {"/rate", [](ros::NodeHandle& nh) { nh.setParam("tf_rate", -1.0); },
       "tf_rate' is -1 Hz; it must be 0 (only on updates) or from 0.01 to 1000 Hz"},
      {"/queue", [](ros::NodeHandle& nh) { nh.setParam("sync_queue_size", 0); },
       "sync_queue_size' is 0; it must be an integer from 1 to 2147483647"},
      // Durations and rates that ros::Duration or a chrono period cannot hold
      // aborted the node (issue 23, C2); each has a bound, named in the refusal.
      {"/interval", [](ros::NodeHandle& nh) { nh.setParam("max_interval", 3e9); },
       "parameter '/interval/max_interval' is 3000000000 s; it must be from 0 to 10 s"},
      {"/tf_rate_tiny", [](ros::NodeHandle& nh) { nh.setParam("tf_rate", 1e-10); },
       "parameter '/tf_rate_tiny/tf_rate' is 1e-10 Hz; it must be 0 (only on updates) or from 0.01 "
       "to 1000 Hz"},
      {"/tf_timeout", [](ros::NodeHandle& nh) { nh.setParam("tf_timeout", 3e9); },
       "tf_timeout' is 3000000000 s; it must be from 0 to 10 s"},
      {"/tolerance", [](ros::NodeHandle& nh) { nh.setParam("transform_tolerance", 1e300); },
       "transform_tolerance' is 1e+300 s; it must be from 0 to 10 s"},
      {"/max_rate", [](ros::NodeHandle& nh) { nh.setParam("max_rate", 1e-11); },
       "max_rate' is 1e-11 Hz; it must be 0 (no limit) or from 0.001 to 1000 Hz"},
      {"/service_timeout", [](ros::NodeHandle& nh) { nh.setParam("service_timeout", 61.0); },
       "service_timeout' is 61 s; it must be from 0 to 60 s"},
      {"/input_timeout", [](ros::NodeHandle& nh) { nh.setParam("input_timeout", std::nan("")); },
       "input_timeout' is nan s; it must be from 0 to 3600 s"},
      {"/hint_timeout", [](ros::NodeHandle& nh) { nh.setParam("hint_timeout", 0.0); },
       "hint_timeout' is 0 s; it must be from 0.01 to 3600 s"},
      // Integers beyond XML-RPC's 32 bits arrive as doubles (roscpp's
      // `_key:=99999999999`): out of range, not the wrong type.
      {"/big_queue", [](ros::NodeHandle& nh) { nh.setParam("sync_queue_size", 99999999999.0); },
       "parameter '/big_queue/sync_queue_size' is 99999999999, out of range; it must be an integer "
       "from 1 to "
       "2147483647"},
      {"/half_queue", [](ros::NodeHandle& nh) { nh.setParam("sync_queue_size", 2.5); },
       "sync_queue_size' has the wrong type"},
      {"/big_core",
       [](ros::NodeHandle& nh) { nh.setParam("relocalizer/point_samples", 99999999999.0); },
       "/big_core/relocalizer: relocalizer parameters: 'point_samples' must be an integer from "
       "-2147483648 to "
       "2147483647, got 99999999999"},
      {"/huge_core",
       [](ros::NodeHandle& nh) { nh.setParam("relocalizer/solver/hypotheses", 1e300); },
       "'solver.hypotheses' must be an integer from -2147483648 to 2147483647, got 1e+300"},
      {"/text_core",
       [](ros::NodeHandle& nh) { nh.setParam("relocalizer/point_samples", "99999999999"); },
       "'point_samples' must be an integer from -2147483648 to 2147483647, got 99999999999"},
      {"/frames", [](ros::NodeHandle& nh) { nh.setParam("odom_frame", "map"); },
       "odom_frame' equals map_frame"},
      // Learning from TF the node publishes itself would feed its own answers back.
      {"/learn_tf", [](ros::NodeHandle& nh) { nh.setParam("learn", true); },
       "learn' is true but publish_tf is true"},
      {"/save_no_learn", [](ros::NodeHandle& nh) { nh.setParam("save_on_exit", "/tmp/m.bin"); },
       "save_on_exit' is set but learn is false"},
      {"/motion",
       [](ros::NodeHandle& nh) {
         nh.setParam("learn", true);
         nh.setParam("publish_tf", false);
         nh.setParam("learn_min_motion", "far");
       },
       "learn_min_motion'"},
      {"/cap",
       [](ros::NodeHandle& nh) {
         nh.setParam("learn", true);
         nh.setParam("publish_tf", false);
         nh.setParam("learn_max_keyframes", 1);
       },
       "learn_max_keyframes' is 1; it must be an integer from 2 to 2147483647"},
      // Submaps: each bad value named, with the setting it depends on.
      {"/radius",
       [](ros::NodeHandle& nh) {
         nh.setParam("learn", true);
         nh.setParam("publish_tf", false);
         nh.setParam("learn_submap_radius", 0.0);
       },
       "'/radius/learn_submap_radius' must be a finite distance > 0 metres (got 0.000000)"},
      {"/overlap",
       [](ros::NodeHandle& nh) {
         nh.setParam("learn", true);
         nh.setParam("publish_tf", false);
         nh.setParam("learn_max_keyframes", 4);
       },
       "'/overlap/learn_submap_overlap' must be between 0 and '/overlap/learn_max_keyframes' - 1 "
       "(got 4)"},
      {"/negative_overlap",
       [](ros::NodeHandle& nh) {
         nh.setParam("learn", true);
         nh.setParam("publish_tf", false);
         nh.setParam("learn_submap_overlap", -1);
       },
       "learn_submap_overlap' is -1; it must be an integer from 0 to 2147483647"},
      {"/cover",
       [](ros::NodeHandle& nh) {
         nh.setParam("learn", true);
         nh.setParam("publish_tf", false);
         nh.setParam("learn_cover_steps", std::nan(""));
       },
       "'/cover/learn_cover_steps' must be finite and >= 0 (got nan)"},
      {"/cover_type",
       [](ros::NodeHandle& nh) {
         nh.setParam("learn", true);
         nh.setParam("publish_tf", false);
         nh.setParam("learn_cover_steps", "one");
       },
       "learn_cover_steps' has the wrong type"},
      {"/relearn",
       [](ros::NodeHandle& nh) {
         nh.setParam("learn", true);
         nh.setParam("publish_tf", false);
         nh.setParam("learn_relearn_agreement", 1.5);
       },
       "'/relearn/learn_relearn_agreement' must be a share between 0 and 1 (got 1.500000)"},
      {"/submap_name",
       [](ros::NodeHandle& nh) {
         nh.setParam("learn", true);
         nh.setParam("publish_tf", false);
         nh.setParam("places",
                     placeList({placeEntry({{"name", "learned/2"}, {"model", "a.model"}})}));
       },
       "is named 'learned/2' like the place of learning (or its submaps, learned/i)"},
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

namespace {

struct NodeRun {
  int status = -1;
  std::string output;
};

// Runs relocalizer_node on `model` with extra `arguments` until it exits (it
// must: the model or a parameter is bad). A node that starts anyway is stopped
// after 20 s: exit status 124.
NodeRun runNodeWithModel(const std::string& model, const std::string& arguments = "",
                         const std::string& name = "broken") {
  NodeRun run;
  const std::string command = "timeout 20 " + std::string(RELOCALIZER_NODE_PATH) +
                              " __name:=" + name + " _model:='" + model + "' " + arguments +
                              " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return run;
  std::array<char, 256> buffer{};
  while (fgets(buffer.data(), buffer.size(), pipe)) run.output += buffer.data();
  run.status = pclose(pipe);
  return run;
}

std::vector<uint8_t> readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void writeBytes(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

}  // namespace

// Places that do not load are logged while another one works; when none
// loads, the node stops with every reason in its one line.
TEST(NodeParams, NodeWhosePlacesAllFailExitsNonZeroNamingEach) {
  ros::NodeHandle("/no_places")
      .setParam("places",
                placeList({placeEntry({{"name", "lab"}, {"model", "/nonexistent/lab.model"}}),
                           placeEntry({{"name", "hall"}, {"model", "/nonexistent/hall.model"}})}));
  const NodeRun run = runNodeWithModel("", "", "no_places");
  ASSERT_TRUE(WIFEXITED(run.status)) << run.output;
  EXPECT_EQ(WEXITSTATUS(run.status), 1) << run.output;
  EXPECT_NE(run.output.find("lab"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("/nonexistent/lab.model: cannot open model file"), std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find("/nonexistent/hall.model: cannot open model file"), std::string::npos)
      << run.output;
  EXPECT_EQ(std::count(run.output.begin(), run.output.end(), '\n'), 1) << run.output;
}

TEST(NodeParams, NodeWithAnUnreadableModelExitsNonZeroWithOneLine) {
  const NodeRun run = runNodeWithModel("/nonexistent/model.bin");
  EXPECT_TRUE(WIFEXITED(run.status));
  EXPECT_EQ(WEXITSTATUS(run.status), 1);
  EXPECT_NE(run.output.find("/nonexistent/model.bin: cannot open model file"), std::string::npos)
      << run.output;
  EXPECT_EQ(std::count(run.output.begin(), run.output.end(), '\n'), 1) << run.output;
}

// Issue 23, C2: these aborted the node with SIGABRT ("Duration is out of dual
// 32-bit range") at start-up, or, tf_timeout in learn mode, on the first frame,
// without naming the parameter. The model is good, so only the parameter can
// stop the node; roscpp stores `_key:=3e9` as a double, as a user's would be.
// `_key:=` parameters stay on the master after the node exits, so each case
// runs under its own node name.
TEST(NodeParams, DurationsBeyondRosDurationStopTheNodeNamingTheParameter) {
  std::string fixture;
  ASSERT_TRUE(ros::NodeHandle("~").getParam("fixture", fixture));
  const std::string good = fixture + "/model.bin";
  struct Case {
    std::string name;
    std::string arguments;
    std::string reason;
    std::string model;
  };
  const std::vector<Case> cases = {
      {"interval", "_max_interval:=3e9",
       "parameter '/interval/max_interval' is 3000000000 s; it must be from 0 to 10 s", good},
      {"tf_rate", "_tf_rate:=1e-10 _odom_frame:=odom",
       "parameter '/tf_rate/tf_rate' is 1e-10 Hz; it must be 0 (only on updates) or from 0.01 to "
       "1000 Hz",
       good},
      {"max_rate", "_max_rate:=1e-11 _mode:=continuous",
       "parameter '/max_rate/max_rate' is 1e-11 Hz; it must be 0 (no limit) or from 0.001 to 1000 "
       "Hz",
       good},
      // Learning from nothing, without a model.
      {"learn_tf_timeout", "_learn:=true _publish_tf:=false _tf_timeout:=3e9",
       "parameter '/learn_tf_timeout/tf_timeout' is 3000000000 s; it must be from 0 to 10 s", ""},
      {"point_samples", "_relocalizer/point_samples:=99999999999",
       "/point_samples/relocalizer: relocalizer parameters: 'point_samples' must be an integer "
       "from -2147483648 to "
       "2147483647, got 99999999999",
       good},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.arguments);
    const NodeRun run = runNodeWithModel(c.model, c.arguments, c.name);
    // Through `timeout`, a signal shows as 128 + its number (134: SIGABRT)
    // and a node that kept running as 124.
    ASSERT_TRUE(WIFEXITED(run.status)) << run.output;
    EXPECT_EQ(WEXITSTATUS(run.status), 1) << run.output;
    EXPECT_NE(run.output.find("relocalizer: " + c.reason), std::string::npos) << run.output;
    EXPECT_EQ(std::count(run.output.begin(), run.output.end(), '\n'), 1) << run.output;
  }
}

// Every kind of bad model file, made here from the fixture's good model: the
// node exits with code 1 (no signal: no crash) and one line naming the file
// and the reason.
TEST(NodeParams, BadModelFilesStopTheNodeWithTheirReason) {
  std::string fixture;
  ASSERT_TRUE(ros::NodeHandle("~").getParam("fixture", fixture));
  const std::vector<uint8_t> good = readBytes(fixture + "/model.bin");
  ASSERT_GT(good.size(), 64u);
  char dir_template[] = "/tmp/relocalizer_bad_models_XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::string dir = dir_template;

  struct Case {
    std::string name;
    std::vector<uint8_t> bytes;  // written to dir/name unless a path is given
    std::string reason;
    std::string path = "";
  };
  auto with = [&good](const std::function<void(std::vector<uint8_t>&)>& change) {
    std::vector<uint8_t> bytes = good;
    change(bytes);
    return bytes;
  };
  const uint64_t body =
      good.size() - 28;  // preamble: magic 8, version 4, reserved 4, length 8, CRC 4
  std::vector<Case> cases = {
      {"truncated.bin", with([](auto& b) { b.resize(b.size() / 2); }),
       "truncated model file (" + std::to_string(good.size() / 2 - 28) + " of " +
           std::to_string(body) + " body bytes present)"},
      {"truncated_preamble.bin", with([](auto& b) { b.resize(20); }),
       "truncated model file (header incomplete)"},
      {"wrong_magic.bin", with([](auto& b) { std::memcpy(b.data(), "PLTREES!", 8); }),
       "not a relocalizer model (wrong magic number; expected a file written by `train`)"},
      {"future_version.bin",
       with([](auto& b) { b[8] = static_cast<uint8_t>(relocalizer::kModelFormatVersion + 1); }),
       "model format version " + std::to_string(relocalizer::kModelFormatVersion + 1) +
           " is not supported (this build reads versions 1 to " +
           std::to_string(relocalizer::kModelFormatVersion) + "); retrain or use a matching build"},
      {"checksum.bin", with([](auto& b) { b[b.size() - 7] ^= 0x40; }),
       "checksum mismatch: the model file is corrupt"},
      {"empty.bin", {}, "model file is empty"},
      // Files a user might pass by mistake: the bag, the node's YAML.
      {"bag",
       {},
       "not a relocalizer model (wrong magic number; expected a file written by `train`)",
       fixture + "/test.bag"},
      {"yaml",
       {},
       "not a relocalizer model (wrong magic number; expected a file written by `train`)",
       ros::param::param<std::string>("~config", "")},
  };
  // A folder that is not a saved set of submaps (the loader would see a size
  // near 2^63) and a FIFO (it would block start-up): refused before loading.
  ASSERT_TRUE(std::filesystem::create_directory(dir + "/model_folder"));
  ASSERT_EQ(mkfifo((dir + "/model_fifo").c_str(), 0600), 0);
  cases.push_back({"folder",
                   {},
                   "is a directory, not a model file nor a folder of learned submaps (it has no "
                   "manifest.json)",
                   dir + "/model_folder"});
  cases.push_back({"fifo",
                   {},
                   "is not a regular file (a device or a pipe?), not a model file",
                   dir + "/model_fifo"});
  for (Case& c : cases) {
    SCOPED_TRACE(c.name);
    if (c.path.empty()) {
      c.path = dir + "/" + c.name;
      writeBytes(c.path, c.bytes);
    }
    const NodeRun run = runNodeWithModel(c.path);
    ASSERT_TRUE(WIFEXITED(run.status)) << "killed by a signal: " << run.output;
    EXPECT_EQ(WEXITSTATUS(run.status), 1);
    // The model is the one place: its error (naming the place) is the line.
    EXPECT_NE(run.output.find("relocalizer: "), std::string::npos) << run.output;
    EXPECT_NE(run.output.find(c.path + ": " + c.reason), std::string::npos) << run.output;
    EXPECT_EQ(std::count(run.output.begin(), run.output.end(), '\n'), 1) << run.output;
  }
  std::filesystem::remove_all(dir);
}

// Issue 38, S1 for save_on_exit: ~save_model was confined to save_model_folder
// but the exit's save was not: the node learned, and at shutdown wrote its
// files into any folder (a stand-in for /etc/cron.d here). Refused at start-up.
TEST(NodeParams, SaveOnExitOutsideTheSaveFolderStopsTheNodeAtStartUp) {
  char dir_template[] = "/tmp/relocalizer_save_on_exit_XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::string dir = dir_template;
  const std::string cron = dir + "/cron.d";
  ASSERT_TRUE(std::filesystem::create_directory(cron));
  writeBytes(cron + "/job", {'#', '\n'});
  for (const std::string target : {cron, cron + "/new", std::string("../cron.d")}) {
    SCOPED_TRACE(target);
    const NodeRun run =
        runNodeWithModel("",
                         "_learn:=true _publish_tf:=false _save_model_folder:=" + dir +
                             "/saves _save_on_exit:=" + target,
                         "save_outside");
    ASSERT_TRUE(WIFEXITED(run.status)) << run.output;
    EXPECT_EQ(WEXITSTATUS(run.status), 1) << run.output;
    EXPECT_NE(run.output.find("relocalizer: save_on_exit: "), std::string::npos) << run.output;
    EXPECT_NE(run.output.find("not inside the save folder " + dir + "/saves"), std::string::npos)
        << run.output;
    EXPECT_EQ(std::distance(std::filesystem::directory_iterator(cron),
                            std::filesystem::directory_iterator()),
              1)
        << "written into " << cron;
  }
  std::filesystem::remove_all(dir);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_params");
  return RUN_ALL_TESTS();
}
