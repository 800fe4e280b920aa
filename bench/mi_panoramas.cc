// MI registration on simulated panoramas, rig images and photos: a
// folder written by `mmba simulate` gives the spherical panoramas (`spherical_stereo`
// stations, lower and upper), the rig's stitched panoramas (`rig_panoramas`) and the rig's
// fisheye images (`rig`), their true poses and camera models (truth/truth.json), and the
// static LiDAR model (`clouds/lidar.ply`, world frame) and the mobile LiDAR
// (`truth/mobile_lidar_true.ply`: the mobile scan at its true positions, world frame;
// `clouds/mobile_lidar.ply` carries the GNSS/INS drift, so no rigid true pose exists for it).
// Each view starts from its true pose perturbed by a random error (each of tx, ty, tz uniform
// in ±A m, each of roll, pitch, yaw uniform in ±B°) for (A, B) = (0.1, 1) and (0.3, 2), is
// registered with the default options, and is scored by the median pixel offset of the
// true correspondences: the LiDAR points projected with the estimate against the truth,
// (a) in the image's own pixels (every point within range that projects into the image) and
// (b) in the pixels of the views that were registered (the paper's 940×452 perspective cuts).
//
//   mi_panoramas SIM_DIR OUT_DIR [CLOUD=mobile|static] [KINDS=spheres,rig_panoramas]
//                [DRAWS=2] [VIEW=perspective] [SEED=1] [MAGNITUDES=both|small|large]
//
// KINDS: comma list of spheres, rig_panoramas, rig (the fisheye images), photos (the photo
// collection's pinhole images; use CLOUD=static, the photos face the front). VIEW (panoramas
// only; fisheye images and photos are registered whole): perspective | equirect | cube.
// Writes OUT_DIR/runs.csv (one row per registration), OUT_DIR/hist_views.csv and
// hist_views.svg (per-view median offset at the start and at the result), OUT_DIR/
// hist_points.csv and hist_points.svg (offsets of all points, pooled), and prints a summary.
// MI_INCIDENCE=0 leaves the mobile cloud's intensity uncorrected for the angle of incidence
// (default: corrected, IncidenceCorrection, with the true trajectory); MI_INCIDENCE=static
// corrects the static model too, by scan (an experiment; by default it is not corrected).
// MI_ORIENTATION="N[,VOXEL]" the orientation classes (register-mi --orientation-classes N;
// default its default, 0 = the plain metric), MI_BINS the histogram's bins.
// MI_GROUND=1 prints, per panorama, the fraction of its views' LiDAR pixels on upward
// surfaces and the LiDAR pixels at the truth, and registers nothing; MI_SAMPLES_DIAG=1 prints,
// per registration, the metric and the samples at the truth and at the result per level, and
// the rendered MI with the shuffled-pairing bias (EvaluateShuffled) subtracted.
// MMBA_DEBUG=1 logs each stage. MI_ONLY selects registrations (below), MI_PERTURB sets their
// start, MI_THREADS the registration's threads (default 2), MI_RESTARTS / MI_RESTART_OFFSET
// ("m,deg") the restarts, MI_POINT_RADIUS ("m,px") the registration's z-buffer footprint
// (the cuts' headings and the scoring keep the default), MI_SAMPLE_BLOCK the per-point
// samples' block (RegistrationOptions::sample_block_px; 0 = each visible point sampled at its
// nearest won pixel), MI_WHOLE_IMAGE_CHECKS=0 switches the
// whole-panorama check off, MI_WEAK_SCAN=0 the scan along the weakly observed direction
// (RegistrationOptions::scan_weak_direction); each
// registration prints its whole-image checks and a `digest` line (RegistrationResult::Digest,
// pose and metric in hex floats) to compare runs.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mi_bench_common.h"
#include "mmba/core/huge_pages.h"
#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/io/trajectory.h"
#include "mmba/registration/mi/job.h"
#include "mmba/registration/mi/mi_registration.h"

using namespace mmba;
using namespace mmba::registration::mi;
namespace fs = std::filesystem;

namespace {


sensors::Camera CameraFromJson(const nlohmann::json& j) {
  sensors::Camera camera;
  camera.model_id = sensors::CameraModelFromName(j.at("model").get<std::string>());
  camera.width = j.at("width").get<int>();
  camera.height = j.at("height").get<int>();
  camera.params = j.at("params").get<std::vector<double>>();
  return camera;
}

Rigid3d PoseFromJson(const nlohmann::json& j) {
  Eigen::Matrix<double, 3, 4> m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) m(r, c) = j.at("matrix").at(r).at(c).get<double>();
  }
  return Rigid3d::FromMatrix(m);
}

struct TrueView {
  std::string kind;  // spheres | rig_panoramas | rig | photos
  std::string name;
  std::string image_path;
  sensors::Camera camera;
  Rigid3d cam_from_world;
};

