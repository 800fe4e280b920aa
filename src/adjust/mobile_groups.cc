// Factor groups of a mobile LiDAR on a vehicle: the smooth correction of its GNSS/INS
// trajectory, points tied to the static LiDAR surface, and rig frames on the same trajectory
// (the camera–LiDAR extrinsic is the shared `vehicle_from_lidar` block).
#include <algorithm>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "mmba/adjust/groups.h"
#include "mmba/registration/mi/mi_prior.h"

namespace mmba::adjust {
namespace {

/// Interpolated correction c = (1 − α)·a + α·b, applied to the GNSS/INS pose (R, p):
/// world_from_body = (Exp(ω)·R, p + δ). Returns the body point `x_body` in the world.
template <typename T>
Eigen::Matrix<T, 3, 1> CorrectedWorldPoint(const T* a, const T* b, double alpha, const Rigid3d& ins,
                                           const Eigen::Matrix<T, 3, 1>& x_body) {
  T omega[3], delta[3];
  for (int k = 0; k < 3; ++k) {
    omega[k] = (1.0 - alpha) * a[k] + alpha * b[k];
    delta[k] = (1.0 - alpha) * a[3 + k] + alpha * b[3 + k];
  }
  // Exp(ω)·(R·x): the GNSS/INS attitude applied first, then the correction.
  const Eigen::Matrix<T, 3, 1> rotated = ins.rotation.cast<T>() * x_body;
  T turned[3];
  const T in[3] = {rotated[0], rotated[1], rotated[2]};
  ceres::AngleAxisRotatePoint(omega, in, turned);
  Eigen::Matrix<T, 3, 1> out;
  for (int k = 0; k < 3; ++k) out[k] = turned[k] + T(ins.translation[k]) + delta[k];
  return out;
}

struct MobilePointCost {
  MobilePointCost(const MobilePoint& p, const Rigid3d& body_from_vehicle) : p(p), body_from_vehicle(body_from_vehicle) {}
  /// The point in the world through the corrected trajectory (nodes a, b) and the extrinsic.
  template <typename T>
  Eigen::Matrix<T, 3, 1> World(const T* a, const T* b, const T* q, const T* t) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(q);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t);
    const Eigen::Matrix<T, 3, 1> in_vehicle = rotation * p.point_lidar.cast<T>() + translation;
    const Eigen::Matrix<T, 3, 1> in_body =
        body_from_vehicle.rotation.cast<T>() * in_vehicle + body_from_vehicle.translation.cast<T>();
    return CorrectedWorldPoint(a, b, p.weight.alpha, p.ins, in_body);
  }
  template <typename T>
  bool operator()(const T* a, const T* b, const T* q, const T* t, T* r) const {
    r[0] = p.normal.cast<T>().dot(World(a, b, q, t) - p.plane_point.cast<T>()) / T(p.sigma_m);
    return true;
  }
  MobilePoint p;
  Rigid3d body_from_vehicle;
};

/// The same on an adjusted scan's plane (in the scan's frame): n·(S·world − q)/σ, S =
/// scan_from_world a parameter block.
struct MobileScanPointCost {
  MobileScanPointCost(const MobilePoint& p, const Rigid3d& body_from_vehicle) : point(p, body_from_vehicle) {}
  template <typename T>
  bool operator()(const T* a, const T* b, const T* q, const T* t, const T* q_sw, const T* t_sw, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(q_sw);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t_sw);
    const Eigen::Matrix<T, 3, 1> in_scan = rotation * point.World(a, b, q, t) + translation;
    r[0] = point.p.normal.cast<T>().dot(in_scan - point.p.plane_point.cast<T>()) / T(point.p.sigma_m);
    return true;
  }
  MobilePointCost point;
};

