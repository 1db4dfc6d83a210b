#pragma once
// A solved pose checked and refined against the scene's surface.
//
// The forests' votes say where the camera probably is; the frame's own depth
// says whether that is true. Moved into the world by a right pose, the depth
// lies on the surface the training frames saw; moved by a wrong one, most of it
// floats in free space or sinks into walls. So after RANSAC and LM:
//  1. robust point-to-plane ICP aligns a subsample of the frame's depth to the
//     surface, starting from the solved pose (a few Gauss-Newton steps; the
//     solved pose is within centimetres when it is right at all), and
//  2. the surface agreement, the share of those depth points that lie within
//     `tolerance` of the surface at the final pose, joins the inlier counts in
//     the decision to answer with a pose or with "no pose".
// Parts of the scene that no training frame saw, and objects that moved since,
// lower the agreement of a right pose, so the gate sits well below 1.

#include <Eigen/Core>
#include <vector>

#include "relocalizer/core/frame.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/surface/surface_model.h"

namespace relocalizer {

struct SurfaceFitParams {
  bool enabled = true;            // ICP and the agreement gate (models without a surface skip both)
  int points = 1200;              // frame depth points aligned and checked (an even grid)
  int iterations = 6;             // Gauss-Newton steps
  float max_distance = 0.05f;     // metres; farther correspondences are not the same surface
  float huber = 0.01f;            // metres; larger residuals are down-weighted
  float tolerance = 0.02f;        // metres: a point agrees when this close to the surface's plane
  float min_agreement = 0.5f;     // evidence needed to answer with a pose (share of the points)
  int min_correspondences = 100;  // fewer leave the pose as solved
};

struct SurfaceFit {
  bool refined = false;            // ICP ran and moved the pose
  Pose pose = Pose::Identity();    // camera-to-world after ICP (the initial pose if !refined)
  float initial_agreement = 0.0f;  // agreement at the solved pose
  float agreement = 0.0f;          // agreement at `pose`
  int points = 0;                  // depth points checked
  int correspondences = 0;         // of the last ICP step
};

// An even grid of about `count` valid depth points of the frame, camera frame.
std::vector<Eigen::Vector3f> surfaceFitPoints(const RgbdFrame& frame, int count);

// Share of `camera_points` within params.tolerance of the surface at `pose`.
float surfaceAgreement(const SurfaceModel& surface,
                       const std::vector<Eigen::Vector3f>& camera_points, const Pose& pose,
                       const SurfaceFitParams& params);

// ICP from `initial`; keeps the initial pose when ICP cannot improve the agreement.
SurfaceFit fitToSurface(const SurfaceModel& surface,
                        const std::vector<Eigen::Vector3f>& camera_points, const Pose& initial,
                        const SurfaceFitParams& params);

}  // namespace relocalizer
