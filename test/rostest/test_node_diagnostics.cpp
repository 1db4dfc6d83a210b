// /diagnostics (issue 27) from three nodes (diagnostics.test): OK after
// answers on the fixture model, WARN when answers keep failing and when the
// inputs stop, ERROR when the only place is unloaded and when learning has no
// model yet, and a status per place while a node holds two.

#include <diagnostic_msgs/DiagnosticArray.h>
#include <relocalizer/LoadPlace.h>
#include <relocalizer/UnloadPlace.h>

#include <algorithm>
#include <atomic>
#include <optional>
#include <thread>

#include "../../src/ros/node/node_params.h"
#include "node_test_support.h"

using namespace relocalizer_test;
using diagnostic_msgs::DiagnosticArray;
using diagnostic_msgs::DiagnosticStatus;

namespace {

std::vector<FrameMessages>* g_frames = nullptr;
CameraPublisher* g_camera = nullptr;
Listener<DiagnosticArray>* g_diagnostics = nullptr;

constexpr const char* kNode = "relocalizer: relocalization";
constexpr const char* kPlacesNode = "places_node: relocalization";
// Long enough for a loaded machine: statuses come every 0.25 s.
constexpr double kWait = 30.0;

std::optional<std::string> value(const DiagnosticStatus& status, const std::string& key) {
  for (const auto& pair : status.values)
    if (pair.key == key) return pair.value;
  return std::nullopt;
}

const DiagnosticStatus* find(const DiagnosticArray& array, const std::string& name) {
  for (const DiagnosticStatus& status : array.status)
    if (status.name == name) return &status;
  return nullptr;
}

// The first array (from now on) holding a status `name` that matches.
std::optional<DiagnosticArray> waitForStatus(
    const std::string& name, const std::function<bool(const DiagnosticStatus&)>& match,
    double seconds = kWait) {
  return g_diagnostics->waitFor(
      [&](const DiagnosticArray& array) {
        const DiagnosticStatus* status = find(array, name);
        return status && match(*status);
      },
      seconds);
}

double number(const DiagnosticStatus& status, const std::string& key) {
  const auto text = value(status, key);
  EXPECT_TRUE(text.has_value()) << status.name << " has no '" << key << "'";
  return text ? std::stod(*text) : -1.0;
}

// Publishes `frame` restamped at 10 Hz while it lives.
class Stream {
 public:
  explicit Stream(FrameMessages frame)
      : thread_([this, frame]() mutable {
          while (!done_ && ros::ok()) {
            frame.stamp(ros::Time::now());
            g_camera->publish(frame);
            ros::WallDuration(0.1).sleep();
          }
        }) {}
  ~Stream() {
    done_ = true;
    thread_.join();
  }

 private:
  std::atomic<bool> done_{false};
  std::thread thread_;
};

relocalizer::Relocalize::Response relocalize(const std::string& node) {
  relocalizer::Relocalize srv;
  srv.request.timeout = 5.0;
  srv.request.wait_for_next = true;
  EXPECT_TRUE(ros::service::call("/" + node + "/relocalize", srv)) << node;
  return srv.response;
}

// The fixture frame with no valid depth: an answer that fails every time.
FrameMessages withoutDepth(FrameMessages frame) {
  std::fill(frame.depth.data.begin(), frame.depth.data.end(), 0);
  return frame;
}

}  // namespace

TEST(Diagnostics, AnswersOnTheFixtureModelAreOk) {
  for (const char* node : {"relocalizer", "places_node", "learner"})
    ASSERT_TRUE(
        ros::service::waitForService(std::string("/") + node + "/relocalize", ros::Duration(60)))
        << node;
  ASSERT_TRUE(g_camera->waitForNode());
  Stream stream((*g_frames)[2]);
  const auto answer = relocalize("relocalizer");
  ASSERT_TRUE(answer.success) << answer.message;

  g_diagnostics->clear();
  const auto array = waitForStatus(kNode, [](const DiagnosticStatus& s) {
    return s.level == DiagnosticStatus::OK && value(s, "last pose age (s)") != "none yet";
  });
  ASSERT_TRUE(array) << "no OK status after an answer";
  const DiagnosticStatus& status = *find(*array, kNode);
  EXPECT_EQ(status.hardware_id, "relocalizer: /relocalizer");
  EXPECT_TRUE(contains(status.message, "last pose")) << status.message;
  EXPECT_EQ(value(status, "places"), "model (map)");
  EXPECT_EQ(value(status, "last pose place"), "model");
  EXPECT_EQ(value(status, "mode"), "on_demand");
  EXPECT_LT(number(status, "last pose age (s)"), kWait);
  EXPECT_GE(number(status, "frames processed"), 1.0);
  EXPECT_LT(number(status, "last frame age (s)"), 1.0);
  // One place: the node's status only.
  EXPECT_EQ(array->status.size(), 1u);
  // 10 Hz sent; a loaded machine delivers fewer, but some on every topic, and
  // the rates span seconds, so they include the time before the stream began.
  EXPECT_TRUE(waitForStatus(kNode, [](const DiagnosticStatus& s) {
    for (const char* topic :
         {"/camera/rgb/image_raw", "/camera/depth/image_raw", "/camera/rgb/camera_info"}) {
      const auto rate = value(s, std::string("input rate ") + topic + " (Hz)");
      if (!rate || std::stod(*rate) < 2.0 || std::stod(*rate) > 20.0) return false;
    }
    return true;
  })) << "no status with every input rate near the 10 Hz sent";
  // And no ERROR since the answer.
  for (const DiagnosticArray& seen : g_diagnostics->messages())
    if (const DiagnosticStatus* s = find(seen, kNode)) {
      EXPECT_NE(s->level, DiagnosticStatus::ERROR) << s->message;
    }
}

