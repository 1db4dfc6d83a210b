#include "support.h"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iterator>

#include "relocalizer/eval/metrics.h"
#include "relocalizer/sim/synthetic_scene.h"

namespace relocalizer::testing {

TrainingParams smallRoomTraining() {
  TrainingParams training;
  for (ForestParams* f : {&training.points, &training.lines}) {
    f->trees = 3;
    f->max_depth = 16;
    f->samples_per_image = 800;
  }
  return training;
}

RelocalizerParams smallRoomRelocalizer() {
  RelocalizerParams params;
  params.point_samples = 800;
  params.line_samples = 400;
  return params;
}

LearningParams onlineRoomLearning() {
  LearningParams p;
  p.training = smallRoomTraining();
  for (ForestParams* f : {&p.training.points, &p.training.lines}) f->samples_per_image = 1000;
  return p;
}

RelocalizerParams onlineRoomRelocalizer() {
  RelocalizerParams r = smallRoomRelocalizer();
  r.point_samples = 1000;
  r.line_samples = 500;
  r.solver.hypotheses = 256;
  return r;
}

RoomWalk submapRoomWalk() {
  const CameraIntrinsics camera = CameraIntrinsics::kinectDefault().scaledTo(320, 240);
  SyntheticRoom room(7);
  const SyntheticTrajectories paths = room.trajectories(80, 20);
  RoomWalk walk;
  for (size_t i = 0; i < paths.train.size(); i += 4)
    walk.learn.push_back(room.render(paths.train[i], camera, static_cast<int>(i)));
  for (size_t i = 0; i < paths.test.size(); ++i)
    walk.test.push_back(room.render(paths.test[i], camera, static_cast<int>(100 + i)));
  return walk;
}

bool correctPose(const Relocalization& answer, const RgbdFrame& frame) {
  return answer.success &&
         within(frameError(frame.id, answer.pose, *frame.ground_truth), kCorrectPose);
}

TempDir::TempDir(const std::string& prefix) {
  static std::atomic<int> counter{0};
  const auto now = std::chrono::steady_clock::now().time_since_epoch().count();
  path_ = std::filesystem::temp_directory_path() /
          (prefix + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + "_" +
           std::to_string(now));
  std::filesystem::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ignored;
  std::filesystem::remove_all(path_, ignored);
}

std::string redkitchenDir() {
  const std::filesystem::path dir = std::filesystem::path(RELOCALIZER_SOURCE_DIR) / ".." /
                                    "shared" / "data" / "7scenes-redkitchen-dev";
  if (std::filesystem::exists(dir / "frame-000000.pose.txt"))
    return std::filesystem::canonical(dir).string();
  return {};
}

bool sameImage(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() &&
         std::equal(a.datastart, a.dataend, b.datastart, b.dataend);
}

std::string readBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::map<std::string, std::string> readTree(const std::filesystem::path& root) {
  std::map<std::string, std::string> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(root))
    if (entry.is_regular_file())
      files[std::filesystem::relative(entry.path(), root).string()] = readBytes(entry.path());
  return files;
}

int runTool(const std::string& tool, const std::string& arguments,
            const std::filesystem::path& stderr_file, const std::filesystem::path& stdout_file) {
  const std::string output = stdout_file == stderr_file ? " > '" + stdout_file.string() + "' 2>&1"
                                                        : " > '" + stdout_file.string() + "' 2> '" +
                                                              stderr_file.string() + "'";
  const std::string command =
      std::string(RELOCALIZER_TOOL_DIR) + "/" + tool + " " + arguments + output;
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace relocalizer::testing
