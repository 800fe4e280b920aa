#include "mmba/io_project/project.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include "mmba/core/error.h"
#include "mmba/io/camera_yaml.h"
#include "mmba/io/yaml_reader.h"
#include "mmba/registration/mi/lidar_image.h"
#include "project_internal.h"

namespace mmba::adjust {
namespace {

namespace fs = std::filesystem;
using Node = const YAML::Node&;
using Field = const std::string&;

class ProjectReader {
 public:
  ProjectReader(const std::string& path, Project* project)
      : r_(path), project_(project), dir_(fs::path(path).parent_path()) {}

  const io::YamlReader& r() const { return r_; }

  /// A path relative to the project file that must exist (a file or, if `folder`, a folder).
  std::string ExistingPath(Node n, Field f, bool folder) const {
    const fs::path given = r_.String(n, f);
    const fs::path full = given.is_absolute() ? given : dir_ / given;
    if (!fs::exists(full)) r_.Fail(n, f, folder ? "an existing folder" : "an existing file", given.string() + " (not found)");
    if (folder != fs::is_directory(full)) r_.Fail(n, f, folder ? "a folder" : "a file", given.string());
    return full.string();
  }

  LossOptions Loss(Node n, Field f) const {
    LossOptions loss;
    if (n.IsScalar()) {
      const std::string name = r_.String(n, f);
      if (!ParseLossType(name, &loss.type)) r_.Fail(n, f, "none, huber, cauchy or soft_l1", name);
      loss.scale = 3.0;
      return loss;
    }
    r_.Map(n, f, {{"type", [&](Node v, Field g) {
                     const std::string name = r_.String(v, g);
                     if (!ParseLossType(name, &loss.type)) r_.Fail(v, g, "none, huber, cauchy or soft_l1", name);
                   }},
                  {"scale", [&](Node v, Field g) { loss.scale = r_.Positive(v, g, 100.0, "σ units"); }}});
    return loss;
  }

  /// A `refine` list: focal, principal_point and (cameras with distortion) distortion.
  RefineIntrinsics Refine(Node n, Field f, bool distortion) const {
    RefineIntrinsics refine{false, false, false};
    const std::vector<std::string> list = r_.StringList(n, f);
    for (size_t i = 0; i < list.size(); ++i) {
      if (list[i] == "focal") refine.focal = true;
      else if (list[i] == "principal_point") refine.principal_point = true;
      else if (list[i] == "distortion" && distortion) refine.distortion = true;
      else r_.Fail(n[i], f + "[" + std::to_string(i) + "]",
                   distortion ? "focal, principal_point or distortion" : "focal or principal_point", list[i]);
    }
    return refine;
  }

  /// σ in pixels: inconsistent units (metres or micrometres given for pixels) fail here.
  double SigmaPx(Node n, Field f) const { return r_.Positive(n, f, 50.0, "px"); }
  /// σ in metres: a value above `hi` is almost certainly millimetres given as metres.
  double SigmaM(Node n, Field f, double hi) const { return r_.Positive(n, f, hi, "m (metres)"); }
  /// 0 (the term is off) or a number in (0, hi].
  double ZeroOrPositive(Node n, Field f, double hi, const std::string& unit) const {
    const double value = r_.Number(n, f);
    if (!(value >= 0 && value <= hi)) {
      r_.Fail(n, f, "0 (off) or a number in (0, " + io::YamlReader::Text(YAML::Node(hi)) + "] " + unit, io::YamlReader::Text(n));
    }
    return value;
  }
  /// `fixed`, `weighted` or `free`: how a calibrated pose enters the adjustment.
  PoseTreatment Treatment(Node n, Field f) const {
    const std::string value = r_.String(n, f);
    for (PoseTreatment t : {PoseTreatment::kFixed, PoseTreatment::kWeighted, PoseTreatment::kFree}) {
      if (value == PoseTreatmentName(t)) return t;
    }
    r_.Fail(n, f, "fixed, weighted or free", value);
    return PoseTreatment::kFree;
  }
  /// A correlation time in seconds: 0 (independent epochs) or positive, at most a day.
  double CorrelationTime(Node n, Field f) const {
    const double value = r_.Number(n, f);
    if (!(value >= 0 && value <= 86400.0)) r_.Fail(n, f, "seconds in [0, 86400] (0 = independent epochs)", io::YamlReader::Text(n));
    return value;
  }