std::vector<TrueView> ReadViews(const fs::path& dir, const std::vector<std::string>& kinds) {
  std::ifstream in(dir / "truth" / "truth.json");
  if (!in) throw std::runtime_error("cannot read " + (dir / "truth" / "truth.json").string());
  const nlohmann::json truth = nlohmann::json::parse(in);
  std::vector<TrueView> views;
  auto wanted = [&](const std::string& k) {
    return std::find(kinds.begin(), kinds.end(), k) != kinds.end();
  };
  if (wanted("spheres")) {
    const nlohmann::json& s = truth.at("spherical_stereo");
    const sensors::Camera lower = CameraFromJson(s.at("lower_camera"));
    const sensors::Camera upper = CameraFromJson(s.at("upper_camera"));
    for (const nlohmann::json& station : s.at("stations")) {
      const std::string name = station.at("name").get<std::string>();
      const auto images = station.at("images").get<std::vector<std::string>>();
      views.push_back({"spheres", name + "_lower", (dir / images.at(0)).string(), lower,
                       PoseFromJson(station.at("lower_from_world"))});
      views.push_back({"spheres", name + "_upper", (dir / images.at(1)).string(), upper,
                       PoseFromJson(station.at("upper_from_world"))});
    }
  }
  const nlohmann::json& rig = truth.at("rig");
  if (wanted("rig_panoramas")) {
    // The stitched panorama is in the rig frame (stitched at stitch_distance_m, so points
    // nearer or farther than that carry a parallax of up to the cameras' 6–7 cm offset).
    const sensors::Camera pano = CameraFromJson(rig.at("panorama_camera"));
    for (const nlohmann::json& frame : rig.at("frames")) {
      const std::string name = frame.at("name").get<std::string>();
      views.push_back({"rig_panoramas", name, (dir / "images" / "rig_panoramas" /
                                                (name + ".png")).string(),
                       pano, PoseFromJson(frame.at("rig_from_world"))});
    }
  }
  if (wanted("photos")) {
    // The photo collection's pinhole (OPENCV) images, at their true poses and calibration.
    const nlohmann::json& photos = truth.at("photos");
    const sensors::Camera camera = CameraFromJson(photos.at("camera"));
    for (const nlohmann::json& photo : photos.at("images")) {
      const std::string file = photo.at("name").get<std::string>();
      views.push_back({"photos", fs::path(file).stem().string(),
                       (dir / "images" / "photos" / file).string(), camera,
                       PoseFromJson(photo.at("cam_from_world"))});
    }
  }
  if (wanted("rig")) {
    const nlohmann::json& cameras = rig.at("cameras");
    for (const nlohmann::json& frame : rig.at("frames")) {
      const std::string name = frame.at("name").get<std::string>();
      const Rigid3d rig_from_world = PoseFromJson(frame.at("rig_from_world"));
      for (size_t k = 0; k < cameras.size(); ++k) {
        const std::string cam = name + "_cam" + std::to_string(k);
        views.push_back({"rig", cam, (dir / "images" / "rig" / (cam + ".png")).string(),
                         CameraFromJson(cameras[k].at("camera")),
                         PoseFromJson(cameras[k].at("cam_from_rig")) * rig_from_world});
      }
    }
  }
  return views;
}

// The stitched rig panorama's geometry (MI_STITCH_WARP): the simulator stitches each panorama
// pixel from the camera with the largest margin at the point `stitch_distance` away along the
// pixel's ray from the rig centre, so a point at another range appears where that camera's
// ray through it meets the stitching sphere — not in its own direction from the rig centre.
// Each point moved along its range (the z-buffer order is kept) to that direction, for the
// rig pose `rig_from_world`; points no camera sees consistently are kept as they are.
LidarPoints StitchWarp(const LidarPoints& points, const Rigid3d& rig_from_world,
                       const std::vector<sensors::Camera>& cameras,
                       const std::vector<Rigid3d>& cam_from_rig, double stitch_distance) {
  LidarPoints out = points;
  const Rigid3d world_from_rig = rig_from_world.Inverse();
  std::vector<Eigen::Vector3d> centres;
  for (const Rigid3d& c : cam_from_rig) centres.push_back(c.Inverse().translation);
  auto margin = [&](size_t c, const Eigen::Vector3d& x_rig, double* m) {
    const Eigen::Vector3d p = cam_from_rig[c] * x_rig;
    if (!(p.z() > 0)) return false;
    const std::optional<Eigen::Vector2d> xy = cameras[c].ImgFromCam(p);
    if (!xy) return false;
    *m = std::min(std::min(xy->x(), cameras[c].width - xy->x()),
                  std::min(xy->y(), cameras[c].height - xy->y()));
    return *m > 0;
  };
  size_t moved = 0;
  std::vector<double> shifts;
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d x = rig_from_world * points.points_in_lidar[i].cast<double>();
    double best = 0;
    Eigen::Vector3d best_dir = Eigen::Vector3d::Zero();
    for (size_t c = 0; c < cameras.size(); ++c) {
      double m;
      if (!margin(c, x, &m) || m <= best) continue;
      const Eigen::Vector3d& o = centres[c];
      const Eigen::Vector3d d = (x - o).normalized();
      const double b = o.dot(d);
      const double disc = b * b - o.squaredNorm() + stitch_distance * stitch_distance;
      if (disc < 0) continue;
      const Eigen::Vector3d sphere = o + (-b + std::sqrt(disc)) * d;
      bool chosen = true;  // would the stitcher take camera c at `sphere`?
      for (size_t k = 0; k < cameras.size() && chosen; ++k) {
        double mk;
        if (k != c && margin(k, sphere, &mk) && mk > m) chosen = false;
      }
      if (!chosen) continue;
      best = m;
      best_dir = sphere.normalized();
    }
    if (best > 0) {
      out.points_in_lidar[i] = (world_from_rig * (x.norm() * best_dir)).cast<float>();
      shifts.push_back(std::acos(std::min(1.0, best_dir.dot(x.normalized()))));
      ++moved;
    }
  }
  std::sort(shifts.begin(), shifts.end());
  std::printf("  stitch warp: %zu of %zu points moved, by %.4f (median) / %.4f (p90) / %.4f (max) deg\n",
              moved, points.size(), shifts.empty() ? 0.0 : shifts[shifts.size() / 2] * 180 / M_PI,
              shifts.empty() ? 0.0 : shifts[shifts.size() * 9 / 10] * 180 / M_PI,
              shifts.empty() ? 0.0 : shifts.back() * 180 / M_PI);
  return out;
}


double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Offsets in the registered views (pooled over the views of the frame).
std::vector<double> ViewOffsets(const LidarPoints& points, const std::vector<View>& views,
                                const Rigid3d& truth, const Rigid3d& estimate,
                                const RenderOptions& render) {
  std::vector<double> all;
  for (const View& view : views) {
    const PixelOffsetStats s = PixelOffsets(points, view, truth, estimate, render);
    all.insert(all.end(), s.offsets_px.begin(), s.offsets_px.end());
  }
  return all;
}


// MI_ONLY="NAME[:MAX_M],..." runs only the listed registrations (all sizes when MAX_M is
// left out); the random starts are drawn as in the full run, so each keeps its start.
bool Selected(const std::string& name, double max_m) {
  const char* only = std::getenv("MI_ONLY");
  if (only == nullptr) return true;
  for (const std::string& item : bench::SplitList(only)) {
    const size_t colon = item.find(':');
    if (item.substr(0, colon) != name) continue;
    if (colon == std::string::npos || std::abs(std::atof(item.c_str() + colon + 1) - max_m) < 1e-9) {
      return true;
    }
  }
  return false;
}

