// JobBuilder's preparation of the clouds (job_builder.h): read, cut to the cameras' range,
// moved to the local frame, checked, the intensity corrected for the angle of incidence and
// the metric's classes encoded.
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "mmba/core/error.h"
#include "mmba/core/logging.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/io/trajectory.h"
#include "registration/mi/job_builder.h"

namespace mmba::registration::mi::internal {
namespace {

namespace fs = std::filesystem;

// Keeps the points of `cloud` (and their attributes) within `range_m` of any of `centres`
// and finite; returns the number dropped.
size_t KeepNearAny(const std::vector<Eigen::Vector3d>& centres, double range_m, io::PointCloud* cloud) {
  const double range_sq = range_m * range_m;
  std::vector<char> far(cloud->size(), 1);
  size_t dropped = 0;
  for (size_t i = 0; i < cloud->size(); ++i) {
    const Eigen::Vector3d& p = cloud->points[i];
    if (p.allFinite()) {
      for (const Eigen::Vector3d& c : centres) far[i] = far[i] && (p - c).squaredNorm() > range_sq;
    }
    dropped += far[i] ? 1 : 0;
  }
  if (dropped > 0) *cloud = io::WithoutMarked(*cloud, far);
  return dropped;
}

}  // namespace

void JobBuilder::PrepareClouds() {
  // Clouds in map-grid coordinates (a georeferenced mobile-mapping cloud in UTM with the
  // camera's pose in the grid): the renderer holds points as floats, which resolve 0.5 m at
  // 5,000 km. Every cloud is moved by −o (o = io::LocalOrigin of the first cloud: its
  // centroid rounded to whole km, 0 for a cloud in its sensor's frame, which is then used as
  // given), the poses by cam_from_local = cam_from_lidar · [I | o], and the result back. The
  // correction (a shift of the camera centre and a turn about it, in the cloud's axes) and its
  // covariance do not change under a shift of the cloud's frame.
  if (!request.trajectory.empty()) {
    trajectory = io::ReadTrajectory(request.trajectory);
    body_from_lidar = io::ReadLidarMountYaml(request.lidar_mount);
  }
  // The camera centres in the clouds' frame (each rig camera's; the start's and, with
  // --perturb, the unperturbed reference's). A point farther than --max-range-m from all of
  // them (plus the search bound, or the probe's 2 m) is never rendered: it is dropped before
  // anything else uses the cloud, so that one absurd point (a 1e12 m glitch) does not move the
  // map-grid origin or enter the incidence fit and the surface classes.
  for (const Rigid3d& pose : {start, reference}) {
    if (rig_mode) {
      for (const Rigid3d& cam_from_rig : rig_yaml.cam_from_rig) {
        camera_centres.push_back((cam_from_rig * pose).Inverse().translation);
      }
    } else {
      camera_centres.push_back(pose.Inverse().translation);
    }
  }
  keep_within_m = options.render.max_range_m + std::max(options.bound_translation_m, 2.0);

  for (const auto& [image_path, lidar_path] : pairs) PrepareCloud(lidar_path);
}

// The cloud read, its non-finite and far points dropped (and counted in clouds_json), moved
// to the local frame; the first cloud sets the local origin.
io::PointCloud JobBuilder::ReadCloud(const std::string& lidar_path) {
  // Points with a non-finite coordinate or intensity (a scanner's "no return") could never
  // be rendered: dropped and counted, as the far ones below.
  io::ReadOptions read_options;
  read_options.skip_invalid_points = true;
  io::ReadStats read_stats;
  io::PointCloud cloud = io::ReadPointCloud(lidar_path, read_options, &read_stats);
  const size_t not_finite = read_stats.num_skipped;
  if (not_finite > 0) {
    spdlog::info("{}: {} of {} points with a non-finite coordinate or intensity, dropped", lidar_path, not_finite,
                 not_finite + cloud.size());
  }
  if (cloud.empty()) throw InputError::Message(lidar_path, "cloud has no (finite) points");
  const size_t points_read = cloud.size() + not_finite;
  const size_t dropped = KeepNearAny(camera_centres, keep_within_m, &cloud);
  if (dropped > 0) {
    spdlog::info("{}: {} of {} points farther than {:.1f} m from the camera (--max-range-m + the search bound), "
                 "dropped",
                 lidar_path, dropped, points_read, keep_within_m);
  }
  clouds_json.push_back({{"lidar", lidar_path},
                         {"points_read", points_read},
                         {"points_not_finite", not_finite},
                         {"points_beyond_range", dropped}});
  if (cloud.empty()) {
    throw InputError::Message(lidar_path, "no point within " + std::to_string(keep_within_m) +
                                              " m of the camera (--max-range-m + the search bound): is the "
                                              "start pose (--initial, the calibration) one of this cloud?");
  }
  if (clouds.empty()) {
    origin = io::LocalOrigin(cloud.points);
    if (!origin.isZero()) {
      spdlog::info("{}: map-grid coordinates, registered relative to ({:.0f}, {:.0f}, {:.0f})",
                   lidar_path, origin.x(), origin.y(), origin.z());
    }
  }
  if (!origin.isZero()) {
    for (Eigen::Vector3d& p : cloud.points) p -= origin;
  }
  return cloud;
}

// Throws unless the cloud has an intensity to register by when the representation needs one.
void JobBuilder::CheckIntensity(const io::PointCloud& cloud, const std::string& lidar_path) const {
  if (options.render.representation == Representation::kIntensity &&
      !cloud.has_intensity()) {
    throw InputError::Message(lidar_path, std::string("cloud has no intensity, which --representation intensity") +
                                              (request.representation_given ? "" : " (the default)") +
                                              " needs; use --representation depth or points (points are "
                                              "compared over the whole image), or --set edges=on (the "
                                              "geometric term alone)");
  }
  if (options.render.representation == Representation::kIntensity) {
    // A LAS file always has the field; a cloud without a measured intensity holds one value
    // (often 0) in it, and an image of one grey level has no information to register by.
    const auto [lowest, highest] = std::minmax_element(cloud.intensity.begin(), cloud.intensity.end());
    if (*lowest == *highest) {
      throw InputError::Message(lidar_path, "every point's intensity is " + fmt::format("{:g}", *lowest) +
                                                ": no intensity to register by, which --representation intensity" +
                                                (request.representation_given ? "" : " (the default)") +
                                                " needs; use --representation depth or points, or --set "
                                                "edges=on (the geometric term alone)");
    }
  }
}

// What gives the scanner's position of the cloud's points: --scanner-origin, --trajectory,
// else (only where the intensity is corrected) the cloud's sidecar.
void JobBuilder::FindScanner(const std::string& lidar_path, ScannerSource* source) const {
  if (!request.scanner_origin.empty()) {
    source->origin = Eigen::Vector3d(request.scanner_origin[0], request.scanner_origin[1], request.scanner_origin[2]);
  }
  source->trajectory = &trajectory;
  source->mount = &body_from_lidar;
  source->trajectory_named = "the --trajectory " + request.trajectory;
  source->from = !request.scanner_origin.empty() ? "--scanner-origin"
                 : !request.trajectory.empty()   ? "--trajectory " + request.trajectory
                                                 : "";
  // (Read only where it is used: a depth or points image is not corrected.)
  if ((correct_incidence || request.incidence_correction == "on") && source->from.empty()) {
    if (const std::optional<io::ScannerSidecar> sidecar = io::ReadScannerSidecar(lidar_path)) {
      source->from = sidecar->path;
      source->origin = sidecar->origin;
      if (!sidecar->trajectory.empty()) {
        source->sidecar_trajectory = io::ReadTrajectory(sidecar->trajectory);
        source->sidecar_mount = io::ReadLidarMountYaml(sidecar->lidar_mount);
        source->trajectory = &source->sidecar_trajectory;
        source->mount = &source->sidecar_mount;
        source->trajectory_named = "the trajectory " + sidecar->trajectory + " (named in " + sidecar->path + ")";
      }
      spdlog::info("{}: the scanner's position from {}", lidar_path, sidecar->path);
    }
  }
}

// The scanner's position of each point in the local frame (none: the correction's scanner is
// empty); throws when the cloud's times are not within the trajectory or the correction is
// asked for ("on") without a scanner.
IncidenceCorrection JobBuilder::ScannerCorrection(const io::PointCloud& cloud, const std::string& lidar_path,
                                                  ScannerSource* source) const {
  IncidenceCorrection correction;
  if (source->origin) {
    const Eigen::Vector3d at = *source->origin - origin;
    correction.scanner = [at](size_t) -> Eigen::Vector3d { return at; };
  } else if (!source->trajectory->empty()) {
    if (!cloud.has_time()) {
      throw InputError::Message(lidar_path, "has no per-point time, which " + source->trajectory_named +
                                                " needs to place the scanner of each point");
    }
    // A cloud whose times the trajectory does not span (another time base, another drive)
    // would be corrected with the scanner at the trajectory's ends.
    const std::vector<std::pair<double, Rigid3d>>& scanner_trajectory = *source->trajectory;
    const auto [first, last] = std::minmax_element(cloud.time.begin(), cloud.time.end());
    if (*first < scanner_trajectory.front().first || *last > scanner_trajectory.back().first) {
      throw InputError::Message(lidar_path, "point times " + std::to_string(*first) + " .. " + std::to_string(*last) +
                                                " s are not within " + source->trajectory_named + "'s " +
                                                std::to_string(scanner_trajectory.front().first) + " .. " +
                                                std::to_string(scanner_trajectory.back().first) + " s");
    }
    correction.scanner = [trajectory = source->trajectory, mount = source->mount, &cloud,
                          &o = origin](size_t i) -> Eigen::Vector3d {
      // (An explicit return type: `.translation - origin` would return an Eigen expression
      // referring to the destroyed temporary.)
      return (io::InterpolateTrajectory(*trajectory, cloud.time[i]) * *mount).translation - o;
    };
  } else if (fs::path(lidar_path).extension() == ".bin") {
    correction.scanner = [&o = origin](size_t) -> Eigen::Vector3d { return -o; };
    source->from = "the KITTI scan's origin";
  }
  if (request.incidence_correction == "on" && !correction.scanner) {
    throw InputError::Message("--incidence-correction", "on needs the scanner's position of " + lidar_path +
                                                            ": --scanner-origin, --trajectory with "
                                                            "--lidar-mount, a sidecar " +
                                                            io::ScannerSidecarPath(lidar_path) +
                                                            ", or a KITTI .bin scan");
  }
  return correction;
}

// The cloud's LidarPoints appended to `clouds`, the intensity corrected for the angle of
// incidence when asked and possible (incidence_json: the fit, else null); returns the local
// planes' normals when the correction computed them.
std::vector<Eigen::Vector3f> JobBuilder::CorrectIncidence(const io::PointCloud& cloud, const std::string& lidar_path,
                                                          const IncidenceCorrection& correction,
                                                          const std::string& scanner_from) {
  std::vector<Eigen::Vector3f> normals;  // the local planes, when computed for the correction
  if (correct_incidence && correction.scanner && cloud.has_intensity()) {
    IncidenceCorrection voxel_correction = correction;
    voxel_correction.voxel_m = static_cast<float>(request.surface_voxel_m);
    IncidenceFit fit;
    clouds.push_back(PrepareLidarPoints(cloud, voxel_correction, &fit, &normals));
    spdlog::info("{}: intensity corrected for the angle of incidence: I / cos^{:.2f} (fitted to {} points, "
                 "correlation {:.2f})",
                 lidar_path, fit.exponent, fit.points, fit.correlation);
    incidence_json.push_back({{"lidar", lidar_path},
                              {"scanner_from", scanner_from},
                              {"exponent", fit.exponent},
                              {"correlation", fit.correlation},
                              {"points", fit.points}});
  } else {
    clouds.push_back(PrepareLidarPoints(cloud));
    incidence_json.push_back(nullptr);
  }
  return normals;
}

// The surface or orientation classes of the last cloud, when asked (orientation from the
// local planes `normals`, or computed when empty).
void JobBuilder::EncodeClasses(const std::string& lidar_path, const std::vector<Eigen::Vector3f>& normals) {
  if (request.surface_classes && options.render.representation == Representation::kIntensity) {
    // The metric conditioned on the surface: ground (a plane within 45° of the cloud's z
    // axis) against the rest (bench/RESULTS.md "Surface classes (opt-in)").
    const std::vector<uint8_t> classes =
        SurfaceClasses(clouds.back().points_in_lidar, Eigen::Vector3f::UnitZ(),
                           static_cast<float>(request.surface_voxel_m));
    EncodeSurfaceClasses(classes, &clouds.back());
    const size_t horizontal = static_cast<size_t>(std::count(classes.begin(), classes.end(), 0));
    spdlog::info("{}: surface classes: {} points on horizontal planes, {} others", lidar_path,
                 horizontal, classes.size() - horizontal);
  }
  if (job.orientation_sectors > 0) {
    // The metric conditioned on which way each surface faces, seen from the start's camera
    // (rig) centre (bench/RESULTS.md "Orientation classes").
    const Rigid3d cam_from_local = ToLocal(start);
    const Eigen::Vector3f viewpoint =
        cam_from_local.Inverse().translation.cast<float>();
    std::vector<size_t> per_class;
    if (normals.empty()) {
      EncodeOrientationClasses(viewpoint, job.orientation_sectors,
                                   static_cast<float>(request.surface_voxel_m), &clouds.back(), &per_class);
    } else {
      EncodeOrientationClasses(viewpoint, job.orientation_sectors, normals, &clouds.back(), &per_class);
    }
    std::string counts;
    for (size_t c = 2; c + 1 < per_class.size(); ++c) counts += (c > 2 ? "/" : "") + std::to_string(per_class[c]);
    spdlog::info("{}: orientation classes: {} facing up, {} facing down, {} steep by azimuth, {} "
                 "without a plane",
                 lidar_path, per_class[0], per_class[1], counts, per_class.back());
  }
}

// With the geometric term on (--set edges=on), a cloud without a measured intensity (no field,
// or one value in it) is registered by its depth edges alone: its intensity is dropped, and the
// job's LiDAR image (--overlay, --lidar-image) shows depth; the MI term needs every cloud's
// intensity (RegisterEdges), so it is left out.
void JobBuilder::GeometricTermAlone(io::PointCloud* cloud, const std::string& lidar_path) {
  if (options.edges != "on") return;
  const auto [lowest, highest] = std::minmax_element(cloud->intensity.begin(), cloud->intensity.end());
  if (cloud->has_intensity() && *lowest != *highest) return;
  spdlog::info("{}: {}; the geometric term alone (depth edges, no MI)", lidar_path,
               cloud->has_intensity() ? "every point's intensity is " + fmt::format("{:g}", *lowest)
                                      : std::string("no intensity"));
  cloud->intensity.clear();
  if (options.render.representation != Representation::kIntensity) return;
  options.render.representation = Representation::kDepth;
  options.metric.lidar_classes = 1;
  job.orientation_sectors = 0;
  correct_incidence = false;
}

void JobBuilder::PrepareCloud(const std::string& lidar_path) {
  io::PointCloud cloud = ReadCloud(lidar_path);
  GeometricTermAlone(&cloud, lidar_path);
  CheckIntensity(cloud, lidar_path);
  // The scanner's centre for each point, in the local frame: given (the options, else the
  // cloud's sidecar CLOUD.scanner.yaml, io::ReadScannerSidecar), from the trajectory at the
  // point's time, or the origin of a KITTI scan (its sensor frame).
  ScannerSource source;
  FindScanner(lidar_path, &source);
  const IncidenceCorrection correction = ScannerCorrection(cloud, lidar_path, &source);
  const std::vector<Eigen::Vector3f> normals = CorrectIncidence(cloud, lidar_path, correction, source.from);
  EncodeClasses(lidar_path, normals);
  spdlog::info("read {}: {} points{}", lidar_path, cloud.size(),
               cloud.has_intensity() ? " with intensity" : "");
}

}  // namespace mmba::registration::mi::internal