TEST(Diagnostics, AnswersThatKeepFailingWarnWithTheReason) {
  std::string reason;
  {
    // Frames keep coming (stopped inputs would be named first).
    Stream stream(withoutDepth((*g_frames)[2]));
    // diagnostics.test: diagnostics_max_failures 3.
    for (int i = 0; i < 3; ++i) {
      const auto answer = relocalize("relocalizer");
      ASSERT_FALSE(answer.success);
      reason = answer.message;
      if (i < 2) {
        g_diagnostics->clear();
        const auto array = waitForStatus(kNode, [&](const DiagnosticStatus& s) {
          return value(s, "failures in a row") == std::to_string(i + 1);
        });
        ASSERT_TRUE(array);
        EXPECT_EQ(find(*array, kNode)->level, DiagnosticStatus::OK) << i + 1 << " failures";
      }
    }
    const auto warned = waitForStatus(kNode, [](const DiagnosticStatus& s) {
      return s.level == DiagnosticStatus::WARN && contains(s.message, "frames in a row");
    });
    ASSERT_TRUE(warned) << "no WARN after 3 failures in a row";
    const DiagnosticStatus& status = *find(*warned, kNode);
    EXPECT_EQ(status.message, "3 frames in a row without a pose: " + reason);
    EXPECT_EQ(value(status, "last failure"), reason);
    EXPECT_EQ(value(status, "failures in a row"), "3");
  }

  // One answer ends it.
  Stream stream((*g_frames)[2]);
  const auto answer = relocalize("relocalizer");
  ASSERT_TRUE(answer.success) << answer.message;
  g_diagnostics->clear();
  EXPECT_TRUE(waitForStatus(kNode, [](const DiagnosticStatus& s) {
    return s.level == DiagnosticStatus::OK && value(s, "failures in a row") == "0";
  }));
}

TEST(Diagnostics, InputsThatStopWarn) {
  {
    Stream stream((*g_frames)[2]);
    ASSERT_TRUE(waitForStatus(
        kNode, [](const DiagnosticStatus& s) { return s.level == DiagnosticStatus::OK; }));
  }
  g_diagnostics->clear();
  // diagnostics.test: input_timeout 1 s.
  const auto warned = waitForStatus(kNode, [](const DiagnosticStatus& s) {
    return s.level == DiagnosticStatus::WARN && contains(s.message, "inputs stopped");
  });
  ASSERT_TRUE(warned) << "no WARN after the frames stopped";
  const DiagnosticStatus& status = *find(*warned, kNode);
  EXPECT_TRUE(contains(status.message, "(input_timeout 1.00 s)")) << status.message;
  EXPECT_GE(number(status, "last frame age (s)"), 1.0);
  // Once the rates' window holds only the silence.
  EXPECT_TRUE(waitForStatus(kNode, [](const DiagnosticStatus& s) {
    return value(s, "input rate /camera/rgb/image_raw (Hz)") == "0.00" &&
           value(s, "input rate /camera/depth/image_raw (Hz)") == "0.00";
  }));
}

TEST(Diagnostics, UnloadingTheOnlyPlaceIsAnError) {
  relocalizer::UnloadPlace unload;
  unload.request.name = "model";  // model.bin's stem
  ASSERT_TRUE(ros::service::call("/relocalizer/unload_place", unload));
  ASSERT_TRUE(unload.response.success) << unload.response.message;
  const auto failed = waitForStatus(
      kNode, [](const DiagnosticStatus& s) { return s.level == DiagnosticStatus::ERROR; });
  ASSERT_TRUE(failed) << "no ERROR without a place";
  const DiagnosticStatus& status = *find(*failed, kNode);
  EXPECT_EQ(status.message, "no usable place: no place loaded (load one with ~load_place)");
  EXPECT_EQ(value(status, "places"), "none");

  std::string fixture;
  ros::NodeHandle("~").getParam("fixture", fixture);
  relocalizer::LoadPlace load;
  load.request.name = "model";
  load.request.model = fixture + "/model.bin";
  ASSERT_TRUE(ros::service::call("/relocalizer/load_place", load));
  ASSERT_TRUE(load.response.success) << load.response.message;
  g_diagnostics->clear();
  // The place is back (the inputs are still stopped: WARN, not ERROR).
  EXPECT_TRUE(waitForStatus(kNode, [](const DiagnosticStatus& s) {
    return s.level == DiagnosticStatus::WARN && value(s, "places") == "model (map)";
  }));
}