// The command line (the top of the file).
struct Args {
  fs::path dir, out_dir;
  std::string cloud_kind = "mobile";
  std::vector<std::string> kinds;
  int draws = 2;
  ViewOptions view_options;
  /// perspective: the two cuts that see the most LiDAR at the start (SelectPerspectiveHeadings);
  /// perspective90: the paper's cuts at ±90° from the panorama's centre column.
  bool auto_headings = true;
  int seed = 1;
  std::string magnitudes = "both";
};

bool ParseArgs(int argc, char** argv, Args* args) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: mi_panoramas SIM_DIR OUT_DIR [CLOUD=mobile|static] "
                 "[KINDS=spheres,rig_panoramas] [DRAWS=2] [VIEW=perspective] [SEED=1] "
                 "[MAGNITUDES=both|small|large]\n");
    return false;
  }
  args->dir = argv[1];
  args->out_dir = argv[2];
  if (argc > 3) args->cloud_kind = argv[3];
  args->kinds = bench::SplitList(argc > 4 ? argv[4] : "spheres,rig_panoramas");
  if (argc > 5) args->draws = std::atoi(argv[5]);
  const std::string view_arg = argc > 6 ? argv[6] : "perspective";
  args->auto_headings = view_arg == "perspective";
  if (view_arg == "perspective90") {
    args->view_options.kind = ViewKind::kPerspective;
  } else if (!ParseViewKind(view_arg, &args->view_options.kind)) {
    return false;
  }
  if (argc > 7) args->seed = std::atoi(argv[7]);
  if (argc > 8) args->magnitudes = argv[8];
  return true;
}

// MI_INCIDENCE=static (an experiment): the static model's intensity corrected for the angle
// of incidence, each point's scanner the delivered registration's centre of the scan it came
// from (the simulator writes clouds/lidar.ply as the scans in order, truth.json gives their
// sizes). False when the scans do not add up to the cloud.
bool StaticScansPoints(const fs::path& dir, const std::string& cloud_path, const io::PointCloud& cloud,
                       LidarPoints* points) {
  std::ifstream in(dir / "truth" / "truth.json");
  const nlohmann::json scans = nlohmann::json::parse(in).at("lidar").at("static_scans");
  std::vector<std::pair<size_t, Eigen::Vector3d>> ends;  // (end index, scanner centre)
  size_t end = 0;
  for (const nlohmann::json& scan : scans) {
    end += scan.at("points").get<size_t>();
    ends.emplace_back(end, PoseFromJson(scan.at("world_from_scan_registered")).translation);
  }
  if (end != cloud.size()) {
    std::fprintf(stderr, "%s: %zu points, the scans %zu\n", cloud_path.c_str(), cloud.size(), end);
    return false;
  }
  IncidenceCorrection correction;
  correction.scanner = [&](size_t i) -> Eigen::Vector3d {
    size_t s = 0;
    while (i >= ends[s].first) ++s;
    return ends[s].second;
  };
  IncidenceFit fit;
  *points = PrepareLidarPoints(cloud, correction, &fit);
  std::printf("incidence correction (static scans): exponent %.3f (correlation %.3f, %zu points)\n",
              fit.exponent, fit.correlation, fit.points);
  return true;
}

// The mobile cloud's intensity corrected for the angle of incidence as register-mi
// --trajectory --lidar-mount does (IncidenceCorrection), with the scanner's centre at each
// point's time from the true trajectory and mounting (the cloud is the mobile scan at its true
// positions). The whole cloud is prepared once for every view (register-mi would first drop
// the points beyond range of each start's camera).
LidarPoints MobilePoints(const fs::path& dir, const io::PointCloud& cloud) {
  std::ifstream in(dir / "truth" / "truth.json");
  const Rigid3d body_from_lidar =
      PoseFromJson(nlohmann::json::parse(in).at("lidar").at("mobile").at("body_from_lidar"));
  const auto trajectory = io::ReadTrajectory((dir / "truth" / "trajectory_true.csv").string());
  IncidenceCorrection correction;
  correction.scanner = [&](size_t i) -> Eigen::Vector3d {
    return (io::InterpolateTrajectory(trajectory, cloud.time.at(i)) * body_from_lidar).translation;
  };
  IncidenceFit fit;
  LidarPoints points = PrepareLidarPoints(cloud, correction, &fit);
  std::printf("incidence correction: exponent %.3f (correlation %.3f, %zu points)\n", fit.exponent,
              fit.correlation, fit.points);
  return points;
}

// The cloud's points: the mobile cloud corrected for the angle of incidence unless
// MI_INCIDENCE=0; the static model (which merges scans whose origins the cloud does not
// carry) as measured unless MI_INCIDENCE=static. False on an inconsistent simulation.
bool ReadPoints(const Args& args, const std::string& cloud_path, LidarPoints* points) {
  const char* incidence_env = std::getenv("MI_INCIDENCE");
  const bool incidence =
      args.cloud_kind == "mobile" && (incidence_env == nullptr || std::atoi(incidence_env) != 0);
  const bool static_incidence = args.cloud_kind == "static" && incidence_env != nullptr &&
                                std::string(incidence_env) == "static";
  const io::PointCloud cloud = io::ReadPointCloud(cloud_path);
  if (static_incidence) return StaticScansPoints(args.dir, cloud_path, cloud, points);
  *points = incidence ? MobilePoints(args.dir, cloud) : PrepareLidarPoints(cloud);
  return true;
}

// MI_STITCH_WARP=truth|start (an experiment): the rig panoramas registered against the cloud
// warped to the stitching's geometry (StitchWarp) at the true or the start pose; the rig's
// cameras and stitching distance from truth.json.
struct StitchRig {
  const char* mode = nullptr;  ///< MI_STITCH_WARP; null: no warp
  std::vector<sensors::Camera> cameras;
  std::vector<Rigid3d> cam_from_rig;
  double distance = 0;
};