struct NodePriorCost {
  NodePriorCost(double sigma_m, double sigma_rad) : w_m(1 / sigma_m), w_rad(1 / sigma_rad) {}
  template <typename T>
  bool operator()(const T* c, T* r) const {
    for (int k = 0; k < 3; ++k) {
      r[k] = c[k] * T(w_rad);
      r[3 + k] = c[3 + k] * T(w_m);
    }
    return true;
  }
  double w_m, w_rad;
};

/// The innovation of a first-order Gauss–Markov process between two nodes:
/// (c_k − φ c_{k−1}) / (σ √(1 − φ²)).
struct GaussMarkovNodeCost {
  GaussMarkovNodeCost(double phi, double sigma_m, double sigma_rad)
      : phi(phi), w_m(1 / (sigma_m * std::sqrt(1 - phi * phi))), w_rad(1 / (sigma_rad * std::sqrt(1 - phi * phi))) {}
  template <typename T>
  bool operator()(const T* previous, const T* c, T* r) const {
    for (int k = 0; k < 6; ++k) r[k] = (c[k] - T(phi) * previous[k]) * T(k < 3 ? w_rad : w_m);
    return true;
  }
  double phi, w_m, w_rad;
};

struct SecondDifferenceCost {
  // σ = 0: that part is not constrained.
  SecondDifferenceCost(double sigma_m, double sigma_rad)
      : w_m(sigma_m > 0 ? 1 / sigma_m : 0.0), w_rad(sigma_rad > 0 ? 1 / sigma_rad : 0.0) {}
  template <typename T>
  bool operator()(const T* a, const T* b, const T* c, T* r) const {
    for (int k = 0; k < 6; ++k) r[k] = (a[k] - 2.0 * b[k] + c[k]) * T(k < 3 ? w_rad : w_m);
    return true;
  }
  double w_m, w_rad;
};

/// rig_from_world (q, t) against (corrected world_from_body · body_from_rig)⁻¹: the rig
/// centre's difference in the world (σ_m) and the angle-axis of the rotation difference (σ_rad).
struct FrameOnTrajectoryCost {
  FrameOnTrajectoryCost(const FrameOnTrajectory& f, const Rigid3d& body_from_rig, double sigma_m, double sigma_rad)
      : f(f), body_from_rig(body_from_rig), w_m(1 / sigma_m), w_rad(1 / sigma_rad) {}
  template <typename T>
  bool operator()(const T* a, const T* b, const T* q, const T* t, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rig_from_world(q);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t);
    const Eigen::Matrix<T, 3, 1> centre = -(rig_from_world.conjugate() * translation);
    const Eigen::Matrix<T, 3, 1> predicted =
        CorrectedWorldPoint<T>(a, b, f.weight.alpha, f.ins, body_from_rig.translation.cast<T>().eval());
    for (int k = 0; k < 3; ++k) r[k] = (centre[k] - predicted[k]) * T(w_m);
    // Predicted world_from_rig rotation: Exp(ω)·R_ins·R_body_from_rig.
    T omega[3];
    for (int k = 0; k < 3; ++k) omega[k] = (1.0 - f.weight.alpha) * a[k] + f.weight.alpha * b[k];
    T omega_q[4];
    ceres::AngleAxisToQuaternion(omega, omega_q);  // w x y z
    const Eigen::Quaternion<T> correction(omega_q[0], omega_q[1], omega_q[2], omega_q[3]);
    const Eigen::Quaternion<T> world_from_rig =
        correction * f.ins.rotation.cast<T>() * body_from_rig.rotation.cast<T>();
    // world_from_rig_predicted⁻¹ · world_from_rig_estimated = identity when they agree.
    const Eigen::Quaternion<T> delta = world_from_rig.conjugate() * rig_from_world.conjugate();
    const T dq[4] = {delta.w(), delta.x(), delta.y(), delta.z()};
    T angle_axis[3];
    ceres::QuaternionToAngleAxis(dq, angle_axis);
    for (int k = 0; k < 3; ++k) r[3 + k] = angle_axis[k] * T(w_rad);
    return true;
  }
  FrameOnTrajectory f;
  Rigid3d body_from_rig;
  double w_m, w_rad;
};