  /// `mi_orientation_classes`: register-mi --orientation-classes, 0 (the plain metric) to 13.
  int MiOrientationClasses(Node n, Field f) const {
    const int value = r_.Integer(n, f);
    constexpr int kMax = registration::mi::kMaxLidarClasses - 3;
    if (value < 0 || value > kMax) {
      r_.Fail(n, f, "0 (the plain metric) to " + std::to_string(kMax) + " azimuth sectors", io::YamlReader::Text(n));
    }
    return value;
  }

  /// `mi_register`: true, false, or a list of image/frame names (only those are registered).
  void MiRegister(Node n, Field f, bool* on, std::vector<std::string>* only) const {
    if (n.IsSequence()) {
      *only = r_.StringList(n, f);
      if (only->empty()) r_.Fail(n, f, "true, false or a non-empty list of image names", "an empty list");
      *on = true;
    } else {
      *on = r_.Bool(n, f);
    }
  }

  void Sensor(Node n, Field f, std::set<std::string>* ids) {
    if (!n.IsMap()) r_.Fail(n, f, "a mapping {id, type, ...}", io::YamlReader::Kind(n));
    r_.Require(n, f, {"id", "type"});
    const std::string id = r_.String(n["id"], f + ".id");
    if (!ids->insert(id).second) r_.Fail(n["id"], f + ".id", "a unique sensor id", id + " (used twice)");
    const std::string type = r_.String(n["type"], f + ".type");
    const int line = n.Mark().line + 1;
    if (type == "photo_collection") {
      PhotoSensor(n, f, id, line);
    } else if (type == "total_station") {
      TotalStationSensor(n, f, id, line);
    } else if (type == "gnss") {
      GnssSensor(n, f, id, line);
    } else if (type == "lidar_static") {
      LidarStaticSensor(n, f, id, line);
    } else if (type == "lidar_mobile") {
      LidarMobileSensor(n, f, id, line);
    } else if (type == "photo_measurements") {
      project_->photo_measurements.push_back(project_internal::ReadPhotoMeasurements(r_, n, f, id, dir_.string()));
    } else if (type == "spherical_stereo" || type == "camera_rig") {
      // Validated (keys, files, σ), not adjusted without observations (docs/project-yaml.md).
      const bool adjusted = type == "spherical_stereo" ? SphericalSensor(n, f, id, line) : RigSensor(n, f, id, line);
      if (!adjusted) project_->other_sensors.push_back({id, type, line});
    } else {
      r_.Fail(n["type"], f + ".type",
              "photo_collection, photo_measurements, total_station, gnss, lidar_static, spherical_stereo, camera_rig or lidar_mobile", type);
    }
  }

  /// A photo_collection.
  void PhotoSensor(Node n, Field f, const std::string& id, int line) {
    const auto keep = [](Node, Field) {};
    const auto path = [&](std::string* out, bool folder) {
      return [this, out, folder](Node v, Field g) { *out = ExistingPath(v, g, folder); };
    };
    PhotoCollection p;
    p.id = id;
    p.line = line;
    r_.Map(n, f, {{"id", keep}, {"type", keep},
                  {"images", path(&p.images, true)},
                  {"calibration", path(&p.calibration, false)},
                  {"colmap_model", path(&p.colmap_model, true)},
                  {"control_measurements", path(&p.control_measurements, false)},
                  {"mi_results", path(&p.mi_results, true)},
                  {"mi_register", [&](Node v, Field g) { MiRegister(v, g, &p.mi_register, &p.mi_only); }},
                  {"mi_orientation_classes", [&](Node v, Field g) { p.mi_orientation_classes = MiOrientationClasses(v, g); }},
                  {"sigma_px", [&](Node v, Field g) { p.sigma_px = SigmaPx(v, g); }},
                  {"control_sigma_px", [&](Node v, Field g) { p.control_sigma_px = SigmaPx(v, g); }},
                  {"gnss_lever_arm_m", [&](Node v, Field g) {
                     const std::vector<double> lever = r_.NumberList(v, g);
                     if (lever.size() != 3) r_.Fail(v, g, "[x, y, z] in metres (the antenna in the camera frame)", io::YamlReader::Text(v));
                     for (double c : lever) {
                       if (!(std::abs(c) <= 10)) r_.Fail(v, g, "a lever arm within 10 m (in metres)", io::YamlReader::Text(v));
                     }
                     p.gnss_lever_arm_m = Eigen::Vector3d(lever[0], lever[1], lever[2]);
                   }},
                  {"register_to_lidar", [&](Node v, Field g) { p.register_to_lidar = r_.Bool(v, g); }},
                  {"registration_window_m", [&](Node v, Field g) { p.registration_window_m = r_.Positive(v, g, 100.0, "m (metres)"); }},
                  {"registration_window_deg", [&](Node v, Field g) { p.registration_window_deg = r_.Positive(v, g, 180.0, "degrees"); }},
                  {"lidar_scale_range", [&](Node v, Field g) {
                     const std::vector<double> range = r_.NumberList(v, g);
                     if (range.size() != 2 || !(range[0] > 0) || !(range[1] > range[0]) || !(range[1] <= 1e6)) {
                       r_.Fail(v, g, "[min, max] with 0 < min < max <= 1e6 (world metres per block unit)", io::YamlReader::Text(v));
                     }
                     p.lidar_scale_min = range[0];
                     p.lidar_scale_max = range[1];
                   }},
                  {"loss", [&](Node v, Field g) { p.loss = Loss(v, g); }},
                  {"refine", [&](Node v, Field g) { p.refine = Refine(v, g, true); }}});
    r_.Require(n, f, {"images"});
    project_->photos.push_back(p);
  }

