#pragma once

// Ray casting against a TriangleMesh with Intel Embree 3 (kept out of this header).

#include <memory>

#include <Eigen/Core>

#include "mmba/sim/mesh.h"

namespace mmba::sim {

/// The first surface a ray meets.
struct RayHit {
  bool hit = false;
  double distance_m = 0.0;        ///< along the (unit) ray direction
  int triangle = -1;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< world frame
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< unit geometric normal, facing the ray
};

/// A built acceleration structure over one mesh. Thread-safe for concurrent Intersect
/// calls. The mesh must outlive the caster.
class RayCaster {
 public:
  explicit RayCaster(const TriangleMesh& mesh);
  ~RayCaster();
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  /// Casts a ray from `origin` along `direction` (normalised here), between `min_m` and
  /// `max_m`.
  RayHit Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                   double min_m = 0.0, double max_m = 1e9) const;
  /// True when nothing blocks the segment a→b (ends excluded by `margin_m`).
  bool Visible(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double margin_m = 1e-3) const;

  const TriangleMesh& mesh() const { return mesh_; }

 private:
  struct Impl;
  const TriangleMesh& mesh_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mmba::sim
