// The spherical stereo pairs of mmba::sim::Simulate: two equirectangular spheres on a tilted
// mast per station, their images, the tie-point observations and approximate station setups,
// and the nominal calibration (the truth differs by the principal points and the mast tilt).

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "mmba/sim/render.h"
#include "sim/simulate_internal.h"

namespace mmba::sim::internal {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

// The two true sphere cameras (lower, upper): nominal parameters with the principal point off
// by U(−a, a) per axis.
std::array<sensors::Camera, 2> SphereCameras(const Context& c) {
  const SphereOptions& o = c.options.spheres;
  Rng rng(c.options.seed, 0x5F4C);
  const int w = o.width, h = o.width / 2;
  std::array<sensors::Camera, 2> truth_cam;
  const auto nominal = sensors::EquirectangularModel::DefaultParams(w, h);
  for (int k = 0; k < 2; ++k) {
    truth_cam[k].camera_id = CameraId(k + 1);
    truth_cam[k].model_id = sensors::CameraModelId::kEquirectangular;
    truth_cam[k].width = w;
    truth_cam[k].height = h;
    truth_cam[k].params = {nominal[0], nominal[1] + rng.Uniform(-o.principal_offset_px, o.principal_offset_px),
                           nominal[2] + rng.Uniform(-o.principal_offset_px, o.principal_offset_px)};
  }
  return truth_cam;
}

// Renders both spheres of every station into images/spherical; returns the stations' truth.
json RenderSpheres(Context* c, const std::vector<SphereStation>& stations,
                   const std::array<sensors::Camera, 2>& truth_cam) {
  json jstations = json::array();
  const RayTable sphere_rays[2] = {MakeRayTable(truth_cam[0], c->options.render.samples_per_axis, c->options.threads),
                                   MakeRayTable(truth_cam[1], c->options.render.samples_per_axis, c->options.threads)};
  for (size_t s = 0; s < stations.size(); ++s) {
    const Rigid3d poses[2] = {stations[s].lower_from_world, stations[s].upper_from_world};
    const char* which[2] = {"lower", "upper"};
    for (int k = 0; k < 2; ++k) {
      const GrayImage image = RenderImage(c->caster, c->scene, truth_cam[k], poses[k], c->options.render,
                                          c->options.seed, 2000 + 2 * s + k, c->options.threads,
                                          &sphere_rays[k]);
      WritePng(image, (c->out / "images" / "spherical" / (stations[s].name + "_" + which[k] + ".png")).string());
      ++c->result.sphere_images;
    }
    jstations.push_back({{"name", stations[s].name},
                         {"lower_from_world", PoseJson(poses[0])},
                         {"upper_from_world", PoseJson(poses[1])},
                         {"images", {"images/spherical/" + stations[s].name + "_lower.png",
                                     "images/spherical/" + stations[s].name + "_upper.png"}}});
  }
  return jstations;
}

// Tie-point observations of the spheres (the photos' tie points seen from a station, true
// projection + N(0, 0.5 px)) into observations/spherical.csv, and approximate station setups
// (position 5 cm, heading 1°) into spherical_stations.csv; both only when there are tie points.
// Returns the number of observations.
size_t WriteSphereObservations(const Context& c, const std::vector<SphereStation>& stations,
                               const std::array<sensors::Camera, 2>& truth_cam) {
  const int w = truth_cam[0].width, h = truth_cam[0].height;
  Rng noise(c.options.seed, 0x5F51);
  std::ostringstream observations, setups;
  observations << "# mmba simulate: tie-point observations in the spherical images (point ids of colmap/photos)\n"
                  "image,point_id,x_px,y_px,sigma_px\n";
  setups << "# mmba simulate: approximate spherical station setups (lower sphere centre, heading of its forward axis from north)\n"
            "station,east_m,north_m,up_m,heading_deg\n";
  size_t num_observations = 0;
  for (size_t s = 0; s < stations.size(); ++s) {
    const Rigid3d poses[2] = {stations[s].lower_from_world, stations[s].upper_from_world};
    const char* which[2] = {"lower", "upper"};
    for (int k = 0; k < 2; ++k) {
      const Vector3d eye = poses[k].Inverse().translation;
      for (const auto& [id, point] : c.tie_points) {
        const auto xy = truth_cam[k].ImgFromCam(poses[k] * point);
        if (!xy || !SeesPoint(c.caster, eye, point)) continue;
        const Vector2d measured = *xy + Vector2d(noise.Normal(0.5), noise.Normal(0.5));
        if (!InsideImage(measured, w, h)) continue;
        observations << stations[s].name << "_" << which[k] << ".png," << id << "," << Fmt(measured.x(), 3) << ","
                     << Fmt(measured.y(), 3) << ",0.5\n";
        ++num_observations;
      }
    }
    const Rigid3d world_from_lower = stations[s].lower_from_world.Inverse();
    const Vector3d forward = world_from_lower.rotation * Vector3d::UnitZ();
    const Vector3d centre = world_from_lower.translation + Vector3d(noise.Normal(0.05), noise.Normal(0.05), noise.Normal(0.05));
    setups << stations[s].name << "," << Fmt(centre.x(), 4) << "," << Fmt(centre.y(), 4) << "," << Fmt(centre.z(), 4) << ","
           << Fmt(std::atan2(forward.x(), forward.y()) / kDeg + noise.Normal(1.0), 3) << "\n";
  }
  if (!c.tie_points.empty()) {
    WriteText(c.out / "observations" / "spherical.csv", observations.str());
    WriteText(c.out / "spherical_stations.csv", setups.str());
  }
  return num_observations;
}

// The truth entry, the nominal calibration file and the project's spherical sensor.
void RecordSpheres(Context* c, const std::vector<SphereStation>& stations,
                   const std::array<sensors::Camera, 2>& truth_cam, const json& jstations, size_t num_observations) {
  const SphereOptions& o = c->options.spheres;
  const int w = o.width, h = o.width / 2;
  const auto nominal = sensors::EquirectangularModel::DefaultParams(w, h);
  c->truth["spherical_stereo"] = {{"lower_camera", CameraJson(truth_cam[0])},
                                  {"upper_camera", CameraJson(truth_cam[1])},
                                  {"baseline_m", o.baseline_m},
                                  {"stations", jstations}};
  WriteText(c->out / "calib" / "spherical_stereo.yaml",
            "# Nominal calibration of the spherical line-scan stereo pair (EQUIRECTANGULAR: f, cx, cy).\n"
            "# The true principal points differ by up to " + Fmt(o.principal_offset_px, 1) +
                " px and the mast is tilted by up to " + Fmt(o.axis_tilt_deg, 3) + " deg (truth/truth.json).\n"
            "model: EQUIRECTANGULAR\nwidth: " + std::to_string(w) + "\nheight: " + std::to_string(h) +
                "\nlower_params: " + YamlList({nominal[0], nominal[1], nominal[2]}) +
                "\nupper_params: " + YamlList({nominal[0], nominal[1], nominal[2]}) +
                "\nbaseline_m: " + Fmt(o.baseline_m) + "  # vertical, lower to upper sphere\n");
  c->project_sensors << "  - id: spherical\n    type: spherical_stereo\n    images: images/spherical\n"
                        "    calibration: calib/spherical_stereo.yaml\n    stations: [";
  for (size_t s = 0; s < stations.size(); ++s) c->project_sensors << (s ? ", " : "") << stations[s].name;
  c->project_sensors << "]\n    baseline_sigma_m: 0.001\n    sigma_px: 0.5\n";
  if (!c->tie_points.empty()) {
    c->project_sensors << "    stations_file: spherical_stations.csv\n    observations: observations/spherical.csv  # "
                       << num_observations << " tie-point observations\n    tie_block: photos\n";
  }
}

}  // namespace