  /// A total_station (one per project).
  void TotalStationSensor(Node n, Field f, const std::string& id, int line) {
    const auto keep = [](Node, Field) {};
    const auto path = [&](std::string* out, bool folder) {
      return [this, out, folder](Node v, Field g) { *out = ExistingPath(v, g, folder); };
    };
    TotalStation t;
    t.id = id;
    t.line = line;
    r_.Map(n, f, {{"id", keep}, {"type", keep}, {"file", path(&t.file, false)},
                  {"loss", [&](Node v, Field g) { t.loss = Loss(v, g); }}});
    r_.Require(n, f, {"file"});
    if (!project_->total_stations.empty()) r_.Fail(n, f, "one total_station sensor (merge the networks into one file)", "a second one");
    project_->total_stations.push_back(t);
  }

  /// A gnss sensor.
  void GnssSensor(Node n, Field f, const std::string& id, int line) {
    const auto keep = [](Node, Field) {};
    const auto path = [&](std::string* out, bool folder) {
      return [this, out, folder](Node v, Field g) { *out = ExistingPath(v, g, folder); };
    };
    Gnss g;
    g.id = id;
    g.line = line;
    r_.Map(n, f, {{"id", keep}, {"type", keep}, {"file", path(&g.file, false)},
                  {"photos", [&](Node v, Field h) { GnssPhotos(v, h, &g); }},
                  {"loss", [&](Node v, Field h) { g.loss = Loss(v, h); }}});
    if (g.file.empty() == g.photos.empty()) {
      r_.Fail(n, f, "one of file (a GNSS CSV) or photos (EXIF positions)", g.file.empty() ? "neither" : "both");
    }
    project_->gnss.push_back(g);
  }

  /// A gnss sensor's `photos: {folder, sigma_horizontal_m, sigma_vertical_m, geoid_undulation_m}`.
  void GnssPhotos(Node n, Field f, Gnss* g) {
    r_.Map(n, f, {{"folder", [&](Node v, Field h) { g->photos = ExistingPath(v, h, true); }},
                  {"sigma_horizontal_m", [&](Node v, Field h) { g->photos_sigma_horizontal_m = SigmaM(v, h, 10.0); }},
                  {"sigma_vertical_m", [&](Node v, Field h) { g->photos_sigma_vertical_m = SigmaM(v, h, 10.0); }},
                  {"geoid_undulation_m", [&](Node v, Field h) {
                     g->photos_geoid_undulation_m = r_.Number(v, h);
                     if (std::abs(g->photos_geoid_undulation_m) > 150) {
                       r_.Fail(v, h, "a geoid undulation N in [-150, 150] m", io::YamlReader::Text(v));
                     }
                   }}});
    r_.Require(n, f, {"folder", "sigma_horizontal_m", "sigma_vertical_m", "geoid_undulation_m"});
  }

