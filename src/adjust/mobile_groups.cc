// Factor groups of a mobile LiDAR on a vehicle: the smooth correction of its GNSS/INS
// trajectory, points tied to the static LiDAR surface, and rig frames on the same trajectory
// (the camera–LiDAR extrinsic is the shared `vehicle_from_lidar` block).
#include <algorithm>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "mmba/adjust/groups.h"
#include "mmba/factors/mobile_lidar.h"
#include "mmba/factors/trajectory_correction.h"
#include "mmba/registration/mi/mi_prior.h"

namespace mmba::adjust {

Rigid3d WorldFromDelivered(const std::vector<TrajectoryNode>& nodes, const NodeWeight& w, const Rigid3d& ins,
                           const Rigid3d& body_from_vehicle, const Rigid3d& vehicle_from_lidar,
                           const Rigid3d& body_from_lidar_nominal) {
  return CorrectedPose(nodes, w, ins) * body_from_vehicle * vehicle_from_lidar * (ins * body_from_lidar_nominal).Inverse();
}

MobileMiPriorGroup::MobileMiPriorGroup(std::vector<MobileMiFrame> frames, std::vector<TrajectoryNode>* nodes,
                                       Rigid3d* vehicle_from_lidar,
                                       const Rigid3d& body_from_vehicle, const Rigid3d& body_from_lidar_nominal,
                                       double covariance_scale, LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "whitened", loss),
      frames_(std::move(frames)),
      nodes_(nodes),
      vehicle_from_lidar_(vehicle_from_lidar),
      body_from_vehicle_(body_from_vehicle),
      body_from_lidar_nominal_(body_from_lidar_nominal),
      covariance_scale_(covariance_scale) {}

void MobileMiPriorGroup::AddResiduals(Scene& scene, ceres::Problem& problem) {
  for (size_t i = 0; i < frames_.size(); ++i) {
    const MobileMiFrame& f = frames_[i];
    Eigen::Matrix<double, 6, 6> sqrt_information;
    if (!scene.HasRigFrame(FrameId(f.frame)) || f.weight.node + 1 >= nodes_->size() ||
        !registration::mi::MiPosePrior::SqrtInformation(covariance_scale_ * f.covariance, &sqrt_information)) {
      Skip();
      continue;
    }
    Rigid3d& pose = scene.RigFrame(FrameId(f.frame));
    AddBlock(problem,
             factors::MobileMiFrameCost<registration::mi::MiPosePrior>::Create(
                 f.weight.alpha, f.ins, body_from_vehicle_, body_from_lidar_nominal_,
                 registration::mi::MiPosePrior(f.rig_from_delivered, sqrt_information)),
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
                                   std::string name)
    : FactorGroup(std::move(name), "m", loss),
      points_(std::move(points)),
      nodes_(nodes),
      vehicle_from_lidar_(vehicle_from_lidar),
      body_from_vehicle_(body_from_vehicle) {}

void MobileLidarGroup::AddResiduals(Scene& scene, ceres::Problem& problem) {
  for (size_t i = 0; i < points_.size(); ++i) {
    const MobilePoint& p = points_[i];
    if (p.scan >= 0) {
      if (!scene.HasScan(ScanId(p.scan))) {
        Skip();
        continue;
      }
      Rigid3d& scan = scene.Scan(ScanId(p.scan));
      AddBlock(problem,
               factors::MobileScanPointCost::Create(factors::MobilePointCost(
                   p.point_lidar, p.weight.alpha, p.ins, p.normal, p.plane_point, p.sigma_m, body_from_vehicle_)),
               {(*nodes_)[p.weight.node].correction, (*nodes_)[p.weight.node + 1].correction,
                vehicle_from_lidar_->rotation.coeffs().data(), vehicle_from_lidar_->translation.data(),
                scan.rotation.coeffs().data(), scan.translation.data()},
               p.sigma_m, i);
      continue;
    }
    ceres::CostFunction* cost = factors::MobilePointCost::Create(p.point_lidar, p.weight.alpha, p.ins, p.normal,
                                                                 p.plane_point, p.sigma_m, body_from_vehicle_);
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
      AddBlock(problem, factors::NodePriorCost::Create(sigma_m_, sigma_rad_),
               {(*nodes_)[i].correction}, 1.0, i);
    } else {
      AddBlock(problem,
               factors::GaussMarkovNodeCost::Create(phi, sigma_m_, sigma_rad_),
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
             factors::SecondDifferenceCost::Create(sigma_m_, sigma_rad_),
             {(*nodes_)[i - 1].correction, (*nodes_)[i].correction, (*nodes_)[i + 1].correction}, 1.0, i - 1);
  }
}

RigTrajectoryGroup::RigTrajectoryGroup(std::vector<FrameOnTrajectory> frames, std::vector<TrajectoryNode>* nodes,
                                       const Rigid3d& body_from_rig, double sigma_m, double sigma_rad, LossOptions loss,
                                       std::string name)
    : FactorGroup(std::move(name), "whitened", loss),
      frames_(std::move(frames)),
      nodes_(nodes),
      body_from_rig_(body_from_rig),
      sigma_m_(sigma_m),
      sigma_rad_(sigma_rad) {}

void RigTrajectoryGroup::AddResiduals(Scene& scene, ceres::Problem& problem) {
  for (size_t i = 0; i < frames_.size(); ++i) {
    const FrameOnTrajectory& f = frames_[i];
    Rigid3d& pose = scene.RigFrame(FrameId(f.frame));
    ceres::CostFunction* cost =
        factors::FrameOnTrajectoryCost::Create(f.weight.alpha, f.ins, body_from_rig_, sigma_m_, sigma_rad_);
    AddBlock(problem, cost,
             {(*nodes_)[f.weight.node].correction, (*nodes_)[f.weight.node + 1].correction, pose.rotation.coeffs().data(),
              pose.translation.data()},
             1.0, i);
  }
}

}  // namespace mmba::adjust
