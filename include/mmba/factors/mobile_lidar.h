#pragma once

// Residuals of a mobile LiDAR and a camera rig on a vehicle whose GNSS/INS trajectory is
// corrected (factors/trajectory_correction.h): LiDAR points on planes of a static surface,
// rig frames on the trajectory, and MI pose priors of rig frames against the delivered cloud.
//
// Frames: world (local tangent plane, m), body (GNSS/INS), vehicle (the rig / vehicle frame),
// lidar. body_from_vehicle is fixed; vehicle_from_lidar is the estimated extrinsic.
// Node blocks are 6-vectors [ω (rad), δ (m)]; quaternion blocks are Eigen coefficients
// [x, y, z, w]; α ∈ [0, 1] is the weight of the second node at the observation's time.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include "mmba/factors/trajectory_correction.h"
#include "mmba/geometry/rigid3d.h"

namespace mmba::factors {

/// A mobile LiDAR point p on a world plane (n, q):
///   X = CorrectedWorldPoint(a, b, α, ins, body_from_vehicle·vehicle_from_lidar·p),
///   r = n·(X − q)/σ_m   (point-to-plane, Chen & Medioni 1992).
/// Blocks: nodes a, b (6 each), vehicle_from_lidar rotation 4, translation 3.
struct MobilePointCost {
  MobilePointCost(const Eigen::Vector3d& point_lidar, double alpha, const Rigid3d& ins, const Eigen::Vector3d& normal,
                  const Eigen::Vector3d& plane_point, double sigma_m, const Rigid3d& body_from_vehicle)
      : point_lidar(point_lidar),
        alpha(alpha),
        ins(ins),
        normal(normal),
        plane_point(plane_point),
        sigma_m(sigma_m),
        body_from_vehicle(body_from_vehicle) {}

  static ceres::CostFunction* Create(const Eigen::Vector3d& point_lidar, double alpha, const Rigid3d& ins,
                                     const Eigen::Vector3d& normal, const Eigen::Vector3d& plane_point,
                                     double sigma_m, const Rigid3d& body_from_vehicle) {
    return new ceres::AutoDiffCostFunction<MobilePointCost, 1, 6, 6, 4, 3>(
        new MobilePointCost(point_lidar, alpha, ins, normal, plane_point, sigma_m, body_from_vehicle));
  }

  /// The point in the world through the corrected trajectory (nodes a, b) and the extrinsic.
  template <typename T>
  Eigen::Matrix<T, 3, 1> World(const T* a, const T* b, const T* q, const T* t) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(q);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t);
    const Eigen::Matrix<T, 3, 1> in_vehicle = rotation * point_lidar.cast<T>() + translation;
    const Eigen::Matrix<T, 3, 1> in_body =
        body_from_vehicle.rotation.cast<T>() * in_vehicle + body_from_vehicle.translation.cast<T>();
    return CorrectedWorldPoint(a, b, alpha, ins, in_body);
  }

  template <typename T>
  bool operator()(const T* a, const T* b, const T* q, const T* t, T* r) const {
    r[0] = normal.cast<T>().dot(World(a, b, q, t) - plane_point.cast<T>()) / T(sigma_m);
    return true;
  }

  Eigen::Vector3d point_lidar;  ///< p in the LiDAR frame [m]
  double alpha;
  Rigid3d ins;                  ///< GNSS/INS world_from_body at the point's time
  Eigen::Vector3d normal;       ///< unit n
  Eigen::Vector3d plane_point;  ///< q [m]
  double sigma_m;
  Rigid3d body_from_vehicle;
};

/// The same point on an adjusted static scan's plane (n, q in the scan frame):
///   r = n·(S·X − q)/σ_m,   S = scan_from_world.
/// Blocks: nodes a, b, vehicle_from_lidar (q 4, t 3), scan_from_world (q 4, t 3).
struct MobileScanPointCost {
  explicit MobileScanPointCost(const MobilePointCost& point) : point(point) {}

  static ceres::CostFunction* Create(const MobilePointCost& point) {
    return new ceres::AutoDiffCostFunction<MobileScanPointCost, 1, 6, 6, 4, 3, 4, 3>(new MobileScanPointCost(point));
  }