TEST(Diagnostics, LearningWithoutAModelIsAnError) {
  const auto array =
      waitForStatus("learner: relocalization", [](const DiagnosticStatus&) { return true; });
  ASSERT_TRUE(array);
  const DiagnosticStatus& status = *find(*array, "learner: relocalization");
  EXPECT_EQ(status.level, DiagnosticStatus::ERROR);
  EXPECT_TRUE(contains(status.message, "no usable place: no model yet")) << status.message;
  EXPECT_EQ(value(status, "submaps"), "0");
  EXPECT_EQ(value(status, "key frames stored"), "0");
  EXPECT_EQ(value(status, "learning backlog"), "0");
  EXPECT_EQ(value(status, "places"), "none");
}

TEST(Diagnostics, EachPlaceHasAStatusWhileTheNodeHoldsSeveral) {
  {
    Stream stream((*g_frames)[2]);  // the first room: place room1
    const auto answer = relocalize("places_node");
    ASSERT_TRUE(answer.success) << answer.message;
    EXPECT_EQ(answer.place, "room1");
  }
  g_diagnostics->clear();
  const auto array = waitForStatus("places_node: place room1", [](const DiagnosticStatus& s) {
    return value(s, "poses") == "1";
  });
  ASSERT_TRUE(array) << "no status of place room1 with its pose";
  const DiagnosticStatus* room1 = find(*array, "places_node: place room1");
  const DiagnosticStatus* room2 = find(*array, "places_node: place room2");
  const DiagnosticStatus* node = find(*array, kPlacesNode);
  ASSERT_TRUE(room2 && node);
  EXPECT_EQ(array->status.size(), 3u);
  EXPECT_EQ(room1->level, DiagnosticStatus::OK);
  EXPECT_EQ(value(*room1, "map frame"), "room1_map");
  EXPECT_GE(number(*room1, "frames screened"), 1.0);
  EXPECT_LT(number(*room1, "last pose age (s)"), kWait);
  EXPECT_EQ(room2->level, DiagnosticStatus::OK);
  EXPECT_EQ(room2->message, "loaded, no pose from it yet");
  EXPECT_EQ(value(*room2, "poses"), "0");
  EXPECT_EQ(value(*room2, "map frame"), "room2_map");
  EXPECT_EQ(value(*node, "places"), "room1 (room1_map), room2 (room2_map)");
  EXPECT_EQ(value(*node, "last pose place"), "room1");
  EXPECT_EQ(room1->hardware_id, "relocalizer: /places_node");

  // One place left: the node's status says it, and the place statuses go.
  relocalizer::UnloadPlace unload;
  unload.request.name = "room2";
  ASSERT_TRUE(ros::service::call("/places_node/unload_place", unload));
  ASSERT_TRUE(unload.response.success) << unload.response.message;
  const auto after = waitForStatus(kPlacesNode, [](const DiagnosticStatus& s) {
    return value(s, "places") == "room1 (room1_map)";
  });
  ASSERT_TRUE(after);
  EXPECT_EQ(after->status.size(), 1u);
}

TEST(Diagnostics, ThresholdsOutOfRangeAreErrorsNamingThem) {
  ros::NodeHandle nh("/diagnostics_params");
  nh.setParam("model", "m.bin");
  nh.setParam("diagnostic_period", 0.0);
  auto params = relocalizer_ros::loadNodeParams(nh);
  ASSERT_FALSE(params.ok());
  EXPECT_EQ(
      params.error(),
      "parameter '/diagnostics_params/diagnostic_period' is 0 s; it must be from 0.1 to 60 s");
  nh.setParam("diagnostic_period", 0.5);
  nh.setParam("diagnostics_max_failures", -1);
  params = relocalizer_ros::loadNodeParams(nh);
  ASSERT_FALSE(params.ok());
  EXPECT_EQ(params.error(),
            "parameter '/diagnostics_params/diagnostics_max_failures' is -1; it must be an integer "
            "from 0 to 2147483647");
  nh.setParam("diagnostics_max_failures", 0);
  params = relocalizer_ros::loadNodeParams(nh);
  ASSERT_TRUE(params.ok()) << params.error();
  EXPECT_EQ(params->diagnostic_period, 0.5);
  EXPECT_EQ(params->diagnostics_max_failures, 0);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_diagnostics");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  std::vector<FrameMessages> frames = loadFixtureFrames();
  CameraPublisher camera;
  Listener<DiagnosticArray> diagnostics("/diagnostics", 1000);
  g_frames = &frames;
  g_camera = &camera;
  g_diagnostics = &diagnostics;
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
