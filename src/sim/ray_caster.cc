#include "mmba/sim/ray_caster.h"

#include <limits>
#include <stdexcept>
#include <string>

#include <embree3/rtcore.h>

namespace mmba::sim {

struct RayCaster::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

RayCaster::RayCaster(const TriangleMesh& mesh) : mesh_(mesh), impl_(std::make_unique<Impl>()) {
  mesh.Validate("ray caster mesh");
  // One worker thread for the build: the machine is shared and the meshes are small.
  impl_->device = rtcNewDevice("threads=1");
  if (!impl_->device) {
    throw std::runtime_error("Embree: rtcNewDevice failed (error " +
                             std::to_string(rtcGetDeviceError(nullptr)) + ")");
  }
  impl_->scene = rtcNewScene(impl_->device);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geometry = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
      mesh.vertices.size()));
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    for (int k = 0; k < 3; ++k) vertices[3 * i + k] = static_cast<float>(mesh.vertices[i][k]);
  }
  auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
      mesh.triangles.size()));
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    for (int k = 0; k < 3; ++k) indices[3 * i + k] = static_cast<unsigned>(mesh.triangles[i][k]);
  }
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(impl_->scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(impl_->scene);
}

RayCaster::~RayCaster() = default;

RayHit RayCaster::Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                            double min_m, double max_m) const {
  const Eigen::Vector3d dir = direction.normalized();
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit query;
  query.ray.org_x = static_cast<float>(origin.x());
  query.ray.org_y = static_cast<float>(origin.y());
  query.ray.org_z = static_cast<float>(origin.z());
  query.ray.dir_x = static_cast<float>(dir.x());
  query.ray.dir_y = static_cast<float>(dir.y());
  query.ray.dir_z = static_cast<float>(dir.z());
  query.ray.tnear = static_cast<float>(min_m);
  query.ray.tfar = static_cast<float>(std::min(max_m, 1e30));
  query.ray.time = 0.0f;
  query.ray.mask = 0xFFFFFFFFu;
  query.ray.id = 0;
  query.ray.flags = 0;
  query.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  query.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &context, &query);
  RayHit hit;
  if (query.hit.geomID == RTC_INVALID_GEOMETRY_ID) return hit;
  hit.hit = true;
  hit.triangle = static_cast<int>(query.hit.primID);
  // Embree works in float; recompute the distance in double against the exact triangle
  // plane so that points lie on the mesh to ~1e-9 m rather than ~1e-6 relative.
  const Eigen::Vector3i& t = mesh_.triangles[hit.triangle];
  const Eigen::Vector3d& a = mesh_.vertices[t[0]];
  Eigen::Vector3d normal = (mesh_.vertices[t[1]] - a).cross(mesh_.vertices[t[2]] - a).normalized();
  const double denom = normal.dot(dir);
  double distance = query.ray.tfar;
  if (std::abs(denom) > 1e-12) distance = normal.dot(a - origin) / denom;
  if (denom > 0) normal = -normal;
  hit.distance_m = distance;
  hit.point = origin + distance * dir;
  hit.normal = normal;
  return hit;
}

bool RayCaster::Visible(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                        double margin_m) const {
  const Eigen::Vector3d d = b - a;
  const double length = d.norm();
  if (length <= 2 * margin_m) return true;
  const RayHit hit = Intersect(a, d / length, margin_m, length - margin_m);
  return !hit.hit;
}

}  // namespace mmba::sim
