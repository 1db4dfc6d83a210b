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
//  2. each of those depth points is seen along its camera ray at the final
//     pose: on the surface (within `tolerance`), in front of it (the surface
//     lies behind it along the ray: something new stands in the view, a
//     person), or behind it (the ray crossed the surface first: the pose sees
//     through walls, which no right pose does). The surface agreement, the
//     share of the points that are not occluders which lie on the surface,
//     joins the inlier counts in the decision to answer with a pose or with
//     "no pose", with a floor on the share of all points on the surface (a
//     view the occluders fill tells nothing) and a ceiling on those seen
//     through it.
// Parts of the scene that no training frame saw, and objects that moved since,
// lower the agreement of a right pose, so the gate sits well below 1. Moving
// the camera along a direction the visible surface does not constrain (along
// a wall and the floor at once) keeps the depth on the surface: no surface
// check sees that; the forests' evidence has to.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "relocalizer/core/frame.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/surface/surface_model.h"

namespace relocalizer {

struct SurfaceFitParams {
  bool enabled = true;           // ICP and the agreement gate (models without a surface skip both)
  int points = 1200;             // frame depth points aligned and checked (an even grid)
  int iterations = 6;            // Gauss-Newton steps
  float max_distance = 0.05f;    // metres; farther correspondences are not the same surface
  float huber = 0.01f;           // metres; larger residuals are down-weighted
  float tolerance = 0.02f;       // metres: a point agrees when this close to the surface's plane
  float min_agreement = 0.5f;    // evidence needed to answer with a pose: SurfaceView::agreement()
  float min_on_surface = 0.25f;  // and this share of all the points on the surface, occluded or not
  // And at most this share seen through the surface. Not 0: where furniture
  // moved, a right pose sees the wall it hid (10-16 % of the view in
  // make bench-heal's room). Opened wide, it let no wrong pose through in
  // make bench-changes, bench-places or bench-heal (docs/reliability.md).
  float max_seen_through = 0.20f;
  int min_correspondences = 100;  // fewer leave the pose as solved
  // Along its camera ray, a depth point this far short of the surface is an
  // occluder (something new in front of it: a person); a surface crossed this
  // far before the point is seen through, which a right pose does only where
  // something the surface holds has gone.
  float occlusion_margin = 0.05f;  // metres
  float occlusion_reach = 3.0f;    // metres behind an occluder the surface is looked for
};

// Where a frame's depth points lie against the surface, each seen along its
// camera ray at a pose.
struct SurfaceView {
  int points = 0;
  int on = 0;        // within tolerance of the surface
  int in_front = 0;  // short of the surface behind them: occluders
  int behind = 0;    // beyond a surface the ray crossed: seen through it

  // The share of the points that could see the surface (all but the
  // occluders) that lie on it.
  float agreement() const;
};

struct SurfaceFit {
  bool refined = false;            // ICP ran and moved the pose
  Pose pose = Pose::Identity();    // camera-to-world after ICP (the initial pose if !refined)
  float initial_agreement = 0.0f;  // agreement at the solved pose
  float agreement = 0.0f;          // agreement at `pose`
  int points = 0;                  // depth points checked
  int correspondences = 0;         // of the last ICP step
  SurfaceView view;                // the depth points at `pose`
};

// An even grid of about `count` valid depth points of the frame, camera frame.
std::vector<Eigen::Vector3f> surfaceFitPoints(const RgbdFrame& frame, int count);

// Share of `camera_points` within params.tolerance of the surface at `pose`.
float surfaceAgreement(const SurfaceModel& surface,
                       const std::vector<Eigen::Vector3f>& camera_points, const Pose& pose,
                       const SurfaceFitParams& params);

// Each of `camera_points` at `pose`: on the surface, in front of it or behind it.
SurfaceView viewSurface(const SurfaceModel& surface,
                        const std::vector<Eigen::Vector3f>& camera_points, const Pose& pose,
                        const SurfaceFitParams& params);

// Why `view` does not confirm its pose, for the "no pose" message; empty when it does.
std::string surfaceRefusal(const SurfaceView& view, const SurfaceFitParams& params);

// ICP from `initial`; keeps the initial pose when ICP cannot improve the agreement.
SurfaceFit fitToSurface(const SurfaceModel& surface,
                        const std::vector<Eigen::Vector3f>& camera_points, const Pose& initial,
                        const SurfaceFitParams& params);

}  // namespace relocalizer
