#pragma once

// Point-to-plane residuals (Chen & Medioni 1992, "Object modelling by registration of
// multiple range images"): the signed distance of a point from a local plane (n, q) of a
// LiDAR surface, n a unit normal, over its σ in metres.
//
// Quaternion blocks are Eigen coefficients [x, y, z, w]; translations and points are 3-vectors
// in metres.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ceres/autodiff_cost_function.h>
#include <ceres/sized_cost_function.h>

namespace mmba::factors {

/// A world point X on a world plane: r = n·(X − q)/σ_m, analytic Jacobian n/σ_m.
/// Block: point_in_world 3.
class PointToPlaneCost : public ceres::SizedCostFunction<1, 3> {
 public:
  PointToPlaneCost(const Eigen::Vector3d& normal, const Eigen::Vector3d& point, double sigma)
      : n_(normal / sigma), d_(normal.dot(point) / sigma) {}
  bool Evaluate(double const* const* p, double* r, double** j) const override {
    r[0] = n_.dot(Eigen::Map<const Eigen::Vector3d>(p[0])) - d_;
    if (j && j[0]) {
      Eigen::Map<Eigen::Vector3d> jacobian(j[0]);
      jacobian = n_;
    }
    return true;
  }

 private:
  Eigen::Vector3d n_;  ///< n/σ [1/m]
  double d_;           ///< n·q/σ
};

/// A world point X on a plane (n, q) given in a scan's frame:
///   r = n·(scan_from_world·X − q)/σ_m.
/// Blocks: scan_from_world rotation 4, translation 3, point_in_world 3.
struct ScanPointToPlaneCost {
  ScanPointToPlaneCost(const Eigen::Vector3d& normal, const Eigen::Vector3d& point, double sigma)
      : n(normal / sigma), q(point) {}

  static ceres::CostFunction* Create(const Eigen::Vector3d& normal, const Eigen::Vector3d& point,
                                     double sigma) {
    return new ceres::AutoDiffCostFunction<ScanPointToPlaneCost, 1, 4, 3, 3>(
        new ScanPointToPlaneCost(normal, point, sigma));
  }

  template <typename T>
  bool operator()(const T* q_sw, const T* t_sw, const T* x, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(q_sw);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t_sw), world(x);
    const Eigen::Matrix<T, 3, 1> in_scan = rotation * world + translation - q.cast<T>();
    r[0] = n.cast<T>().dot(in_scan);
    return true;
  }

  Eigen::Vector3d n;  ///< n/σ [1/m]
  Eigen::Vector3d q;  ///< plane point in the scan frame [m]
};

/// A point p of one static scan on another scan's plane (n, q), both scans' poses estimated:
///   r = n·(S_to·S_from⁻¹·p − q)/σ_m,   S = scan_from_world.
/// Blocks: S_from rotation 4, translation 3, S_to rotation 4, translation 3.
struct ScanToScanCost {
  ScanToScanCost(const Eigen::Vector3d& point_in_from, const Eigen::Vector3d& normal_in_to,
                 const Eigen::Vector3d& plane_point_in_to, double sigma_m)
      : p(point_in_from), n(normal_in_to / sigma_m), q(plane_point_in_to) {}

  static ceres::CostFunction* Create(const Eigen::Vector3d& point_in_from, const Eigen::Vector3d& normal_in_to,
                                     const Eigen::Vector3d& plane_point_in_to, double sigma_m) {
    return new ceres::AutoDiffCostFunction<ScanToScanCost, 1, 4, 3, 4, 3>(
        new ScanToScanCost(point_in_from, normal_in_to, plane_point_in_to, sigma_m));
  }

  template <typename T>
  bool operator()(const T* q_from, const T* t_from, const T* q_to, const T* t_to, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> r_from(q_from), r_to(q_to);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> tr_from(t_from), tr_to(t_to);
    const Eigen::Matrix<T, 3, 1> world = r_from.conjugate() * (p.cast<T>() - tr_from);
    r[0] = n.cast<T>().dot(r_to * world + tr_to - q.cast<T>());
    return true;
  }

  Eigen::Vector3d p;  ///< point in the `from` scan's frame [m]
  Eigen::Vector3d n;  ///< n/σ in the `to` scan's frame [1/m]
  Eigen::Vector3d q;  ///< plane point in the `to` scan's frame [m]
};

}  // namespace mmba::factors