  template <typename T>
  bool operator()(const T* a, const T* b, const T* q, const T* t, const T* q_sw, const T* t_sw, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(q_sw);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t_sw);
    const Eigen::Matrix<T, 3, 1> in_scan = rotation * point.World(a, b, q, t) + translation;
    r[0] = point.normal.cast<T>().dot(in_scan - point.plane_point.cast<T>()) / T(point.sigma_m);
    return true;
  }

  MobilePointCost point;
};

/// A rig frame on the corrected trajectory: rig_from_world (q, t) against the predicted
/// world_from_rig = (Exp(ω)·R_ins·R_br, CorrectedWorldPoint(t_br)), B = body_from_rig:
///   r[0..2] = (c − c_predicted)/σ_m,  c = −Rᵀt the rig centre in the world [m],
///   r[3..5] = AngleAxis(R_predictedᵀ·R_world_from_rig)/σ_rad.
/// Blocks: nodes a, b (6 each), rig_from_world rotation 4, translation 3.
struct FrameOnTrajectoryCost {
  FrameOnTrajectoryCost(double alpha, const Rigid3d& ins, const Rigid3d& body_from_rig, double sigma_m,
                        double sigma_rad)
      : alpha(alpha), ins(ins), body_from_rig(body_from_rig), w_m(1 / sigma_m), w_rad(1 / sigma_rad) {}

  static ceres::CostFunction* Create(double alpha, const Rigid3d& ins, const Rigid3d& body_from_rig, double sigma_m,
                                     double sigma_rad) {
    return new ceres::AutoDiffCostFunction<FrameOnTrajectoryCost, 6, 6, 6, 4, 3>(
        new FrameOnTrajectoryCost(alpha, ins, body_from_rig, sigma_m, sigma_rad));
  }

  template <typename T>
  bool operator()(const T* a, const T* b, const T* q, const T* t, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rig_from_world(q);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t);
    const Eigen::Matrix<T, 3, 1> centre = -(rig_from_world.conjugate() * translation);
    const Eigen::Matrix<T, 3, 1> predicted =
        CorrectedWorldPoint<T>(a, b, alpha, ins, body_from_rig.translation.cast<T>().eval());
    for (int k = 0; k < 3; ++k) r[k] = (centre[k] - predicted[k]) * T(w_m);
    // Predicted world_from_rig rotation: Exp(ω)·R_ins·R_body_from_rig.
    T omega[3];
    for (int k = 0; k < 3; ++k) omega[k] = (1.0 - alpha) * a[k] + alpha * b[k];
    T omega_q[4];
    ceres::AngleAxisToQuaternion(omega, omega_q);  // w x y z
    const Eigen::Quaternion<T> correction(omega_q[0], omega_q[1], omega_q[2], omega_q[3]);
    const Eigen::Quaternion<T> world_from_rig = correction * ins.rotation.cast<T>() * body_from_rig.rotation.cast<T>();
    // world_from_rig_predicted⁻¹ · world_from_rig_estimated = identity when they agree.
    const Eigen::Quaternion<T> delta = world_from_rig.conjugate() * rig_from_world.conjugate();
    const T dq[4] = {delta.w(), delta.x(), delta.y(), delta.z()};
    T angle_axis[3];
    ceres::QuaternionToAngleAxis(dq, angle_axis);
    for (int k = 0; k < 3; ++k) r[3 + k] = angle_axis[k] * T(w_rad);
    return true;
  }

  double alpha;
  Rigid3d ins;  ///< GNSS/INS world_from_body at the frame's time
  Rigid3d body_from_rig;
  double w_m, w_rad;  ///< 1/σ_m [1/m], 1/σ_rad [1/rad]
};