  /// A lidar_static.
  void LidarStaticSensor(Node n, Field f, const std::string& id, int line) {
    const auto keep = [](Node, Field) {};
    const auto path = [&](std::string* out, bool folder) {
      return [this, out, folder](Node v, Field g) { *out = ExistingPath(v, g, folder); };
    };
    LidarStatic l;
    l.id = id;
    l.line = line;
    r_.Map(n, f, {{"id", keep}, {"type", keep},
                  {"reference_cloud", path(&l.reference_cloud, false)},
                  {"scans", [&](Node v, Field g) {
                     if (!v.IsSequence()) r_.Fail(v, g, "a list of {file}", io::YamlReader::Kind(v));
                     for (size_t i = 0; i < v.size(); ++i) {
                       const std::string gi = g + "[" + std::to_string(i) + "]";
                       LidarScanFile scan;
                       scan.line = v[i].Mark().line + 1;
                       r_.Map(v[i], gi, {{"file", path(&scan.file, false)},
                                         {"world_from_scan", [&](Node w, Field h) {
                                            scan.world_from_scan = io::ReadYamlPose(r_, w, h);
                                            scan.has_pose = true;
                                          }},
                                         {"approximate", [&](Node w, Field h) { scan.approximate = r_.Bool(w, h); }}});
                       r_.Require(v[i], gi, {"file"});
                       l.scans.push_back(scan);
                     }
                   }},
                  {"range_sigma_m", [&](Node v, Field g) { l.range_sigma_m = SigmaM(v, g, 0.5); }},
                  {"surface_sigma_m", [&](Node v, Field g) { l.surface_sigma_m = SigmaM(v, g, 0.5); }},
                  {"max_distance_m", [&](Node v, Field g) { l.max_distance_m = SigmaM(v, g, 10.0); }},
                  {"targets", path(&l.targets, false)},
                  {"scans_levelled", [&](Node v, Field g) { l.scans_levelled = r_.Bool(v, g); }},
                  {"scan_sigma_m", [&](Node v, Field g) { l.scan_sigma_m = SigmaM(v, g, 10.0); }},
                  {"scan_sigma_deg", [&](Node v, Field g) { l.scan_sigma_deg = r_.Positive(v, g, 30.0, "degrees"); }},
                  {"scan_points", [&](Node v, Field g) {
                     l.scan_points = r_.Integer(v, g);
                     if (l.scan_points < 100 || l.scan_points > 1000000) r_.Fail(v, g, "an integer in [100, 1000000]", io::YamlReader::Text(v));
                   }},
                  {"loss", [&](Node v, Field g) { l.loss = Loss(v, g); }}});
    r_.Require(n, f, {"reference_cloud"});
    for (size_t i = 0; i < l.scans.size(); ++i) {
      if (l.scans[i].approximate && !l.scans[i].has_pose) {
        r_.Fail(n["scans"][i], f + ".scans[" + std::to_string(i) + "].approximate", "world_from_scan with it", "approximate without world_from_scan");
      }
    }
    project_->lidar_static.push_back(l);
  }

