#pragma once
// Camera poses are camera-to-world rigid transforms: p_world = pose * p_camera.
// This is the 7-Scenes and TUM convention, and what REP 105 calls the camera
// pose in the map frame.

#include <Eigen/Geometry>

#include "relocalizer/core/expected.h"

namespace relocalizer {

using Pose = Eigen::Isometry3d;
// Pose covariances: (x, y, z, rotation about x, y, z), as geometry_msgs orders them.
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Nearest rotation (Frobenius norm) to a 3x3 matrix, via SVD. Ground-truth
// rotations from KinectFusion have column norms of about 0.9999; measuring
// angles on them without this reports ~0.8 degrees for a perfect estimate.
Eigen::Matrix3d nearestRotation(const Eigen::Matrix3d& m);

// A 4x4 camera-to-world matrix checked and projected to a rigid transform.
// Fails when it holds non-finite values, its last row is not (0 0 0 1), or its
// rotation block is far from orthonormal (|det - 1| > 0.05).
Expected<Pose> poseFromMatrix(const Eigen::Matrix4d& m);

// Euclidean distance between the camera centres, metres.
double translationError(const Pose& estimate, const Pose& truth);

// Angle of the relative rotation, degrees, after projecting both rotations to
// the nearest rotation matrix.
double rotationErrorDegrees(const Pose& estimate, const Pose& truth);

// Two answers that are each right (within 5 cm / 5 deg of the truth) are
// within about twice that of each other: the tolerance at which two answers
// for one frame count as one (the place search's answers of one map, a weak
// answer and the second draw that confirms it).
constexpr double kAnswersAgreeMetres = 0.10;
constexpr double kAnswersAgreeDegrees = 10.0;

// Both translationError and rotationErrorDegrees within the bounds.
bool posesAgree(const Pose& a, const Pose& b, double metres = kAnswersAgreeMetres,
                double degrees = kAnswersAgreeDegrees);

// Pose from translation and quaternion (x, y, z, w order as in TUM files); the
// quaternion is normalised.
Pose poseFromTranslationQuaternion(const Eigen::Vector3d& t, const Eigen::Quaterniond& q);

}  // namespace relocalizer
