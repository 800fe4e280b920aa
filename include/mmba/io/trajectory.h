// GNSS/INS trajectories of a vehicle body: CSV rows time_s, x_east_m, y_north_m, z_up_m,
// qw, qx, qy, qz (world_from_body; body x forward, y left, z up), as `mmba simulate` writes
// them and `mmba adjust` and `mmba register-mi` read them.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"

namespace mmba::io {

/// The rows of a trajectory CSV (at least 2, strictly increasing times, unit quaternions);
/// InputError naming the file, line and column otherwise.
std::vector<std::pair<double, Rigid3d>> ReadTrajectory(const std::string& path);

/// world_from_body at `time` from the trajectory rows (linear position, slerp rotation; the
/// first or last row outside their span).
Rigid3d InterpolateTrajectory(const std::vector<std::pair<double, Rigid3d>>& rows, double time);

/// Where the scanner of each point of a cloud was, from the cloud's sidecar file
/// CLOUD.scanner.yaml (the cloud's path without its extension + ".scanner.yaml"), which holds
/// the keys of register-mi's options of the same name:
///   scanner_origin: [x, y, z]        # a static scan: the scanner's centre in the cloud's frame
///   trajectory: FILE                 # a mobile cloud: its GNSS/INS trajectory CSV …
///   lidar_mount: FILE                # … and the mounting YAML (body_from_lidar); both or neither
/// File names are relative to the sidecar's folder and returned resolved. `mmba simulate`
/// writes one for each mobile cloud.
struct ScannerSidecar {
  std::string path;                      ///< the sidecar itself
  std::optional<Eigen::Vector3d> origin;  ///< scanner_origin
  std::string trajectory;                ///< resolved path, or empty
  std::string lidar_mount;               ///< resolved path, or empty
};

/// The sidecar path of `cloud_path` (whether or not it exists).
std::string ScannerSidecarPath(const std::string& cloud_path);

/// The sidecar of `cloud_path`, or nullopt when there is none. InputError naming the sidecar,
/// line and key for an unknown key, a malformed value, both an origin and a trajectory, a
/// trajectory without a mount (or the reverse), or a named file that does not exist.
std::optional<ScannerSidecar> ReadScannerSidecar(const std::string& cloud_path);

}  // namespace mmba::io