StitchRig ReadStitchRig(const fs::path& dir) {
  StitchRig stitch;
  stitch.mode = std::getenv("MI_STITCH_WARP");
  if (stitch.mode == nullptr) return stitch;
  std::ifstream in(dir / "truth" / "truth.json");
  const nlohmann::json rig = nlohmann::json::parse(in).at("rig");
  for (const nlohmann::json& c : rig.at("cameras")) {
    stitch.cameras.push_back(CameraFromJson(c.at("camera")));
    stitch.cam_from_rig.push_back(PoseFromJson(c.at("cam_from_rig")));
  }
  stitch.distance = rig.at("stitch_distance_m").get<double>();
  return stitch;
}

// The metric's classes: register-mi's orientation classes (OrientationSectors: by default
// kDefaultOrientationSectors on planes of kDefaultSurfaceVoxelM, none with surface classes),
// seen from each start's camera centre, so only the local planes are computed here.
struct Classes {
  int sectors = 0;
  float voxel = static_cast<float>(kDefaultSurfaceVoxelM);
  std::vector<Eigen::Vector3f> plane_normals;  ///< of the cloud's points, when sectors > 0
  bool surface = false;
};

// MI_SURFACE_CLASSES=V: register-mi --surface-classes true --surface-voxel-m V, encoded into
// `points`. MI_ORIENTATION="sectors[,voxel]": register-mi --orientation-classes sectors
// [--surface-voxel-m voxel] (0: the plain metric).
Classes SetupClasses(LidarPoints* points) {
  Classes classes;
  if (const char* v = std::getenv("MI_SURFACE_CLASSES"); v != nullptr && std::atof(v) > 0) {
    classes.surface = true;
    EncodeSurfaceClasses(SurfaceClasses(points->points_in_lidar, Eigen::Vector3f::UnitZ(),
                                        static_cast<float>(std::atof(v))),
                         points);
  }
  int asked = -1;
  if (const char* v = std::getenv("MI_ORIENTATION")) std::sscanf(v, "%d,%f", &asked, &classes.voxel);
  classes.sectors = OrientationSectors(asked, Representation::kIntensity, classes.surface);
  if (classes.sectors > 0) classes.plane_normals = LocalPlaneNormals(points->points_in_lidar, classes.voxel);
  return classes;
}

// The registration's options from the environment (the top of the file and
// mi_bench_common.h) and the classes; `scoring_render` receives the rendering the cuts'
// headings and the scoring use, the default footprint and range whatever MI_POINT_RADIUS and
// MI_RANGE say. False on a bad MI_REGION or MI_METRIC.
bool PanoramaOptions(const Classes& classes, RegistrationOptions* options, RenderOptions* scoring_render) {
  bench::ApplyEvaluatorEnv(options);
  bench::ApplySearchEnv(options);
  // MI_COV_FLOOR=0: the calibrated Laplace covariance without the pixel-isotropic floor.
  if (const char* v = std::getenv("MI_COV_FLOOR")) options->covariance_pixel_floor = std::atoi(v) != 0;
  if (const char* v = std::getenv("MI_COARSE_CANDIDATES")) options->coarse_candidates = std::atoi(v);
  if (const char* v = std::getenv("MI_COARSE_SPREAD")) options->coarse_start_spread = std::atof(v);
  if (const char* v = std::getenv("MI_WEAK_SCAN")) options->scan_weak_direction = std::atoi(v) != 0;
  if (classes.surface) options->metric.lidar_classes = 2;
  if (classes.sectors > 0) options->metric.lidar_classes = OrientationClassCount(classes.sectors);
  // MI_BINS: the joint histogram's bins per axis (register-mi --bins).
  if (const char* v = std::getenv("MI_BINS")) options->metric.bins = std::atoi(v);
  if (const char* v = std::getenv("MI_RESTART_OFFSET")) {  // "m,deg"
    std::sscanf(v, "%lf,%lf", &options->restart_offset_m, &options->restart_offset_deg);
  }
  if (const char* v = std::getenv("MI_RESTARTS")) options->restarts = std::atoi(v);
  if (const char* v = std::getenv("MI_WHOLE_IMAGE_CHECKS")) {
    options->whole_image_checks = std::atoi(v) != 0;
  }
  if (const char* v = std::getenv("MI_REGION")) {
    if (!ParseRegion(v, &options->metric.region)) return false;
  }
  if (const char* v = std::getenv("MI_METRIC")) {
    if (!ParseMetric(v, &options->metric.kind)) return false;
  }
  *scoring_render = options->render;
  // MI_POINT_RADIUS="m,px": the z-buffer footprint (RenderOptions point_radius_m,
  // max_point_radius_px); MI_RANGE="min,max": the LiDAR points used, by range from the camera.
  if (const char* v = std::getenv("MI_POINT_RADIUS")) {
    std::sscanf(v, "%lf,%d", &options->render.point_radius_m, &options->render.max_point_radius_px);
  }
  if (const char* v = std::getenv("MI_RANGE")) {
    std::sscanf(v, "%lf,%lf", &options->render.min_range_m, &options->render.max_range_m);
  }
  // MI_SEARCH_ONLY=1: no restarts and no halves (the search and its end pose are unchanged;
  // the status is then not the acceptance's) — for diagnosing the search quickly.
  if (std::getenv("MI_SEARCH_ONLY") != nullptr) {
    options->restarts = 0;
    options->split_check = false;
  }
  return true;
}

// One registration's summary row (the per-magnitude summary).
struct Row {
  std::string size;
  bool ok;
  double image_before, image_after, view_before, view_after, sigma, seconds;
};

// Both sizes are always drawn (in this order), MAGNITUDES only selects which are run: a
// start does not depend on which sizes are run.
const std::vector<std::pair<double, double>> kSizes = {{0.1, 1.0}, {0.3, 2.0}};

std::string SizeName(double max_m) { return max_m == 0.1 ? "0.1m/1deg" : "0.3m/2deg"; }

// What every registration of the run shares.
struct Bench {
  Args args;
  LidarPoints points;
  Classes classes;
  StitchRig stitch;
  RegistrationOptions options;
  RenderOptions scoring_render;
  std::ofstream runs;
  std::vector<Row> rows;
  std::map<std::string, std::vector<double>> pooled_before, pooled_after;
  std::mt19937 rng;
};