std::vector<SphereStation> SphereStations(Context* c) {
  const SphereOptions& o = c->options.spheres;
  std::vector<SphereStation> stations;
  Rng rng(c->options.seed, 0x5F4E);
  const double distance = std::max(6.0, 0.9 * c->framing.width);
  for (int s = 0; s < o.stations; ++s) {
    const double t = o.stations == 1 ? 0.5 : static_cast<double>(s) / (o.stations - 1);
    const double azimuth = (-40.0 + 80.0 * t) * kDeg;
    const Vector3d ground(c->framing.centre.x() + distance * std::sin(azimuth),
                          c->framing.front_y - distance * std::cos(azimuth), 0.0);
    // Upright sphere frame looking at the object (x right, y down, z forward), then the
    // mast tilt (the calibration error) about the two horizontal axes.
    const Vector3d lower = ground + Vector3d(0, 0, o.lower_height_m);
    const Rigid3d upright = LookAt(lower, Vector3d(c->framing.centre.x(), c->framing.front_y, lower.z()));
    const Eigen::Quaterniond tilt =
        Eigen::AngleAxisd(rng.Uniform(-o.axis_tilt_deg, o.axis_tilt_deg) * kDeg, Vector3d::UnitX()) *
        Eigen::AngleAxisd(rng.Uniform(-o.axis_tilt_deg, o.axis_tilt_deg) * kDeg, Vector3d::UnitZ());
    const Eigen::Quaterniond world_from_sphere = upright.Inverse().rotation * tilt;
    // The baseline runs along the sphere's own up axis (−y), i.e. along the tilted mast.
    const Vector3d upper = lower + o.baseline_m * (world_from_sphere * Vector3d(0, -1, 0));
    SphereStation station;
    station.name = "S" + std::to_string(s + 1);
    station.lower_from_world = Rigid3d(world_from_sphere, lower).Inverse();
    station.upper_from_world = Rigid3d(world_from_sphere, upper).Inverse();
    stations.push_back(station);
  }
  return stations;
}

void SimulateSpheres(Context* c, const std::vector<SphereStation>& stations) {
  if (stations.empty()) return;
  const std::array<sensors::Camera, 2> truth_cam = SphereCameras(*c);
  const json jstations = RenderSpheres(c, stations, truth_cam);
  const size_t num_observations = WriteSphereObservations(*c, stations, truth_cam);
  RecordSpheres(c, stations, truth_cam, jstations, num_observations);
}

}  // namespace mmba::sim::internal