/// MI pose of a rig frame against the mobile LiDAR's delivered cloud: the predicted
/// rig_from_delivered = rig_from_world · C·T_ins·B_v·V·(T_ins·B_ln)⁻¹ (WorldFromDelivered),
/// then registration/mi/mi_prior.h's whitened residual on that pose.
/// Blocks: nodes a, b (6 each), vehicle_from_lidar (q 4, t 3), rig_from_world (q 4, t 3).
struct MobileMiFrameCost {
  MobileMiFrameCost(const MobileMiFrame& f, const Rigid3d& body_from_vehicle, const Rigid3d& body_from_lidar_nominal,
                    const Eigen::Matrix<double, 6, 6>& sqrt_information)
      : f(f), body_from_vehicle(body_from_vehicle),
        delivered_from_lidar(f.ins * body_from_lidar_nominal), prior(f.rig_from_delivered, sqrt_information) {}
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
      omega[k] = (1.0 - f.weight.alpha) * a[k] + f.weight.alpha * b[k];
      delta[k] = (1.0 - f.weight.alpha) * a[3 + k] + f.weight.alpha * b[3 + k];
    }
    ceres::AngleAxisToQuaternion(omega, omega_q);  // w x y z
    const Quaternion world_from_body = Quaternion(omega_q[0], omega_q[1], omega_q[2], omega_q[3]) * f.ins.rotation.cast<T>();
    const Vector world_from_body_t = f.ins.translation.cast<T>() + delta;
    // world_from_lidar = world_from_body · body_from_vehicle · vehicle_from_lidar.
    const Quaternion body_from_lidar = body_from_vehicle.rotation.cast<T>() * vehicle_from_lidar;
    const Vector body_from_lidar_t = body_from_vehicle.rotation.cast<T>() * vehicle_from_lidar_t + body_from_vehicle.translation.cast<T>();
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
  MobileMiFrame f;
  Rigid3d body_from_vehicle;
  Rigid3d delivered_from_lidar;  ///< T_ins(t)·B_ln: how the delivered cloud placed the LiDAR at t
  registration::mi::MiPosePrior prior;
};

}  // namespace

Rigid3d WorldFromDelivered(const std::vector<TrajectoryNode>& nodes, const NodeWeight& w, const Rigid3d& ins,
                           const Rigid3d& body_from_vehicle, const Rigid3d& vehicle_from_lidar,
                           const Rigid3d& body_from_lidar_nominal) {
  return CorrectedPose(nodes, w, ins) * body_from_vehicle * vehicle_from_lidar * (ins * body_from_lidar_nominal).Inverse();
}

MobileMiPriorGroup::MobileMiPriorGroup(std::vector<MobileMiFrame> frames, std::vector<Rigid3d>* rig_from_world,
                                       std::vector<TrajectoryNode>* nodes, Rigid3d* vehicle_from_lidar,
                                       const Rigid3d& body_from_vehicle, const Rigid3d& body_from_lidar_nominal,
                                       double covariance_scale, LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "whitened", loss),
      frames_(std::move(frames)),
      rig_from_world_(rig_from_world),
      nodes_(nodes),
      vehicle_from_lidar_(vehicle_from_lidar),
      body_from_vehicle_(body_from_vehicle),
      body_from_lidar_nominal_(body_from_lidar_nominal),
      covariance_scale_(covariance_scale) {}