  /// A lidar_mobile.
  void LidarMobileSensor(Node n, Field f, const std::string& id, int line) {
    const auto keep = [](Node, Field) {};
    const auto path = [&](std::string* out, bool folder) {
      return [this, out, folder](Node v, Field g) { *out = ExistingPath(v, g, folder); };
    };
    LidarMobile m;
    m.id = id;
    m.line = line;
    const auto degrees = [&](double* out, double hi) {
      return [this, out, hi](Node v, Field g) { *out = r_.Positive(v, g, hi, "degrees"); };
    };
    const auto metres = [&](double* out, double hi) {
      return [this, out, hi](Node v, Field g) { *out = SigmaM(v, g, hi); };
    };
    r_.Map(n, f, {{"id", keep}, {"type", keep}, {"cloud", path(&m.cloud, false)},
                  {"trajectory", path(&m.trajectory, false)}, {"calibration", path(&m.calibration, false)},
                  {"rig", [&](Node v, Field g) { m.rig = r_.String(v, g); }},
                  {"range_sigma_m", metres(&m.range_sigma_m, 0.5)},
                  {"surface_sigma_m", metres(&m.surface_sigma_m, 0.5)},
                  {"max_distance_m", metres(&m.max_distance_m, 10.0)},
                  {"points", [&](Node v, Field g) {
                     m.points = r_.Integer(v, g);
                     if (m.points < 100 || m.points > 5000000) r_.Fail(v, g, "an integer in [100, 5000000]", r_.Text(v));
                   }},
                  {"node_spacing_s", [&](Node v, Field g) { m.node_spacing_s = r_.Positive(v, g, 600.0, "seconds"); }},
                  {"max_range_m", [&](Node v, Field g) {
                     double number = 0;
                     if (v.IsScalar() && v.Scalar() == "auto") {
                       m.max_range_m = -1.0;
                     } else if (!v.IsScalar() || !YAML::convert<double>::decode(v, number)) {
                       r_.Fail(v, g, "metres, 0 (no limit) or auto", r_.Text(v));
                     } else {
                       m.max_range_m = ZeroOrPositive(v, g, 10000.0, "m (metres), or auto");
                     }
                   }},
                  {"trajectory_sigma_m", metres(&m.trajectory_sigma_m, 10.0)},
                  {"trajectory_sigma_deg", degrees(&m.trajectory_sigma_deg, 30.0)},
                  {"trajectory_correlation_s", [&](Node v, Field g) { m.trajectory_correlation_s = CorrelationTime(v, g); }},
                  {"smoothness_sigma_m", [&](Node v, Field g) { m.smoothness_sigma_m = ZeroOrPositive(v, g, 1.0, "m (metres)"); }},
                  {"smoothness_sigma_deg", [&](Node v, Field g) { m.smoothness_sigma_deg = ZeroOrPositive(v, g, 10.0, "degrees"); }},
                  {"frame_sigma_m", metres(&m.frame_sigma_m, 1.0)},
                  {"frame_sigma_deg", degrees(&m.frame_sigma_deg, 10.0)},
                  {"extrinsic", [&](Node v, Field g) { m.extrinsic = Treatment(v, g); }},
                  {"extrinsic_sigma_m", metres(&m.extrinsic_sigma_m, 1.0)},
                  {"extrinsic_sigma_deg", degrees(&m.extrinsic_sigma_deg, 30.0)},
                  {"loss", [&](Node v, Field g) { m.loss = Loss(v, g); }}});
    r_.Require(n, f, {"cloud", "trajectory", "calibration"});
    project_->lidar_mobile.push_back(m);
  }

  /// A spherical_stereo; true when it has observations (adjusted), false when only validated.
  bool SphericalSensor(Node n, Field f, const std::string& id, int line) {
    const auto keep = [](Node, Field) {};
    const auto path = [&](std::string* out, bool folder) {
      return [this, out, folder](Node v, Field g) { *out = ExistingPath(v, g, folder); };
    };
    SphericalStereo p;
    p.id = id;
    p.line = line;
    r_.Map(n, f, {{"id", keep}, {"type", keep}, {"images", path(&p.images, true)},
                  {"calibration", path(&p.calibration, false)},
                  {"stations", [&](Node v, Field g) { p.stations = r_.StringList(v, g); }},
                  {"stations_file", path(&p.stations_file, false)},
                  {"observations", path(&p.observations, false)},
                  {"tie_block", [&](Node v, Field g) { p.tie_block = r_.String(v, g); }},
                  {"baseline_sigma_m", [&](Node v, Field g) { p.baseline_sigma_m = SigmaM(v, g, 0.5); }},
                  {"sigma_px", [&](Node v, Field g) { p.sigma_px = SigmaPx(v, g); }},
                  {"loss", [&](Node v, Field g) { p.loss = Loss(v, g); }},
                  {"dense_cloud", [&](Node v, Field g) { p.dense_cloud = r_.Bool(v, g); }},
                  {"register_to_lidar", [&](Node v, Field g) { p.register_to_lidar = r_.Bool(v, g); }},
                  {"setup_window_m", [&](Node v, Field g) { p.setup_window_m = ZeroOrPositive(v, g, 100.0, "m (metres)"); }},
                  {"setup_window_deg", [&](Node v, Field g) { p.setup_window_deg = r_.Positive(v, g, 180.0, "degrees"); }},
                  {"refine", [&](Node v, Field g) {
                     const RefineIntrinsics refine = Refine(v, g, false);
                     p.refine_focal = refine.focal;
                     p.refine_principal_point = refine.principal_point;
                   }}});
    r_.Require(n, f, {"images", "calibration"});
    if (!p.observations.empty() || !p.stations_file.empty()) {
      r_.Require(n, f, {"observations", "stations_file", "tie_block"});
      project_->spherical.push_back(p);
      return true;
    }
    return false;
  }

