// The reconstruction-like clouds of mmba::sim::Simulate: what the other modalities would
// deliver of the object (spherical stereo, multi-view stereo, a plane proxy), each with a
// documented error model, placed in a random block frame (the registration truth) and also
// cropped to the object's western part.

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "mmba/io_cloud/point_cloud.h"
#include "mmba/sim/texture.h"
#include "sim/simulate_internal.h"

namespace mmba::sim::internal {
namespace {

using Eigen::Vector3d;

// The material of a surface sample: its intensity (albedo) and whether it is glass.
struct SampleMaterial {
  const TriangleMesh& mesh;
  uint64_t seed;
  float Intensity(const SurfaceSample& s) const {
    const Material& m = mesh.materials[mesh.triangle_material[s.triangle]];
    return static_cast<float>(Albedo(m, s.point, s.normal, seed));
  }
  bool IsGlass(const SurfaceSample& s) const {
    return mesh.materials[mesh.triangle_material[s.triangle]].material_class == MaterialClass::kGlass;
  }
};

// (1) Spherical stereo: points seen by both spheres of a station; range error of a
// vertical-baseline pair σ_r = r²·σ_d / (f·b·sin θ) (the depth error of stereo, Z²σ_d/(f b),
// with the effective baseline b·sin θ perpendicular to the ray; θ from the vertical),
// along the ray from the lower sphere. Rays within 12° of the vertical are dropped.
io::PointCloud StereoCloud(const Context& c, const std::vector<SurfaceSample>& samples,
                           const std::vector<SphereStation>& stations, const SampleMaterial& look, Rng* rng) {
  const CloudOptions& o = c.options.clouds;
  const double f_sphere = o.stereo_width_px / (2 * M_PI);
  io::PointCloud stereo;
  for (const SurfaceSample& s : samples) {
    if (look.IsGlass(s) || stations.empty()) continue;
    const SphereStation& st = stations[rng->Next() % stations.size()];
    const Vector3d lower = st.lower_from_world.Inverse().translation;
    const Vector3d upper = st.upper_from_world.Inverse().translation;
    if (!SeesPoint(c.caster, lower, s.point) || !SeesPoint(c.caster, upper, s.point)) continue;
    const Vector3d ray = s.point - lower;
    const double r = ray.norm();
    const double sin_theta = std::hypot(ray.x(), ray.y()) / r;
    if (sin_theta < std::sin(12 * kDeg)) continue;
    const double sigma = r * r * o.stereo_disparity_sigma_px / (f_sphere * c.options.spheres.baseline_m * sin_theta);
    stereo.points.push_back(s.point + rng->Normal(sigma) * ray / r);
    stereo.intensity.push_back(look.Intensity(s));
  }
  return stereo;
}

// (2) Multi-view: points seen by ≥ 2 photos, a subset (coarser), isotropic noise growing
// with the distance to the nearest camera (σ = multi_view_sigma_m · d / 10 m), holes
// (spheres of 0.5–1.5 m removed: textureless or occluded parts), and uniform outliers.
io::PointCloud MultiViewCloud(const Context& c, const std::vector<SurfaceSample>& samples,
                              const std::vector<Rigid3d>& photo_poses, const SampleMaterial& look, Rng* rng) {
  const CloudOptions& o = c.options.clouds;
  io::PointCloud multi_view;
  std::vector<Vector3d> holes;
  std::vector<double> hole_radii;
  for (int k = 0; k < o.multi_view_holes && !samples.empty(); ++k) {
    holes.push_back(samples[rng->Next() % samples.size()].point);
    hole_radii.push_back(rng->Uniform(0.5, 1.5));
  }
  for (const SurfaceSample& s : samples) {
    if (look.IsGlass(s) || rng->Uniform() > o.multi_view_keep) continue;
    bool in_hole = false;
    for (size_t k = 0; k < holes.size(); ++k) in_hole |= (s.point - holes[k]).norm() < hole_radii[k];
    if (in_hole) continue;
    int seen = 0;
    double nearest = 1e9;
    for (const Rigid3d& pose : photo_poses) {
      const Vector3d eye = pose.Inverse().translation;
      const Vector3d p_cam = pose * s.point;
      if (p_cam.z() <= 0) continue;
      if (!SeesPoint(c.caster, eye, s.point)) continue;
      nearest = std::min(nearest, (eye - s.point).norm());
      if (++seen >= 2) break;
    }
    if (seen < 2) continue;
    const double sigma = o.multi_view_sigma_m * nearest / 10.0;
    multi_view.points.push_back(s.point + Vector3d(rng->Normal(sigma), rng->Normal(sigma), rng->Normal(sigma)));
    multi_view.intensity.push_back(look.Intensity(s));
  }
  const size_t outliers = static_cast<size_t>(o.multi_view_outliers * multi_view.size());
  for (size_t k = 0; k < outliers; ++k) {
    multi_view.points.push_back(Vector3d(rng->Uniform(c.scene.object_min.x(), c.scene.object_max.x()),
                                         rng->Uniform(c.scene.object_min.y() - 2, c.scene.object_max.y()),
                                         rng->Uniform(c.scene.object_min.z(), c.scene.object_max.z())));
    multi_view.intensity.push_back(static_cast<float>(rng->Uniform()));
  }
  return multi_view;
}

// (3) Plane proxy: surface samples binned by dominant normal axis and coordinate
// (plane_bin_m); bins holding ≥ 0.5 % of the samples become an axis-aligned plane at the
// bins' mean coordinate; points are projected onto it and thinned to one per voxel.
io::PointCloud PlaneProxyCloud(const Context& c, const std::vector<SurfaceSample>& samples,
                               const SampleMaterial& look) {
  const CloudOptions& o = c.options.clouds;
  io::PointCloud proxy;
  std::map<std::pair<int, long>, std::vector<size_t>> bins;
  for (size_t i = 0; i < samples.size(); ++i) {
    if (look.IsGlass(samples[i])) continue;
    int axis;
    samples[i].normal.cwiseAbs().maxCoeff(&axis);
    bins[{axis, std::lround(samples[i].point[axis] / o.plane_bin_m)}].push_back(i);
  }
  std::map<std::tuple<long, long, long>, bool> voxels;
  for (const auto& [key, members] : bins) {
    if (members.size() < 0.005 * samples.size()) continue;
    double mean = 0;
    for (size_t i : members) mean += samples[i].point[key.first];
    mean /= members.size();
    for (size_t i : members) {
      Vector3d p = samples[i].point;
      p[key.first] = mean;
      const auto voxel = std::make_tuple(std::lround(p.x() / o.plane_voxel_m), std::lround(p.y() / o.plane_voxel_m),
                                         std::lround(p.z() / o.plane_voxel_m));
      if (voxels.count(voxel)) continue;
      voxels[voxel] = true;
      proxy.points.push_back(p);
      proxy.intensity.push_back(look.Intensity(samples[i]));
    }
  }
  return proxy;
}

// A random block frame: any heading, ±5° tilt, within ±10 m horizontally and ±2 m vertically.
Rigid3d RandomBlockTransform(Rng* rng) {
  const Eigen::Quaterniond rotation =
      Eigen::AngleAxisd(rng->Uniform(0, 2 * M_PI), Vector3d::UnitZ()) *
      Eigen::AngleAxisd(rng->Uniform(-5, 5) * kDeg, Vector3d::UnitX()) *
      Eigen::AngleAxisd(rng->Uniform(-5, 5) * kDeg, Vector3d::UnitY());
  return Rigid3d(rotation, Vector3d(rng->Uniform(-10, 10), rng->Uniform(-10, 10), rng->Uniform(-2, 2)));
}

// Writes clouds/<name>.ply in a random block frame and clouds/<name>_part.ply (the object's
// western part_fraction), their viewpoints and their world_from_<name> registration truth.
void WriteBlockCloud(Context* c, const std::string& name, const io::PointCloud& cloud_in_world,
                     const std::vector<Vector3d>& sensors_in_world, Rng* rng) {
  const Rigid3d world_from_cloud = RandomBlockTransform(rng);
  const Rigid3d cloud_from_world = world_from_cloud.Inverse();
  io::PointCloud cloud = cloud_in_world;
  for (auto& p : cloud.points) p = cloud_from_world * p;
  io::WritePly(cloud, (c->out / "clouds" / (name + ".ply")).string());
  WriteViewpoints(c, name, cloud_from_world, sensors_in_world);
  c->registration_truth["world_from_" + name] = MatrixJson(world_from_cloud);
  // Partial crop: the western part of the object.
  const double x_cut = c->scene.object_min.x() +
                       c->options.clouds.part_fraction * (c->scene.object_max.x() - c->scene.object_min.x());
  io::PointCloud part;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (cloud_in_world.points[i].x() > x_cut) continue;
    part.points.push_back(cloud.points[i]);
    if (cloud.has_intensity()) part.intensity.push_back(cloud.intensity[i]);
  }
  io::WritePly(part, (c->out / "clouds" / (name + "_part.ply")).string());
  c->registration_truth["world_from_" + name + "_part"] = MatrixJson(world_from_cloud);
}

}  // namespace

