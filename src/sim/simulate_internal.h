#pragma once

// The stages of `mmba::sim::Simulate` (photos, spherical stereo, rig, LiDAR, total station and
// GNSS, reconstruction-like clouds, truth and project files) and what they share: the run's
// context, the object's framing, and the small geometry and output-format helpers. Each stage
// draws from its own random streams (seed, stream id), so the stages' outputs do not depend on
// one another's draws.

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "mmba/geodesy/geodesy.h"
#include "mmba/geometry/rigid3d.h"
#include "mmba/sensors/camera.h"
#include "mmba/sim/lidar.h"
#include "mmba/sim/ray_caster.h"
#include "mmba/sim/scenes.h"
#include "mmba/sim/simulate.h"
#include "sim/random_internal.h"

namespace mmba::sim::internal {

namespace fs = std::filesystem;
using json = nlohmann::json;
constexpr double kDeg = M_PI / 180.0;

// ---------------------------------------------------------------- geometry

/// cam_from_world of a camera at `eye` looking at `target` (x right, y down, z forward),
/// rolled by `roll_rad` about its axis.
Rigid3d LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, double roll_rad = 0.0);

/// A rotation about a random axis: axis-angle vector N(0, sigma_rad) per component.
Eigen::Quaterniond SmallRotation(Rng* rng, double sigma_rad);

/// An area-weighted sample on a triangle of the object, with that triangle.
struct SurfaceSample {
  Eigen::Vector3d point;
  Eigen::Vector3d normal;
  int triangle;
};

/// `count` area-weighted samples on the triangles of the object (inside its bounds, ground
/// excluded by the bounds' z and a margin), drawn from the stream (seed, stream).
std::vector<SurfaceSample> SampleObjectSurface(const SimScene& scene, int count, uint64_t seed,
                                               uint64_t stream);

/// True when `point` is the first surface seen from `eye` (within `tolerance_m`).
bool SeesPoint(const RayCaster& caster, const Eigen::Vector3d& eye, const Eigen::Vector3d& point,
               double tolerance_m = 2e-3);

/// False when `xy` lies left of, above, right of or below [0, width) × [0, height).
inline bool InsideImage(const Eigen::Vector2d& xy, double width, double height) {
  return !(xy.x() < 0 || xy.y() < 0 || xy.x() >= width || xy.y() >= height);
}

// ---------------------------------------------------------------- output formats

/// A 4×4 homogeneous matrix as four rows.
json MatrixJson(const Rigid3d& pose);
/// {qvec_wxyz, tvec, matrix} of a pose.
json PoseJson(const Rigid3d& pose);
json VecJson(const Eigen::Vector3d& v);
/// {model, width, height, params} of a camera.
json CameraJson(const sensors::Camera& camera);
/// Writes `text` to `path` atomically.
void WriteText(const fs::path& path, const std::string& text);
/// `v` in fixed notation with `precision` decimals.
std::string Fmt(double v, int precision = 6);
/// A YAML flow list of `values` with `precision` significant digits.
std::string YamlList(const std::vector<double>& values, int precision = 9);
/// {qvec_wxyz: [...], tvec: [...]} of a pose.
std::string YamlPose(const Rigid3d& pose);

// ---------------------------------------------------------------- the run

/// A point in front of the object at which sensors look, and its size.
struct Framing {
  Eigen::Vector3d centre;   // front-centre of the object, mid-height
  double width, height, front_y;
};

/// What every stage reads (options, scene, ray caster, tangent plane, output folder) and
/// adds to (truth JSON, registration truth, project.yaml's sensors, the result's counts).
struct Context {
  const SimulateOptions& options;
  const SimScene& scene;
  const RayCaster& caster;
  const geodesy::LocalTangentPlane& plane;
  fs::path out;
  Framing framing;
  json truth;
  json registration_truth;
  std::ostringstream project_sensors;
  SimulateResult result;
  /// The photos' tie points (COLMAP point3D id, true position): other image sensors observe
  /// the same ids, standing for features matched across sensors.
  std::vector<std::pair<uint64_t, Eigen::Vector3d>> tie_points;
};

/// The two spheres of a spherical stereo station (lower and upper on a tilted mast).
struct SphereStation {
  std::string name;
  Rigid3d lower_from_world, upper_from_world;
};

/// Photos: an OPENCV camera on two rings in front of the object; images, true and perturbed
/// COLMAP models, target image measurements, the nominal calibration.
void SimulatePhotos(Context* c);

/// The spherical stereo stations: two equirectangular spheres on a tilted mast each.
std::vector<SphereStation> SphereStations(Context* c);
/// The spherical stereo pairs' images, tie-point observations, setups and calibration.
void SimulateSpheres(Context* c, const std::vector<SphereStation>& stations);

/// The Ladybug-style rig: 5 cameras around + 1 up, OPENCV_FISHEYE, on the vehicle; its images,
/// panoramas, tie-point observations and factory calibration.
void SimulateRig(Context* c, const Trajectory& trajectory);

/// Writes clouds/<name>.viewpoints.txt: the sensor positions of a cloud in its own frame.
void WriteViewpoints(Context* c, const std::string& name, const Rigid3d& cloud_from_world,
                     const std::vector<Eigen::Vector3d>& sensors_in_world);
/// Static terrestrial scans (registered as delivered) and the mobile LiDAR (georeferenced with
/// the nominal mounting), their target measurements, sidecars and calibration.
void SimulateLidar(Context* c, const Trajectory& trajectory, const Rigid3d& body_from_lidar);

/// The total-station network (survey/network.xml), GNSS control and the GNSS/INS trajectory.
void SimulateSurvey(Context* c, const Trajectory& trajectory);

/// Reconstruction-like clouds of the other modalities (spherical stereo, multi-view, plane
/// proxy), each in a random block frame, whole and cropped.
void SimulateClouds(Context* c, const std::vector<SphereStation>& stations,
                    const std::vector<Rigid3d>& photo_poses);

/// The scene's entries of truth.json (scene, frames, origin, trajectory, registration).
void RecordSceneTruth(Context* c, const Trajectory& trajectory);
/// project.yaml: origin, check points and the sensors the stages recorded.
std::string ProjectYaml(const Context& c);
/// truth/cameras/<images subfolder>/<image stem>.yaml for every simulated image.
void WriteTrueCameraYamls(const Context& c);

}  // namespace mmba::sim::internal