void OpenRuns(Bench* b) {
  b->runs.open(b->args.out_dir / "runs.csv");
  b->runs << "view,kind,max_m,max_deg,tx,ty,tz,roll,pitch,yaw,status,"
             "image_px_before,image_px_after,view_px_before,view_px_after,sigma_px,"
             "restart_spread_px,err_tx,err_ty,err_tz,err_roll,err_pitch,err_yaw,"
             "sd_tx,sd_ty,sd_tz,sd_roll,sd_pitch,sd_yaw,mahalanobis2,n_eff,inflation,"
             "sigma_px_calibrated,restart_rms_px,split_spread_px,variance_factor_halves,"
             "variance_factor_restarts,variance_factor,evaluations,"
             "metric_true_l0,metric_est_l0,metric_true_l1,metric_est_l1,metric_true_l2,"
             "metric_est_l2,seconds,"
             "cpu_seconds,reason\n";
}

// The frame of a view at `start`: a panorama's perspective cuts at the headings that see the
// most LiDAR at the start (AutoPerspectiveViews, as register-mi --headings auto) or the
// view kind asked; fisheye images and photos whole.
Frame MakeFrame(const Bench& b, const TrueView& tv, const GrayImage& image, const Rigid3d& start) {
  Frame frame;
  frame.name = tv.name;
  ViewOptions vo = b.args.view_options;
  if (!tv.camera.IsSpherical()) vo.kind = ViewKind::kImage;
  if (b.args.auto_headings && vo.kind == ViewKind::kPerspective) {
    frame.views = AutoPerspectiveViews(image, tv.camera, b.points, start, vo, b.scoring_render,
                                       tv.image_path, nullptr);
  } else {
    frame.views = MakeViews(image, tv.camera, vo, tv.image_path);
  }
  frame.points = &b.points;
  return frame;
}

// MI_DUMP_DIR (inspection): each registered view's photo and its LiDAR image at the true pose.
void DumpViews(const Bench& b, const TrueView& tv, const Frame& truth_frame, const std::string& dump) {
  fs::create_directories(dump);
  LidarImage lidar;
  for (const View& view : truth_frame.views) {
    const std::string base = dump + "/" + tv.name + "_" + view.name;
    WriteGrayPng(view.image, base + "_photo.png");
    RenderLidarImage(b.points, view, tv.cam_from_world, b.options.render, &lidar);
    WriteGrayPng(LidarImageToGray(lidar), base + "_lidar.png");
  }
}

// MI_GROUND (inspection): of the views' LiDAR pixels at the true pose, the fraction on
// surfaces facing up (orientation class 0), per view and in all.
void PrintGround(const Bench& b, const TrueView& tv, const Frame& truth_frame) {
  const std::vector<uint8_t> cls =
      OrientationClasses(b.points.points_in_lidar, b.classes.plane_normals, Eigen::Vector3f::UnitZ(),
                         tv.cam_from_world.Inverse().translation.cast<float>(), 4);
  LidarImage lidar;
  double up = 0, all = 0;
  std::vector<double> per_view;
  for (const View& view : truth_frame.views) {
    RenderLidarImage(b.points, view, tv.cam_from_world, b.options.render, &lidar);
    double u = 0, a = 0;
    for (int idx : lidar.point_index) {
      if (idx < 0) continue;
      a += 1;
      u += cls[idx] == 0;
    }
    per_view.push_back(a > 0 ? u / a : 0);
    up += u;
    all += a;
  }
  std::printf("GROUND %s %s %.3f views", tv.kind.c_str(), tv.name.c_str(), up / all);
  for (double v : per_view) std::printf(" %.3f", v);
  std::printf(" covered %.0f\n", all);
}

// MI_PROBE (inspection): where does the metric peak along each axis around the truth?
void ProbeAtTruth(const Bench& b, const TrueView& tv, const Frame& truth_frame) {
  RegistrationOptions probe_options = b.options;
  probe_options.bound_translation_m = 1.0;
  probe_options.bound_rotation_deg = 2.0;
  const FrameSetEvaluator evaluator({truth_frame}, tv.cam_from_world, probe_options);
  for (int level = 0; level < 2; ++level) {
    const std::vector<ProbeSample> probe = Probe(evaluator, tv.cam_from_world, 1.0, 0.05, level);
    std::printf("%s probe level %d, argmax per axis (m / deg):", tv.name.c_str(), level);
    bench::PrintProbeArgmax(probe);
    std::printf("\n");
  }
}

// The points a start's frame registers against: the cloud, warped to the stitching
// (MI_STITCH_WARP, rig panoramas) into `warped`, and with the orientation classes seen from
// the start's camera centre into `classed`.
void SetFramePoints(const Bench& b, const TrueView& tv, const Rigid3d& start, Frame* frame,
                    LidarPoints* warped, LidarPoints* classed) {
  if (b.stitch.mode != nullptr && tv.kind == "rig_panoramas") {
    *warped = StitchWarp(b.points, std::string(b.stitch.mode) == "truth" ? tv.cam_from_world : start,
                         b.stitch.cameras, b.stitch.cam_from_rig, b.stitch.distance);
    frame->points = warped;
  }
  if (b.classes.sectors > 0) {
    *classed = frame->points == warped ? *warped : b.points;
    const Eigen::Vector3f centre = start.Inverse().translation.cast<float>();
    EncodeSurfaceClasses(OrientationClasses(classed->points_in_lidar, b.classes.plane_normals,
                                            Eigen::Vector3f::UnitZ(), centre, b.classes.sectors),
                         classed);
    frame->points = classed;
  }
}

// One registration from one start and its scores.
struct Run {
  const TrueView* view = nullptr;
  double max_m = 0, max_deg = 0;
  Vector6d perturbation;
  RegistrationResult result;
  PixelOffsetStats image_before, image_after;  ///< in the image's own pixels
  Vector6d truth_correction;                   ///< the true correction from the start
  Vector6d error;                              ///< estimate − truth
  Vector6d sd = Vector6d::Constant(NAN);       ///< the covariance's, when valid
  double mahalanobis2 = NAN;
  std::array<double, 3> metric_true{NAN, NAN, NAN}, metric_est{NAN, NAN, NAN};
  double seconds = 0, cpu = 0;
  std::string reason;  ///< without commas and newlines
};