  /// A camera_rig; true when it has observations (adjusted), false when only validated.
  bool RigSensor(Node n, Field f, const std::string& id, int line) {
    const auto keep = [](Node, Field) {};
    const auto path = [&](std::string* out, bool folder) {
      return [this, out, folder](Node v, Field g) { *out = ExistingPath(v, g, folder); };
    };
    CameraRig p;
    p.id = id;
    p.line = line;
    r_.Map(n, f, {{"id", keep}, {"type", keep}, {"images", path(&p.images, true)},
                  {"panoramas", path(&p.panoramas, true)}, {"calibration", path(&p.calibration, false)},
                  {"mi_results", path(&p.mi_results, true)},
                  {"mi_register", [&](Node v, Field g) { MiRegister(v, g, &p.mi_register, &p.mi_only); }},
                {"mi_orientation_classes", [&](Node v, Field g) { p.mi_orientation_classes = MiOrientationClasses(v, g); }},
                  {"mi_lidar", [&](Node v, Field g) {
                     const std::string value = r_.String(v, g);
                     if (value != "static" && value != "mobile") r_.Fail(v, g, "static or mobile", value);
                     p.mi_lidar = value == "mobile" ? MiLidar::kMobile : MiLidar::kStatic;
                   }},
                  {"mi_incidence_correction", [&](Node v, Field g) { p.mi_incidence_correction = r_.Bool(v, g); }},
                  {"mi_time_window_s", [&](Node v, Field g) { p.mi_time_window_s = r_.Positive(v, g, 60.0, "seconds"); }},
                  {"mi_views", [&](Node v, Field g) {
                     const std::string value = r_.String(v, g);
                     if (value != "panoramas" && value != "cameras") r_.Fail(v, g, "panoramas or cameras", value);
                     p.mi_views = value == "cameras" ? MiViews::kCameras : MiViews::kPanoramas;
                   }},
                  {"trajectory", path(&p.trajectory, false)}, {"frames_file", path(&p.frames_file, false)},
                  {"observations", path(&p.observations, false)},
                  {"tie_block", [&](Node v, Field g) { p.tie_block = r_.String(v, g); }},
                  {"sigma_px", [&](Node v, Field g) { p.sigma_px = SigmaPx(v, g); }},
                  {"trajectory_sigma_m", [&](Node v, Field g) { p.trajectory_sigma_m = SigmaM(v, g, 10.0); }},
                  {"trajectory_sigma_deg", [&](Node v, Field g) { p.trajectory_sigma_deg = r_.Positive(v, g, 30.0, "degrees"); }},
                  {"trajectory_correlation_s", [&](Node v, Field g) { p.trajectory_correlation_s = CorrelationTime(v, g); }},
                  {"cam_from_rig", [&](Node v, Field g) { p.cam_from_rig = Treatment(v, g); }},
                  {"cam_from_rig_sigma_m", [&](Node v, Field g) { p.cam_from_rig_sigma_m = SigmaM(v, g, 1.0); }},
                  {"cam_from_rig_sigma_deg", [&](Node v, Field g) { p.cam_from_rig_sigma_deg = r_.Positive(v, g, 30.0, "degrees"); }},
                  {"loss", [&](Node v, Field g) { p.loss = Loss(v, g); }},
                  {"refine", [&](Node v, Field g) { p.refine = Refine(v, g, true); }}});
    r_.Require(n, f, {"images", "calibration"});
    if ((p.mi_register && p.mi_views == MiViews::kPanoramas) || !p.mi_results.empty()) r_.Require(n, f, {"panoramas"});
    if (!p.observations.empty() || !p.frames_file.empty()) {
      r_.Require(n, f, {"observations", "frames_file", "trajectory", "tie_block"});
      project_->rigs.push_back(p);
      return true;
    }
    return false;
  }