void SimulateClouds(Context* c, const std::vector<SphereStation>& stations,
                    const std::vector<Rigid3d>& photo_poses) {
  const CloudOptions& o = c->options.clouds;
  if (o.surface_samples == 0) return;
  const std::vector<SurfaceSample> samples = SampleObjectSurface(c->scene, o.surface_samples, c->options.seed, 0xC10D);
  Rng rng(c->options.seed, 0xC10E);
  const SampleMaterial look{c->scene.mesh, c->options.seed};
  const io::PointCloud stereo = StereoCloud(*c, samples, stations, look, &rng);
  const io::PointCloud multi_view = MultiViewCloud(*c, samples, photo_poses, look, &rng);
  const io::PointCloud proxy = PlaneProxyCloud(*c, samples, look);
  std::vector<Vector3d> stereo_stations, camera_centres;
  for (const SphereStation& st : stations) stereo_stations.push_back(st.lower_from_world.Inverse().translation);
  for (const Rigid3d& pose : photo_poses) camera_centres.push_back(pose.Inverse().translation);
  WriteBlockCloud(c, "spherical_stereo", stereo, stereo_stations, &rng);
  WriteBlockCloud(c, "multi_view", multi_view, camera_centres, &rng);
  WriteBlockCloud(c, "plane_proxy", proxy, {}, &rng);
  c->truth["clouds"] = {
      {"spherical_stereo", {{"points", stereo.size()}, {"model", "sigma_r = r^2 sigma_d / (f b sin(theta)) along the ray from the lower sphere"},
                            {"disparity_sigma_px", o.stereo_disparity_sigma_px},
                            {"stereo_width_px", o.stereo_width_px}, {"baseline_m", c->options.spheres.baseline_m}}},
      {"multi_view", {{"points", multi_view.size()}, {"model", "kept fraction, holes, isotropic sigma = multi_view_sigma_m * d / 10 m, uniform outliers"},
                      {"multi_view_sigma_m", o.multi_view_sigma_m}, {"holes", o.multi_view_holes},
                      {"outlier_fraction", o.multi_view_outliers}}},
      {"plane_proxy", {{"points", proxy.size()}, {"model", "axis-aligned planes fitted to binned surface samples, voxel-thinned"},
                       {"bin_m", o.plane_bin_m}, {"voxel_m", o.plane_voxel_m}}}};
}

}  // namespace mmba::sim::internal