// MI_SAMPLES_DIAG: the metric and the samples at the truth and at the result at `level`, and
// the rendered MI with the shuffled-pairing bias (EvaluateShuffled) subtracted.
void PrintSamplesDiag(const FrameSetEvaluator& evaluator, const Run& run, int level) {
  const Rigid3d& truth = run.view->cam_from_world;
  const RegistrationResult& r = run.result;
  const MetricValue a = evaluator.Evaluate(truth, level);
  const MetricValue b = evaluator.Evaluate(r.cam_from_lidar, level);
  std::printf("  l%d true: value %.6f mi %.5f H %.4f samples %.0f | est: value %.6f mi %.5f H %.4f samples %.0f\n",
              level, a.value, a.mi, a.joint_entropy, a.samples, b.value, b.mi, b.joint_entropy, b.samples);
  double mt, me;
  std::vector<double> st, se;
  evaluator.EvaluateShuffled(truth, level, 4, &mt, &st);
  evaluator.EvaluateShuffled(r.cam_from_lidar, level, 4, &me, &se);
  double bt = 0, be = 0;
  for (double v : st) bt += v / st.size();
  for (double v : se) be += v / se.size();
  std::printf("  l%d rendered mi true %.5f - bias %.5f = %.5f | est %.5f - bias %.5f = %.5f | corrected est-true %+.5f\n",
              level, mt, bt, mt - bt, me, be, me - be, (me - be) - (mt - bt));
  if (level == 0) {
    std::printf("  checks mi %.5f shuffled %.5f (sd %.6f)\n", r.checks.mi_bits,
                r.checks.mi_shuffled_bits, r.checks.mi_shuffled_sd_bits);
  }
}

// Does the metric itself prefer the truth (a search failure) or the estimate (a metric whose
// maximum is not at the truth)? Each pyramid level up to 3, the default metric.
void MetricAtLevels(const Bench& b, const Frame& frame, const Rigid3d& start, Run* run) {
  const FrameSetEvaluator evaluator({frame}, start, b.options);
  for (int level = 0; level < std::min(3, evaluator.levels()); ++level) {
    run->metric_true[level] = evaluator.Evaluate(run->view->cam_from_world, level).value;
    run->metric_est[level] = evaluator.Evaluate(run->result.cam_from_lidar, level).value;
    if (std::getenv("MI_SAMPLES_DIAG") != nullptr) PrintSamplesDiag(evaluator, *run, level);
  }
}

// MI_LINE_PROBE (inspection): the metric along the straight line truth → estimate (t = 0
// truth, t = 1 estimate, in correction space) at each level, for several metric settings:
// which of them put the maximum of that line at the truth at every level?
void LineProbe(const Bench& b, const Frame& frame, const Rigid3d& start, const Run& run) {
  const Vector6d c_est = run.result.correction;
  const Vector6d c_true = run.truth_correction;
  struct Setting {
    const char* name;
    MetricKind kind;
    Region region;
    int bins;
  };
  const Setting settings[] = {{"nmi overlap 64", MetricKind::kNmi, Region::kOverlap, 64},
                              {"nmi whole 64", MetricKind::kNmi, Region::kWholeImage, 64},
                              {"mi overlap 64", MetricKind::kMi, Region::kOverlap, 64},
                              {"mi whole 64", MetricKind::kMi, Region::kWholeImage, 64},
                              {"nmi overlap 32", MetricKind::kNmi, Region::kOverlap, 32}};
  const FrameSetEvaluator evaluator({frame}, start, b.options);
  for (const Setting& setting : settings) {
    MetricOptions metric = b.options.metric;
    metric.kind = setting.kind;
    metric.region = setting.region;
    metric.bins = setting.bins;
    std::printf("  line %-16s", setting.name);
    for (int level = 0; level < evaluator.levels(); ++level) {
      double best = -INFINITY, best_t = 0, at_truth = 0, at_est = 0;
      for (int k = -5; k <= 15; ++k) {
        const double t = 0.1 * k;
        const double value =
            evaluator.Evaluate(ApplyCorrection(start, c_true + t * (c_est - c_true)), level, metric).value;
        if (k == 0) at_truth = value;
        if (k == 10) at_est = value;
        if (value > best) {
          best = value;
          best_t = t;
        }
      }
      std::printf("  l%d argmax t=%+.1f (est-true %+.5f)", level, best_t, at_est - at_truth);
    }
    std::printf("\n");
  }
}

// The estimate's error against the truth and, with a valid covariance, its σ and the squared
// Mahalanobis distance.
void ErrorStats(const Rigid3d& start, Run* run) {
  const RegistrationResult& r = run->result;
  run->truth_correction = CorrectionBetween(start, run->view->cam_from_world);
  run->error = r.correction - run->truth_correction;
  if (r.covariance_valid) {
    run->sd = r.covariance.diagonal().cwiseSqrt();
    Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(r.covariance);
    if (ldlt.info() == Eigen::Success) run->mahalanobis2 = run->error.dot(ldlt.solve(run->error));
  }
}

void WriteRunRow(const Run& run, const Row& row, std::ofstream& runs) {
  const RegistrationResult& r = run.result;
  runs << run.view->name << "," << run.view->kind << "," << run.max_m << "," << run.max_deg;
  for (int i = 0; i < 6; ++i) runs << "," << run.perturbation[i];
  runs << "," << r.status << "," << run.image_before.median_px << "," << run.image_after.median_px << ","
       << row.view_before << "," << row.view_after << "," << r.checks.sigma_px << ","
       << r.checks.restart_spread_px;
  for (int i = 0; i < 6; ++i) runs << "," << run.error[i];
  for (int i = 0; i < 6; ++i) runs << "," << run.sd[i];
  runs << "," << run.mahalanobis2 << "," << r.checks.effective_samples << ","
       << r.checks.sample_inflation << "," << r.checks.sigma_px_calibrated << ","
       << r.checks.restart_rms_px << "," << r.checks.split_spread_px << ","
       << r.checks.variance_factor_halves << "," << r.checks.variance_factor_restarts << ","
       << r.checks.variance_factor << "," << r.evaluations;
  for (int level = 0; level < 3; ++level) {
    runs << "," << run.metric_true[level] << "," << run.metric_est[level];
  }
  runs << "," << run.seconds << "," << run.cpu << ",\"" << run.reason << "\"\n";
  runs.flush();
}