 private:
  io::YamlReader r_;
  Project* project_;
  fs::path dir_;
};

/// check_points: each once, and a total station that surveys them; a project has photos or a
/// total station.
void CheckCheckPoints(const Project& project, const io::YamlReader& r, const YAML::Node& root) {
  std::set<std::string> seen;
  for (size_t i = 0; i < project.check_points.size(); ++i) {
    if (!seen.insert(project.check_points[i]).second) {
      r.Fail(root["check_points"][i], "check_points[" + std::to_string(i) + "]", "each point once", project.check_points[i]);
    }
  }
  bool gcp_list = false;
  for (const PhotoMeasurements& p : project.photo_measurements) gcp_list = gcp_list || !p.gcp_list.empty();
  if (!project.check_points.empty() && project.total_stations.empty() && !project.control && !gcp_list) {
    r.Fail(root["check_points"], "check_points", "a total_station sensor, a control file or a gcp_list that surveys them", "none");
  }
  if (project.photos.empty() && project.total_stations.empty() && project.photo_measurements.empty()) {
    r.Fail(root["sensors"], "sensors", "at least a photo_collection, photo_measurements or total_station", "none of them");
  }
}

/// Sensors that name other sensors (tie_block, rig, mi_lidar) name ones that exist, and the
/// sensors a sensor needs (a mobile LiDAR needs a static one and photos) are present.
void CheckSensorReferences(const Project& project, const std::string& path) {
  for (const SphericalStereo& sphere : project.spherical) {
    bool found = false;
    for (const PhotoCollection& p : project.photos) found = found || p.id == sphere.tie_block;
    if (!found) {
      throw InputError(path, sphere.line, "tie_block", sphere.tie_block, "the id of a photo_collection sensor");
    }
  }
  for (const CameraRig& rig : project.rigs) {
    bool found = false;
    for (const PhotoCollection& p : project.photos) found = found || p.id == rig.tie_block;
    if (!found) throw InputError(path, rig.line, "tie_block", rig.tie_block, "the id of a photo_collection sensor");
  }
  for (const LidarMobile& m : project.lidar_mobile) {
    if (project.lidar_static.empty()) {
      throw InputError(path, m.line, "type", "lidar_mobile",
                       "a lidar_static sensor too: the mobile points are tied to its reference surface");
    }
    if (project.photos.empty()) {
      throw InputError(path, m.line, "type", "lidar_mobile", "a photo_collection too (its block bounds the LiDAR surface)");
    }
    if (m.rig.empty()) continue;
    bool found = false;
    for (const CameraRig& rig : project.rigs) found = found || rig.id == m.rig;
    if (!found) throw InputError(path, m.line, "rig", m.rig, "the id of a camera_rig sensor with observations");
  }
  // MI registration runs against the static LiDAR (the world-frame cloud).
  for (const PhotoCollection& p : project.photos) {
    if (p.register_to_lidar && project.lidar_static.empty()) {
      throw InputError(path, p.line, "register_to_lidar", "true", "a lidar_static sensor too: the block's tie points are registered to its reference cloud");
    }
    if (p.mi_register && project.lidar_static.empty()) {
      throw InputError(path, p.line, "mi_register", "true", "a lidar_static sensor too: the photos are registered to its reference cloud");
    }
  }
  for (const CameraRig& rig : project.rigs) {
    if (rig.mi_lidar == MiLidar::kMobile) {
      const bool carried = std::any_of(project.lidar_mobile.begin(), project.lidar_mobile.end(),
                                       [&](const LidarMobile& m) { return m.rig == rig.id; });
      if (!carried) {
        throw InputError(path, rig.line, "mi_lidar", "mobile",
                         "a lidar_mobile sensor with rig: " + rig.id + " (the panoramas are registered to its cloud)");
      }
    } else if (rig.mi_register && project.lidar_static.empty()) {
      throw InputError(path, rig.line, "mi_register", "true", "a lidar_static sensor too: the panoramas are registered to its reference cloud");
    }
  }
  if (project.lidar_mobile.size() > 1) {
    throw InputError(path, project.lidar_mobile[1].line, "type", "lidar_mobile", "one lidar_mobile sensor in this version");
  }
}

}  // namespace

const char* PoseTreatmentName(PoseTreatment treatment) {
  switch (treatment) {
    case PoseTreatment::kFixed: return "fixed";
    case PoseTreatment::kWeighted: return "weighted";
    case PoseTreatment::kFree: return "free";
  }
  return "free";
}

Project LoadProject(const std::string& path) {
  Project project;
  project.path = path;
  project.dir = fs::path(path).parent_path().string();
  ProjectReader reader(path, &project);
  const io::YamlReader& r = reader.r();
  const YAML::Node root = r.Load("project file");
  if (!root.IsMap()) r.Fail(root, "(file)", "a mapping with mmba_project, name, origin, sensors", io::YamlReader::Kind(root));
  r.Require(root, "", {"mmba_project", "sensors"});
  std::set<std::string> ids;
  bool have_origin = false;
  r.Map(root, "", {
      {"mmba_project", [&](Node n, Field f) {
         const int version = r.Integer(n, f);
         if (version != 1) r.Fail(n, f, "1", std::to_string(version));
       }},
      {"name", [&](Node n, Field f) { project.name = r.String(n, f); }},
      {"origin", [&](Node n, Field f) {
         r.Map(n, f, {{"latitude_deg", [&](Node v, Field g) {
                         project.origin.latitude_deg = r.Number(v, g);
                         if (std::abs(project.origin.latitude_deg) > 90) r.Fail(v, g, "a latitude in [-90, 90] degrees", r.Text(v));
                       }},
                      {"longitude_deg", [&](Node v, Field g) {
                         project.origin.longitude_deg = r.Number(v, g);
                         if (std::abs(project.origin.longitude_deg) > 180) r.Fail(v, g, "a longitude in [-180, 180] degrees", r.Text(v));
                       }},
                      {"height_m", [&](Node v, Field g) {
                         project.origin.height_m = r.Number(v, g);
                         if (std::abs(project.origin.height_m) > 10000) r.Fail(v, g, "an ellipsoidal height in metres (|h| <= 10 km)", r.Text(v));
                       }}});
         r.Require(n, f, {"latitude_deg", "longitude_deg", "height_m"});
         have_origin = true;
       }},
      {"simulated", [&](Node n, Field f) {
         r.Map(n, f, {{"seed", [](Node, Field) {}}, {"preset", [](Node, Field) {}},
                      {"truth", [&](Node v, Field g) { project.truth = reader.ExistingPath(v, g, false); }}});
       }},
      {"check_points", [&](Node n, Field f) { project.check_points = r.StringList(n, f); }},
      {"frame", [&](Node n, Field f) { project.frame = project_internal::ReadFrame(r, n, f); }},
      {"crs", [](Node, Field) {}},  // read below, with geoid_grid
      {"geoid_grid", [](Node, Field) {}},
      {"control", [&](Node n, Field f) { project.control = project_internal::ReadControl(r, n, f, project.dir); }},
      {"scale_bars", [&](Node n, Field f) { project.scale_bars = project_internal::ReadScaleBars(r, n, f); }},
      {"adjustment", [&](Node n, Field f) {
         AdjustSettings& s = project.settings;
         r.Map(n, f, {{"max_iterations", [&](Node v, Field g) {
                         s.max_iterations = r.Integer(v, g);
                         if (s.max_iterations < 1) r.Fail(v, g, "an integer >= 1", r.Text(v));
                       }},
                      {"outer_iterations", [&](Node v, Field g) {
                         s.outer_iterations = r.Integer(v, g);
                         if (s.outer_iterations < 1 || s.outer_iterations > 20) r.Fail(v, g, "an integer in [1, 20]", r.Text(v));
                       }},
                      {"confidence", [&](Node v, Field g) {
                         s.confidence = r.Number(v, g);
                         if (!(s.confidence > 0.5 && s.confidence < 1)) r.Fail(v, g, "a probability in (0.5, 1)", r.Text(v));
                       }},
                      {"outlier_sigma", [&](Node v, Field g) { s.outlier_sigma = r.Positive(v, g, 100, "σ units"); }},
                      {"variance_components", [&](Node v, Field g) { s.variance_components = r.Bool(v, g); }}});
       }},
      {"sensors", [&](Node n, Field f) {
         if (!n.IsSequence() || n.size() == 0) r.Fail(n, f, "a non-empty list of sensors", io::YamlReader::Kind(n));
         for (size_t i = 0; i < n.size(); ++i) reader.Sensor(n[i], f + "[" + std::to_string(i) + "]", &ids);
       }},
  });
  project_internal::ReadCrs(r, root["crs"], root["geoid_grid"], &project);
  const bool gcp_origin = project_internal::ApplyGcpListCrs(r, root, have_origin, &project);
  project_internal::SetCrsOrigin(r, root, have_origin || gcp_origin, &project);
  project_internal::CheckPhotogrammetricKeys(project, r, root, have_origin || project.crs);
  CheckCheckPoints(project, r, root);
  CheckSensorReferences(project, path);
  if (project.name.empty()) project.name = fs::path(path).parent_path().filename().string();
  return project;
}

std::optional<geodesy::CrsFrame> ProjectCrsFrame(const Project& project) {
  if (!project.crs) return std::nullopt;
  return geodesy::CrsFrame(project.crs, project.origin);
}

double MobileMaxRange(const LidarMobile& mobile) {
  if (mobile.max_range_m >= 0) return mobile.max_range_m;
  return mobile.max_distance_m / std::tan(mobile.trajectory_sigma_deg * M_PI / 180.0);
}

}  // namespace mmba::adjust