/// A pose prior on a rig frame given against the mobile LiDAR's delivered cloud (the MI
/// registration of Wang, Ferrie & Macfarlane, CVPRW 2012, calibrating the camera–LiDAR
/// extrinsic over many frames). The predicted pose is
///   rig_from_delivered = rig_from_world · world_from_lidar · (ins·body_from_lidar_nominal)⁻¹,
///   world_from_lidar = CorrectedPose(a, b, α, ins) · body_from_vehicle · vehicle_from_lidar,
/// and `PosePrior` (a functor (q 4, t 3) → 6 residuals, e.g. registration::mi::MiPosePrior)
/// gives the whitened residual on it.
/// Blocks: nodes a, b (6 each), vehicle_from_lidar (q 4, t 3), rig_from_world (q 4, t 3).
template <typename PosePrior>
struct MobileMiFrameCost {
  MobileMiFrameCost(double alpha, const Rigid3d& ins, const Rigid3d& body_from_vehicle,
                    const Rigid3d& body_from_lidar_nominal, const PosePrior& prior)
      : alpha(alpha),
        ins(ins),
        body_from_vehicle(body_from_vehicle),
        delivered_from_lidar(ins * body_from_lidar_nominal),
        prior(prior) {}

  static ceres::CostFunction* Create(double alpha, const Rigid3d& ins, const Rigid3d& body_from_vehicle,
                                     const Rigid3d& body_from_lidar_nominal, const PosePrior& prior) {
    return new ceres::AutoDiffCostFunction<MobileMiFrameCost, 6, 6, 6, 4, 3, 4, 3>(
        new MobileMiFrameCost(alpha, ins, body_from_vehicle, body_from_lidar_nominal, prior));
  }

  template <typename T>
  bool operator()(const T* a, const T* b, const T* q_vl, const T* t_vl, const T* q_rw, const T* t_rw, T* r) const {
    using Quaternion = Eigen::Quaternion<T>;
    using Vector = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Quaternion> vehicle_from_lidar(q_vl);
    const Eigen::Map<const Vector> vehicle_from_lidar_t(t_vl);
    const Eigen::Map<const Quaternion> rig_from_world(q_rw);
    const Eigen::Map<const Vector> rig_from_world_t(t_rw);
    // Corrected world_from_body: (Exp(ω)·R_ins, p_ins + δ), as CorrectedWorldPoint.
    T omega[3], omega_q[4];
    Vector delta;
    for (int k = 0; k < 3; ++k) {
      omega[k] = (1.0 - alpha) * a[k] + alpha * b[k];
      delta[k] = (1.0 - alpha) * a[3 + k] + alpha * b[3 + k];
    }
    ceres::AngleAxisToQuaternion(omega, omega_q);  // w x y z
    const Quaternion world_from_body = Quaternion(omega_q[0], omega_q[1], omega_q[2], omega_q[3]) * ins.rotation.cast<T>();
    const Vector world_from_body_t = ins.translation.cast<T>() + delta;
    // world_from_lidar = world_from_body · body_from_vehicle · vehicle_from_lidar.
    const Quaternion body_from_lidar = body_from_vehicle.rotation.cast<T>() * vehicle_from_lidar;
    const Vector body_from_lidar_t =
        body_from_vehicle.rotation.cast<T>() * vehicle_from_lidar_t + body_from_vehicle.translation.cast<T>();
    const Quaternion world_from_lidar = world_from_body * body_from_lidar;
    const Vector world_from_lidar_t = world_from_body * body_from_lidar_t + world_from_body_t;
    // world_from_delivered = world_from_lidar · (delivered_from_lidar)⁻¹.
    const Quaternion lidar_from_delivered = delivered_from_lidar.rotation.conjugate().cast<T>();
    const Vector lidar_from_delivered_t = -(lidar_from_delivered * delivered_from_lidar.translation.cast<T>());
    const Quaternion world_from_delivered = world_from_lidar * lidar_from_delivered;
    const Vector world_from_delivered_t = world_from_lidar * lidar_from_delivered_t + world_from_lidar_t;
    // rig_from_delivered = rig_from_world · world_from_delivered.
    const Quaternion rig_from_delivered = rig_from_world * world_from_delivered;
    const Vector rig_from_delivered_t = rig_from_world * world_from_delivered_t + rig_from_world_t;
    return prior(rig_from_delivered.coeffs().data(), rig_from_delivered_t.data(), r);
  }

  double alpha;
  Rigid3d ins;  ///< GNSS/INS world_from_body at the frame's time
  Rigid3d body_from_vehicle;
  Rigid3d delivered_from_lidar;  ///< ins·body_from_lidar_nominal: how the delivered cloud placed the LiDAR
  PosePrior prior;
};

}  // namespace mmba::factors
