#pragma once
// The scene's own surface: one oriented point per occupied voxel, fused from
// the depth of posed frames (the training frames, or key frames learned
// online). A pose is only right if the frame's depth, moved into the world by
// it, lies on this surface; surface_fit.h refines a pose by aligning the depth
// to it and measures how much of the depth agrees.
//
// Each voxel keeps the mean of the depth points that fell into it and the mean
// of their normals. Voxels seen in fewer than `min_frames` frames are dropped:
// sensor noise, "flying pixels" at depth edges and objects that moved leave
// such voxels, the room's structure does not.

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <unordered_map>
#include <vector>

#include "relocalizer/core/camera.h"
#include "relocalizer/core/pose.h"

namespace relocalizer {

struct SurfaceParams {
  float voxel_size = 0.02f;  // metres: finer than the 5 cm test, coarser than Kinect noise at 3 m
  int pixel_stride = 4;      // pixels between the depth samples of a frame
  int normal_step = 3;       // pixels between the points that span a normal
  float max_depth = 4.0f;    // metres; the Kinect's depth error grows with z^2 beyond
  int min_frames = 3;        // voxels seen in fewer frames are dropped
};

struct SurfaceElement {
  Eigen::Vector3f point = Eigen::Vector3f::Zero();    // world, metres
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();  // world, unit
};

class SurfaceModel {
 public:
  SurfaceModel() = default;
  // Elements in a canonical order (the builder sorts them by voxel), so that
  // the same frames give the same model bytes.
  SurfaceModel(float voxel_size, std::vector<SurfaceElement> elements);

  bool empty() const { return elements_.empty(); }
  float voxelSize() const { return voxel_size_; }
  const std::vector<SurfaceElement>& elements() const { return elements_; }

  // The element of the voxel that holds `world`; if that voxel is empty, the
  // element of a neighbouring voxel nearest to the voxel's centre; null when no
  // element lies within one voxel. One hash probe: the neighbours are resolved
  // when the model is made.
  const SurfaceElement* near(const Eigen::Vector3f& world) const;

  // near() of each of `count` points into `out`. A model of millions of voxels
  // misses the cache on nearly every probe; here all the probes are fetched
  // before any is read, then all the elements, so the misses overlap instead
  // of following one another.
  void nearAll(const Eigen::Vector3f* world, size_t count, const SurfaceElement** out) const;

 private:
  // Open addressing from a packed voxel key to an element index.
  struct Index {
    std::vector<uint64_t> keys;
    std::vector<int32_t> elements;
    uint64_t mask = 0;
    void insert(uint64_t key, int32_t element);
    int32_t find(uint64_t key) const;
    void prefetch(uint64_t key) const;
  };
  void buildIndex();

  float voxel_size_ = 0.02f;
  std::vector<SurfaceElement> elements_;
  Index index_;
};

// A voxel's packed key (21 bits per axis, +-20 km at 2 cm).
uint64_t surfaceVoxelKey(const Eigen::Vector3f& world, float voxel_size);

class SurfaceBuilder {
 public:
  explicit SurfaceBuilder(SurfaceParams params = {}) : params_(params) {}

  // Depth in metres (CV_32FC1, NaN or <= 0 invalid) of a camera at `camera_to_world`.
  void addFrame(const cv::Mat& depth, const CameraIntrinsics& camera, const Pose& camera_to_world);

  SurfaceModel build() const;
  int frames() const { return frames_; }

 private:
  struct Voxel {
    Eigen::Vector3d point_sum = Eigen::Vector3d::Zero();
    Eigen::Vector3d normal_sum = Eigen::Vector3d::Zero();
    int points = 0;
    int frames = 0;
    int last_frame = -1;
  };
  SurfaceParams params_;
  std::unordered_map<uint64_t, Voxel> voxels_;
  int frames_ = 0;
};

}  // namespace relocalizer
