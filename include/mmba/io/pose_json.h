#pragma once

// Rigid poses in JSON and as 4×4 matrices: the one reader and writer of poses that mmba's
// JSON files carry (register-cloud's target_from_source, register-mi's cam_from_lidar, a
// user's --initial pose, the simulator's truth).
//
// Forms read:
//   - a 4×4 matrix as 16 numbers (row-major) or as 4 rows of 4 numbers (numpy's tolist());
//   - {"qvec_wxyz": [w, x, y, z], "tvec": [x, y, z]} (COLMAP's convention, x' = R(q)·x + t).
// Form written: 4 rows of 4 numbers.

#include <cstdint>
#include <string>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "mmba/geometry/rigid3d.h"

namespace mmba::io {

/// The 4×4 matrix of `pose` as 4 rows of 4 numbers.
nlohmann::json PoseToJson(const Rigid3d& pose);

/// A 4×4 matrix as 16 numbers (row-major) or as four rows of four numbers. False, with
/// `problem` saying what was found, when it is neither.
bool Matrix4FromJson(const nlohmann::json& value, double row_major[16], std::string* problem);

/// A pose in any form read (see above); InputError naming `file` and `field` otherwise,
/// including a matrix whose last row is not (0 0 0 1) or whose rotation is not orthonormal
/// within 1e-4, and a quaternion whose norm is not 1 within 1e-3.
Rigid3d PoseFromJson(const nlohmann::json& value, const std::string& file, const std::string& field);

/// The pose under `key` of the JSON object in the file at `path`; InputError naming the file,
/// the line and the field when the file is not JSON, lacks the key, or the pose is invalid.
Rigid3d ReadPoseJson(const std::string& path, const std::string& key);

/// A 4×4 row-major matrix from 16 numbers as a rigid transform; throws InputError (naming
/// `where` and `field`) unless the numbers are finite, the last row is (0 0 0 1) and the
/// rotation is orthonormal within `tolerance`.
Rigid3d RigidFromRowMajor4x4(const double* values16, const std::string& where, const std::string& field,
                             double tolerance = 1e-4);

/// Throws InputError (file, line, field) unless |R·Rᵀ − I| ≤ tolerance (largest element) and
/// |det R − 1| ≤ tolerance.
void CheckRotation(const Eigen::Matrix3d& rotation, const std::string& file, int64_t line,
                   const std::string& field, double tolerance);

}  // namespace mmba::io
