#include "support.h"

#include <unistd.h>
#include <atomic>
#include <chrono>

namespace relocalizer::testing {

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

}  // namespace relocalizer::testing