void MobileMiPriorGroup::AddResiduals(Scene&, ceres::Problem& problem) {
  for (size_t i = 0; i < frames_.size(); ++i) {
    const MobileMiFrame& f = frames_[i];
    Eigen::Matrix<double, 6, 6> sqrt_information;
    if (f.frame >= rig_from_world_->size() || f.weight.node + 1 >= nodes_->size() ||
        !registration::mi::MiPosePrior::SqrtInformation(covariance_scale_ * f.covariance, &sqrt_information)) {
      Skip();
      continue;
    }
    Rigid3d& pose = (*rig_from_world_)[f.frame];
    AddBlock(problem,
             new ceres::AutoDiffCostFunction<MobileMiFrameCost, 6, 6, 6, 4, 3, 4, 3>(
                 new MobileMiFrameCost(f, body_from_vehicle_, body_from_lidar_nominal_, sqrt_information)),
             {(*nodes_)[f.weight.node].correction, (*nodes_)[f.weight.node + 1].correction,
              vehicle_from_lidar_->rotation.coeffs().data(), vehicle_from_lidar_->translation.data(),
              pose.rotation.coeffs().data(), pose.translation.data()},
             1.0, i);
  }
}

NodeWeight WeightAt(const std::vector<TrajectoryNode>& nodes, double time_s) {
  const auto it = std::upper_bound(nodes.begin(), nodes.end(), time_s,
                                   [](double t, const TrajectoryNode& n) { return t < n.time_s; });
  size_t i = it == nodes.begin() ? 0 : static_cast<size_t>(it - nodes.begin()) - 1;
  i = std::min(i, nodes.size() - 2);
  const double span = nodes[i + 1].time_s - nodes[i].time_s;
  return {i, std::clamp((time_s - nodes[i].time_s) / span, 0.0, 1.0)};
}

Rigid3d CorrectedPose(const std::vector<TrajectoryNode>& nodes, const NodeWeight& w, const Rigid3d& ins) {
  Eigen::Vector3d omega, delta;
  for (int k = 0; k < 3; ++k) {
    omega[k] = (1 - w.alpha) * nodes[w.node].correction[k] + w.alpha * nodes[w.node + 1].correction[k];
    delta[k] = (1 - w.alpha) * nodes[w.node].correction[3 + k] + w.alpha * nodes[w.node + 1].correction[3 + k];
  }
  const double angle = omega.norm();
  const Eigen::Quaterniond correction =
      angle > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, omega / angle)) : Eigen::Quaterniond::Identity();
  return Rigid3d(correction * ins.rotation, ins.translation + delta);
}

MobileLidarGroup::MobileLidarGroup(std::vector<MobilePoint> points, std::vector<TrajectoryNode>* nodes,
                                   Rigid3d* vehicle_from_lidar, const Rigid3d& body_from_vehicle, LossOptions loss,
                                   std::string name, std::vector<Rigid3d>* scan_from_world)
    : FactorGroup(std::move(name), "m", loss),
      points_(std::move(points)),
      nodes_(nodes),
      vehicle_from_lidar_(vehicle_from_lidar),
      body_from_vehicle_(body_from_vehicle),
      scan_from_world_(scan_from_world) {}

void MobileLidarGroup::AddResiduals(Scene&, ceres::Problem& problem) {
  for (size_t i = 0; i < points_.size(); ++i) {
    const MobilePoint& p = points_[i];
    if (p.scan >= 0) {
      if (!scan_from_world_ || static_cast<size_t>(p.scan) >= scan_from_world_->size()) {
        Skip();
        continue;
      }
      Rigid3d& scan = (*scan_from_world_)[p.scan];
      AddBlock(problem,
               new ceres::AutoDiffCostFunction<MobileScanPointCost, 1, 6, 6, 4, 3, 4, 3>(
                   new MobileScanPointCost(p, body_from_vehicle_)),
               {(*nodes_)[p.weight.node].correction, (*nodes_)[p.weight.node + 1].correction,
                vehicle_from_lidar_->rotation.coeffs().data(), vehicle_from_lidar_->translation.data(),
                scan.rotation.coeffs().data(), scan.translation.data()},
               p.sigma_m, i);
      continue;
    }
    auto* cost = new ceres::AutoDiffCostFunction<MobilePointCost, 1, 6, 6, 4, 3>(new MobilePointCost(p, body_from_vehicle_));
    AddBlock(problem, cost,
             {(*nodes_)[p.weight.node].correction, (*nodes_)[p.weight.node + 1].correction,
              vehicle_from_lidar_->rotation.coeffs().data(), vehicle_from_lidar_->translation.data()},
             p.sigma_m, i);
  }
}