// The registration's lines: the cuts' headings, the offsets and checks; with a covariance
// the whole-image checks; the digest (pose and metric in hex floats) to compare runs.
void PrintRun(const Run& run, const Row& row, const Frame& frame) {
  const RegistrationResult& r = run.result;
  const std::array<double, 3>& mt = run.metric_true;
  const std::array<double, 3>& me = run.metric_est;
  std::string headings;
  for (const View& view : frame.views) headings += view.name.substr(view.name.rfind('_') + 1) + " ";
  std::printf("[%s] ", headings.c_str());
  std::printf("%-16s %-9s %-6s image %6.2f -> %6.2f px  views %6.2f -> %6.2f px  sigma "
              "%.2f px (calibrated %.2f, factor %.1f)  restarts %.2f px (rms %.2f)  halves %.2f px  maha2 %.1f  N_eff %.0f (/%.1f)  metric est-true l0 %+.5f l1 %+.5f l2 %+.5f  %5.1f s (cpu %.1f)  %s\n",
              run.view->name.c_str(), row.size.c_str(), r.status.c_str(), row.image_before,
              row.image_after, row.view_before, row.view_after, r.checks.sigma_px,
              r.checks.sigma_px_calibrated, r.checks.variance_factor, r.checks.restart_spread_px,
              r.checks.restart_rms_px, r.checks.split_spread_px, run.mahalanobis2,
              r.checks.effective_samples, r.checks.sample_inflation, me[0] - mt[0], me[1] - mt[1],
              me[2] - mt[2], run.seconds, run.cpu, run.reason.c_str());
  if (r.covariance_valid) {
    std::printf("  restart best gain %+.6f\n", r.checks.restart_best_gain);
    std::printf("  image checks: sigma %.3f px, restarts %.2f px, halves %.2f px, factor "
                "%.1f, calibrated sigma %.3f px\n",
                r.checks.image_sigma_px, r.checks.image_restart_spread_px,
                r.checks.image_split_spread_px, r.checks.image_variance_factor,
                r.checks.image_sigma_px_calibrated);
  }
  std::printf("  digest %016llx  pose %a %a %a %a %a %a %a  metric %a  iterations %d  "
              "evaluations %d\n",
              static_cast<unsigned long long>(r.Digest()), r.cam_from_lidar.rotation.w(),
              r.cam_from_lidar.rotation.x(), r.cam_from_lidar.rotation.y(),
              r.cam_from_lidar.rotation.z(), r.cam_from_lidar.translation.x(),
              r.cam_from_lidar.translation.y(), r.cam_from_lidar.translation.z(),
              r.metric_after.value, r.iterations, r.evaluations);
  std::fflush(stdout);
}

// Registers view `tv` from its true pose perturbed by `p`, scores it against the truth,
// writes its row of runs.csv, pools its offsets and prints it.
void RegisterStart(Bench* b, const TrueView& tv, const GrayImage& image, const View& whole,
                   double max_m, double max_deg, const Vector6d& p) {
  Run run;
  run.view = &tv;
  run.max_m = max_m;
  run.max_deg = max_deg;
  run.perturbation = p;
  const Rigid3d start = ApplyCorrection(tv.cam_from_world, p);
  Timer timer;
  const double cpu0 = bench::CpuSeconds();
  Frame frame = MakeFrame(*b, tv, image, start);
  LidarPoints warped, classed;
  SetFramePoints(*b, tv, start, &frame, &warped, &classed);
  run.result = RegisterFrames({frame}, start, b->options);
  const RegistrationResult& r = run.result;
  run.seconds = timer.ElapsedSeconds();
  run.cpu = bench::CpuSeconds() - cpu0;
  const RenderOptions& scoring = b->scoring_render;
  run.image_before = PixelOffsets(b->points, whole, tv.cam_from_world, start, scoring);
  run.image_after = PixelOffsets(b->points, whole, tv.cam_from_world, r.cam_from_lidar, scoring);
  const std::vector<double> vb = ViewOffsets(b->points, frame.views, tv.cam_from_world, start, scoring);
  const std::vector<double> va =
      ViewOffsets(b->points, frame.views, tv.cam_from_world, r.cam_from_lidar, scoring);
  ErrorStats(start, &run);
  MetricAtLevels(*b, frame, start, &run);
  if (std::getenv("MI_LINE_PROBE") != nullptr) LineProbe(*b, frame, start, run);
  const std::string size = SizeName(max_m);
  const Row row{size,       r.ok(),     run.image_before.median_px, run.image_after.median_px,
                Median(vb), Median(va), r.checks.sigma_px,          run.seconds};
  b->rows.push_back(row);
  // Pooled point offsets: a thinned sample (every 50th point) of every registration.
  for (size_t k = 0; k < run.image_before.offsets_px.size(); k += 50) {
    b->pooled_before[size].push_back(run.image_before.offsets_px[k]);
  }
  for (size_t k = 0; k < run.image_after.offsets_px.size(); k += 50) {
    b->pooled_after[size].push_back(run.image_after.offsets_px[k]);
  }
  run.reason = r.reason;
  std::replace(run.reason.begin(), run.reason.end(), ',', ';');
  std::replace(run.reason.begin(), run.reason.end(), '\n', ' ');
  WriteRunRow(run, row, b->runs);
  PrintRun(run, row, frame);
}

