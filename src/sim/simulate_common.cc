// Geometry and output-format helpers shared by the stages of mmba::sim::Simulate.

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "mmba/core/atomic_file.h"
#include "sim/simulate_internal.h"

namespace mmba::sim::internal {

using Eigen::Vector3d;

Rigid3d LookAt(const Vector3d& eye, const Vector3d& target, double roll_rad) {
  const Vector3d forward = (target - eye).normalized();
  Vector3d right = forward.cross(Vector3d::UnitZ());
  if (right.norm() < 1e-6) right = Vector3d::UnitX();
  right.normalize();
  const Vector3d down = forward.cross(right);
  Eigen::Matrix3d world_from_cam;
  world_from_cam << right, down, forward;
  const Eigen::Matrix3d roll = Eigen::AngleAxisd(roll_rad, Vector3d::UnitZ()).toRotationMatrix();
  return Rigid3d(Eigen::Quaterniond(world_from_cam * roll), eye).Inverse();
}

Eigen::Quaterniond SmallRotation(Rng* rng, double sigma_rad) {
  const Vector3d axis_angle(rng->Normal(sigma_rad), rng->Normal(sigma_rad), rng->Normal(sigma_rad));
  if (axis_angle.norm() < 1e-15) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(axis_angle.norm(), axis_angle.normalized()));
}

json MatrixJson(const Rigid3d& pose) {
  const Eigen::Matrix4d m = pose.ToMatrix4();
  json rows = json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  return rows;
}

json PoseJson(const Rigid3d& pose) {
  return json{{"qvec_wxyz", {pose.rotation.w(), pose.rotation.x(), pose.rotation.y(), pose.rotation.z()}},
              {"tvec", {pose.translation.x(), pose.translation.y(), pose.translation.z()}},
              {"matrix", MatrixJson(pose)}};
}

json VecJson(const Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

json CameraJson(const sensors::Camera& camera) {
  return json{{"model", camera.ModelName()}, {"width", camera.width}, {"height", camera.height},
              {"params", camera.params}};
}

void WriteText(const fs::path& path, const std::string& text) {
  WriteFileAtomically(path, [&](std::ostream& out) { out << text; });
}

std::string Fmt(double v, int precision) {
  std::ostringstream s;
  s << std::setprecision(precision) << std::fixed << v;
  return s.str();
}

std::string YamlList(const std::vector<double>& values, int precision) {
  std::ostringstream s;
  s << std::setprecision(precision) << "[";
  for (size_t i = 0; i < values.size(); ++i) s << (i ? ", " : "") << values[i];
  s << "]";
  return s.str();
}

std::string YamlPose(const Rigid3d& pose) {
  const auto& q = pose.rotation;
  return "{qvec_wxyz: " + YamlList({q.w(), q.x(), q.y(), q.z()}) +
         ", tvec: " + YamlList({pose.translation.x(), pose.translation.y(), pose.translation.z()}) + "}";
}

std::vector<SurfaceSample> SampleObjectSurface(const SimScene& scene, int count, uint64_t seed,
                                               uint64_t stream) {
  const TriangleMesh& mesh = scene.mesh;
  const Vector3d lo = scene.object_min - Vector3d::Constant(0.05);
  const Vector3d hi = scene.object_max + Vector3d::Constant(0.05);
  std::vector<double> cumulative;
  std::vector<int> index;
  double total = 0;
  for (size_t t = 0; t < mesh.NumTriangles(); ++t) {
    const Eigen::Vector3i& f = mesh.triangles[t];
    const Vector3d centroid = (mesh.vertices[f[0]] + mesh.vertices[f[1]] + mesh.vertices[f[2]]) / 3.0;
    if ((centroid.array() < lo.array()).any() || (centroid.array() > hi.array()).any()) continue;
    total += mesh.TriangleArea(t);
    cumulative.push_back(total);
    index.push_back(static_cast<int>(t));
  }
  std::vector<SurfaceSample> samples;
  if (index.empty()) return samples;
  Rng rng(seed, stream);
  samples.reserve(count);
  for (int i = 0; i < count; ++i) {
    const double u = rng.Uniform() * total;
    const size_t k = std::min(index.size() - 1,
                              static_cast<size_t>(std::lower_bound(cumulative.begin(), cumulative.end(), u) -
                                                  cumulative.begin()));
    const int t = index[k];
    const Eigen::Vector3i& f = mesh.triangles[t];
    double a = rng.Uniform(), b = rng.Uniform();
    if (a + b > 1) {
      a = 1 - a;
      b = 1 - b;
    }
    const Vector3d p = mesh.vertices[f[0]] + a * (mesh.vertices[f[1]] - mesh.vertices[f[0]]) +
                       b * (mesh.vertices[f[2]] - mesh.vertices[f[0]]);
    samples.push_back({p, mesh.TriangleNormal(t), t});
  }
  return samples;
}

bool SeesPoint(const RayCaster& caster, const Vector3d& eye, const Vector3d& point,
               double tolerance_m) {
  const Vector3d d = point - eye;
  const double length = d.norm();
  const RayHit hit = caster.Intersect(eye, d / length, 1e-3, length + 1.0);
  return hit.hit && std::abs(hit.distance_m - length) < tolerance_m;
}

}  // namespace mmba::sim::internal