TrajectoryPriorGroup::TrajectoryPriorGroup(std::vector<TrajectoryNode>* nodes, double sigma_m, double sigma_rad,
                                           double correlation_s, LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "whitened", loss),
      nodes_(nodes),
      sigma_m_(sigma_m),
      sigma_rad_(sigma_rad),
      correlation_s_(correlation_s) {}

void TrajectoryPriorGroup::AddResiduals(Scene&, ceres::Problem& problem) {
  for (size_t i = 0; i < nodes_->size(); ++i) {
    const double phi = i == 0 ? 0.0 : GaussMarkovFactor((*nodes_)[i].time_s - (*nodes_)[i - 1].time_s, correlation_s_);
    if (phi == 0.0) {
      AddBlock(problem, new ceres::AutoDiffCostFunction<NodePriorCost, 6, 6>(new NodePriorCost(sigma_m_, sigma_rad_)),
               {(*nodes_)[i].correction}, 1.0, i);
    } else {
      AddBlock(problem,
               new ceres::AutoDiffCostFunction<GaussMarkovNodeCost, 6, 6, 6>(new GaussMarkovNodeCost(phi, sigma_m_, sigma_rad_)),
               {(*nodes_)[i - 1].correction, (*nodes_)[i].correction}, 1.0, i);
    }
  }
}

TrajectorySmoothnessGroup::TrajectorySmoothnessGroup(std::vector<TrajectoryNode>* nodes, double sigma_m,
                                                     double sigma_rad, std::string name)
    : FactorGroup(std::move(name), "whitened", LossOptions()), nodes_(nodes), sigma_m_(sigma_m), sigma_rad_(sigma_rad) {}

void TrajectorySmoothnessGroup::AddResiduals(Scene&, ceres::Problem& problem) {
  for (size_t i = 1; i + 1 < nodes_->size(); ++i) {
    AddBlock(problem,
             new ceres::AutoDiffCostFunction<SecondDifferenceCost, 6, 6, 6, 6>(new SecondDifferenceCost(sigma_m_, sigma_rad_)),
             {(*nodes_)[i - 1].correction, (*nodes_)[i].correction, (*nodes_)[i + 1].correction}, 1.0, i - 1);
  }
}

RigTrajectoryGroup::RigTrajectoryGroup(std::vector<FrameOnTrajectory> frames, std::vector<Rigid3d>* rig_from_world,
                                       std::vector<TrajectoryNode>* nodes, const Rigid3d& body_from_rig, double sigma_m,
                                       double sigma_rad, LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "whitened", loss),
      frames_(std::move(frames)),
      rig_from_world_(rig_from_world),
      nodes_(nodes),
      body_from_rig_(body_from_rig),
      sigma_m_(sigma_m),
      sigma_rad_(sigma_rad) {}

void RigTrajectoryGroup::AddResiduals(Scene&, ceres::Problem& problem) {
  for (size_t i = 0; i < frames_.size(); ++i) {
    const FrameOnTrajectory& f = frames_[i];
    Rigid3d& pose = (*rig_from_world_)[f.frame];
    auto* cost = new ceres::AutoDiffCostFunction<FrameOnTrajectoryCost, 6, 6, 6, 4, 3>(
        new FrameOnTrajectoryCost(f, body_from_rig_, sigma_m_, sigma_rad_));
    AddBlock(problem, cost,
             {(*nodes_)[f.weight.node].correction, (*nodes_)[f.weight.node + 1].correction, pose.rotation.coeffs().data(),
              pose.translation.data()},
             1.0, i);
  }
}

}  // namespace mmba::adjust