// MI_PERTURB="tx,ty,tz,roll,pitch,yaw" (m, deg) replaces the drawn start of every
// registration run (with MI_ONLY: one chosen start). False when it is not 6 numbers.
bool FixedPerturbation(Vector6d* p) {
  const char* v = std::getenv("MI_PERTURB");
  if (v == nullptr) return true;
  const std::vector<std::string> items = bench::SplitList(v);
  if (items.size() != 6) {
    std::fprintf(stderr, "MI_PERTURB needs 6 numbers\n");
    return false;
  }
  for (int i = 0; i < 6; ++i) (*p)[i] = std::atof(items[i].c_str());
  return true;
}

// One view: its inspections (MI_DUMP_DIR, MI_GROUND — which registers nothing —, MI_PROBE),
// then its registrations, DRAWS random starts of each size (each of tx, ty, tz uniform in ±A
// m, each angle in ±B°), the views cut for each start (the headings depend on the start
// pose). False on a bad MI_PERTURB.
bool RunView(Bench* b, const TrueView& tv) {
  const GrayImage image = ReadGrayImage(tv.image_path);
  const Frame truth_frame = MakeFrame(*b, tv, image, tv.cam_from_world);
  View whole;
  whole.camera = tv.camera;
  whole.image = image;
  if (const char* dump = std::getenv("MI_DUMP_DIR")) DumpViews(*b, tv, truth_frame, dump);
  if (std::getenv("MI_GROUND") != nullptr && !b->classes.plane_normals.empty()) {
    PrintGround(*b, tv, truth_frame);
    return true;
  }
  if (std::getenv("MI_PROBE") != nullptr) ProbeAtTruth(*b, tv, truth_frame);
  const std::string& magnitudes = b->args.magnitudes;
  for (const auto& [max_m, max_deg] : kSizes) {
    for (int d = 0; d < b->args.draws; ++d) {
      std::uniform_real_distribution<double> um(-max_m, max_m), ud(-max_deg, max_deg);
      Vector6d p;
      p << um(b->rng), um(b->rng), um(b->rng), ud(b->rng), ud(b->rng), ud(b->rng);
      const bool size_selected = magnitudes == "both" || (magnitudes == "small") == (max_m == 0.1);
      if (!size_selected || !Selected(tv.name, max_m)) continue;
      if (!FixedPerturbation(&p)) return false;
      RegisterStart(b, tv, image, whole, max_m, max_deg, p);
    }
  }
  return true;
}

// Per magnitude: the counts of ok, right and wrong, the median offsets and time; writes the
// histograms of the per-view median offsets and of the pooled point offsets.
void PrintSummary(const Bench& b) {
  for (const auto& [max_m, max_deg] : kSizes) {
    const std::string size = SizeName(max_m);
    int n = 0, ok = 0, ok_below = 0, all_below = 0, wrong_ok = 0, false_fail = 0;
    int ok_below_view = 0, all_below_view = 0;
    std::vector<double> before, after, time;
    for (const Row& r : b.rows) {
      if (r.size != size) continue;
      ++n;
      before.push_back(r.image_before);
      after.push_back(r.image_after);
      time.push_back(r.seconds);
      const bool below = r.image_after < 1.0;
      all_below += below;
      all_below_view += r.view_after < 1.0;
      if (r.ok) {
        ++ok;
        ok_below += below;
        ok_below_view += r.view_after < 1.0;
        wrong_ok += !below;
      } else {
        false_fail += below;
      }
    }
    if (n == 0) continue;
    std::printf("%s: %d registrations; %d ok, of which %d < 1 px in the image's pixels (%.1f %%) "
                "and %d < 1 px in the registered views' pixels; wrong ok (>= 1 px image): %d; "
                "failed but < 1 px: %d; all runs < 1 px: %d image, %d views; median offset "
                "before %.2f px, after %.2f px; median time %.1f s\n",
                size.c_str(), n, ok, ok_below, ok > 0 ? 100.0 * ok_below / ok : 0.0,
                ok_below_view, wrong_ok, false_fail, all_below, all_below_view, Median(before),
                Median(after), Median(time));
    const std::string tag = max_m == 0.1 ? "small" : "large";
    const fs::path& out_dir = b.args.out_dir;
    bench::WriteHistogram(out_dir / ("hist_views_" + tag + ".csv"), out_dir / ("hist_views_" + tag + ".svg"),
                          "Median pixel offset per view, start errors up to " + size + " (" +
                              std::to_string(n) + " registrations)",
                          "views", before, after, 0.5, 24, false);
    bench::WriteHistogram(out_dir / ("hist_points_" + tag + ".csv"), out_dir / ("hist_points_" + tag + ".svg"),
                          "Pixel offsets of the LiDAR points (pooled), start errors up to " + size,
                          "fraction", b.pooled_before.at(size), b.pooled_after.at(size), 0.5, 24, true);
  }
}

}  // namespace

int main(int argc, char** argv) {
  mmba::ReexecWithHugePageMalloc(argv);  // as the mmba binary does (core/huge_pages.h)
  Bench b;
  if (!ParseArgs(argc, argv, &b.args)) return 2;
  if (std::getenv("MMBA_DEBUG") != nullptr) SetVerbosity(Verbosity::kVerbose);
  else SetVerbosity(Verbosity::kQuiet);
  fs::create_directories(b.args.out_dir);
  const fs::path& dir = b.args.dir;
  const std::string cloud_path = b.args.cloud_kind == "static"
                                     ? (dir / "clouds" / "lidar.ply").string()
                                     : (dir / "truth" / "mobile_lidar_true.ply").string();
  Timer setup;
  if (!ReadPoints(b.args, cloud_path, &b.points)) return 2;
  b.stitch = ReadStitchRig(dir);
  b.classes = SetupClasses(&b.points);
  const std::vector<TrueView> views = ReadViews(dir, b.args.kinds);
  std::printf("%s: %zu points, %zu views, setup %.1f s\n", cloud_path.c_str(), b.points.size(),
              views.size(), setup.ElapsedSeconds());
  if (!PanoramaOptions(b.classes, &b.options, &b.scoring_render)) return 2;
  OpenRuns(&b);
  b.rng.seed(b.args.seed);
  for (const TrueView& tv : views) {
    if (!RunView(&b, tv)) return 2;
  }
  PrintSummary(b);
  std::printf("peak memory %.0f MiB\n", bench::PeakRssMiB());
  return 0;
}
