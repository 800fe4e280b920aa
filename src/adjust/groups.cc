#include "mmba/adjust/groups.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "mmba/factors/composed_reprojection.h"
#include "mmba/factors/coordinate_observation.h"
#include "mmba/factors/point_to_plane.h"
#include "mmba/factors/pose_prior.h"
#include "mmba/factors/reprojection_error.h"
#include "mmba/registration/mi/mi_prior.h"

namespace mmba::adjust {

TargetReprojectionGroup::TargetReprojectionGroup(survey::SurveyNetwork* network,
                                                 std::vector<TargetMeasurement> measurements,
                                                 LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "px", loss), network_(network), measurements_(std::move(measurements)) {}

void TargetReprojectionGroup::AddResiduals(Scene& scene, ceres::Problem& problem) {
  for (size_t i = 0; i < measurements_.size(); ++i) {
    const TargetMeasurement& m = measurements_[i];
    survey::SurveyPoint* point = network_->Find(m.point_id);
    if (point == nullptr || !scene.HasImage(m.image_id)) {
      Skip();
      continue;
    }
    ImagePose& image = scene.Image(m.image_id);
    sensors::Camera& camera = scene.Camera(image.camera_id);
    if (!camera.ImgFromCam(image.cam_from_world * point->coords)) {
      Skip();
      continue;
    }
    ceres::CostFunction* inner = factors::CreateReprojectionCost(camera.model_id, m.xy, m.sigma_px,
                                                                 camera.params.data());
    AddBlock(problem, new factors::NetworkPointReprojectionCost(inner),
             {image.cam_from_world.rotation.coeffs().data(), image.cam_from_world.translation.data(),
              point->xy_block(), point->z_block(), camera.params.data()},
             m.sigma_px, i);
  }
}

UpperSphereGroup::UpperSphereGroup(std::vector<UpperSphereObservation> observations, Eigen::Vector3d* baseline,
                                   LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "px", loss), observations_(std::move(observations)), baseline_(baseline) {}

void UpperSphereGroup::AddResiduals(Scene& scene, ceres::Problem& problem) {
  for (size_t i = 0; i < observations_.size(); ++i) {
    const UpperSphereObservation& o = observations_[i];
    if (!scene.HasImage(o.lower_image_id) || !scene.HasPoint(o.point3D_id) || !scene.HasCamera(o.camera_id)) {
      Skip();
      continue;
    }
    ImagePose& lower = scene.Image(o.lower_image_id);
    sensors::Camera& camera = scene.Camera(o.camera_id);
    Eigen::Vector3d& point = scene.Point(o.point3D_id);
    if (!camera.ImgFromCam(lower.cam_from_world * point - *baseline_)) {
      Skip();
      continue;
    }
    ceres::CostFunction* inner = factors::CreateReprojectionCost(camera.model_id, o.xy, o.sigma_px, camera.params.data());
    AddBlock(problem, new factors::BaselineReprojectionCost(inner),
             {lower.cam_from_world.rotation.coeffs().data(), lower.cam_from_world.translation.data(),
              baseline_->data(), point.data(), camera.params.data()},
             o.sigma_px, i);
  }
}

VectorPriorGroup::VectorPriorGroup(Eigen::Vector3d* value, const Eigen::Vector3d& prior, double sigma,
                                   std::string name)
    : FactorGroup(std::move(name), "m", LossOptions()), value_(value), prior_(prior), sigma_(sigma) {}

void VectorPriorGroup::AddResiduals(Scene&, ceres::Problem& problem) {
  for (int k = 0; k < 3; ++k) {
    AddBlock(problem, new factors::ScalarPriorCost(k, prior_(k), sigma_), {value_->data()}, sigma_, k);
  }
}

RigReprojectionGroup::RigReprojectionGroup(std::vector<RigObservation> observations, std::vector<CameraId> cameras,
                                           LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "px", loss), observations_(std::move(observations)), cameras_(std::move(cameras)) {}

void RigReprojectionGroup::AddResiduals(Scene& scene, ceres::Problem& problem) {
  for (size_t i = 0; i < observations_.size(); ++i) {
    const RigObservation& o = observations_[i];
    if (!scene.HasPoint(o.point3D_id) || !scene.HasRigFrame(FrameId(o.frame)) || o.camera >= cameras_.size() ||
        !scene.HasCamFromRig(cameras_[o.camera])) {
      Skip();
      continue;
    }
    Rigid3d& rw = scene.RigFrame(FrameId(o.frame));
    Rigid3d& cr = scene.CamFromRig(cameras_[o.camera]);
    sensors::Camera& camera = scene.Camera(cameras_[o.camera]);
    Eigen::Vector3d& point = scene.Point(o.point3D_id);
    // Observations within 15° of a fisheye's 90° limit are left out: a point that crosses the
    // limit during the solve makes the cost undefined and Ceres rejects the whole step.
    const Eigen::Vector3d in_camera = cr * (rw * point);
    if (!camera.ImgFromCam(in_camera) || (!camera.IsSpherical() && in_camera.z() < 0.26 * in_camera.norm())) {
      Skip();
      continue;
    }
    ceres::CostFunction* inner = factors::CreateReprojectionCost(camera.model_id, o.xy, o.sigma_px, camera.params.data());
    AddBlock(problem, new factors::RigReprojectionCost(inner),
             {rw.rotation.coeffs().data(), rw.translation.data(), cr.rotation.coeffs().data(), cr.translation.data(),
              point.data(), camera.params.data()},
             o.sigma_px, i);
  }
}

double GaussMarkovFactor(double dt_s, double correlation_s) {
  return correlation_s > 0 ? std::exp(-std::abs(dt_s) / correlation_s) : 0.0;
}

PosePriorGroup::PosePriorGroup(std::vector<Rigid3d*> poses, std::vector<Rigid3d> priors, double sigma_m,
                               double sigma_rad, LossOptions loss, std::string name, std::vector<double> times,
                               double correlation_s)
    : FactorGroup(std::move(name), "whitened", loss),
      poses_(std::move(poses)),
      priors_(std::move(priors)),
      sigma_m_(sigma_m),
      sigma_rad_(sigma_rad),
      times_(std::move(times)),
      correlation_s_(times_.size() == poses_.size() ? correlation_s : 0.0) {}

void PosePriorGroup::AddResiduals(Scene&, ceres::Problem& problem) {
  // In time order (the Gauss–Markov innovations run along time); the residual keeps the
  // pose's own index.
  std::vector<size_t> order(poses_.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  if (correlation_s_ > 0) std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return times_[a] < times_[b]; });
  for (size_t k = 0; k < order.size(); ++k) {
    const size_t i = order[k];
    const double phi = k == 0 || correlation_s_ <= 0 ? 0.0 : GaussMarkovFactor(times_[i] - times_[order[k - 1]], correlation_s_);
    if (phi == 0.0) {
      AddBlock(problem,
               factors::PosePriorCost::Create(priors_[i], sigma_m_, sigma_rad_),
               {poses_[i]->rotation.coeffs().data(), poses_[i]->translation.data()}, 1.0, i);
      continue;
    }
    const size_t j = order[k - 1];
    AddBlock(problem,
             factors::GaussMarkovPosePriorCost::Create(priors_[j], priors_[i], phi, sigma_m_, sigma_rad_),
             {poses_[j]->rotation.coeffs().data(), poses_[j]->translation.data(), poses_[i]->rotation.coeffs().data(),
              poses_[i]->translation.data()},
             1.0, i);
  }
}

MiPriorGroup::MiPriorGroup(std::vector<MiResult> results, double covariance_scale, LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "whitened", loss), results_(std::move(results)), covariance_scale_(covariance_scale) {}

void MiPriorGroup::AddResiduals(Scene& scene, ceres::Problem& problem) {
  for (size_t i = 0; i < results_.size(); ++i) {
    const MiResult& r = results_[i];
    Rigid3d* pose = r.pose != nullptr ? r.pose : scene.HasImage(r.image_id) ? &scene.Image(r.image_id).cam_from_world : nullptr;
    ceres::CostFunction* cost =
        pose != nullptr ? registration::mi::MiPosePrior::Create(r.cam_from_world, covariance_scale_ * r.covariance) : nullptr;
    if (cost == nullptr) {
      Skip();
      continue;
    }
    AddBlock(problem, cost, {pose->rotation.coeffs().data(), pose->translation.data()}, 1.0, i);
  }
}

GnssPointGroup::GnssPointGroup(survey::SurveyNetwork* network, std::vector<GnssPoint> points,
                               LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "m", loss), network_(network), points_(std::move(points)) {}

void GnssPointGroup::AddResiduals(Scene&, ceres::Problem& problem) {
  for (size_t i = 0; i < points_.size(); ++i) {
    survey::SurveyPoint* point = network_->Find(points_[i].point_id);
    for (int axis = 0; axis < 3; ++axis) {
      if (point == nullptr) {
        Skip();
        continue;
      }
      AddBlock(problem,
               new factors::GnssAxisCost(axis, points_[i].enu(axis), points_[i].sigma(axis)),
               {axis < 2 ? point->xy_block() : point->z_block()}, points_[i].sigma(axis), 3 * i + axis);
    }
  }
}

GnssCameraGroup::GnssCameraGroup(std::vector<GnssCamera> cameras, LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "m", loss), cameras_(std::move(cameras)) {}

void GnssCameraGroup::AddResiduals(Scene& scene, ceres::Problem& problem) {
  for (size_t i = 0; i < cameras_.size(); ++i) {
    const GnssCamera& c = cameras_[i];
    for (int axis = 0; axis < 3; ++axis) {
      if (!scene.HasImage(c.image_id)) {
        Skip();
        continue;
      }
      Rigid3d& pose = scene.Image(c.image_id).cam_from_world;
      AddBlock(problem, factors::GnssCameraAxisCost::Create(axis, c.lever_arm, c.enu(axis), c.sigma(axis)),
               {pose.rotation.coeffs().data(), pose.translation.data()}, c.sigma(axis), 3 * i + axis);
    }
  }
}

LidarSurfaceGroup::LidarSurfaceGroup(std::vector<SurfacePlane> planes, LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "m", loss), planes_(std::move(planes)) {}

void LidarSurfaceGroup::AddResiduals(Scene& scene, ceres::Problem& problem) {
  for (size_t i = 0; i < planes_.size(); ++i) {
    const SurfacePlane& plane = planes_[i];
    if (!scene.HasPoint(plane.point3D_id) ||
        (plane.scan >= 0 && !scene.HasScan(ScanId(plane.scan)))) {
      Skip();
      continue;
    }
    double* point = scene.Point(plane.point3D_id).data();
    if (plane.scan < 0) {
      AddBlock(problem, new factors::PointToPlaneCost(plane.normal, plane.point, plane.sigma_m), {point}, plane.sigma_m, i);
      continue;
    }
    Rigid3d& pose = scene.Scan(ScanId(plane.scan));
    AddBlock(problem,
             factors::ScanPointToPlaneCost::Create(plane.normal, plane.point, plane.sigma_m),
             {pose.rotation.coeffs().data(), pose.translation.data(), point}, plane.sigma_m, i);
  }
}

ScanTargetGroup::ScanTargetGroup(survey::SurveyNetwork* network, std::vector<ScanTarget> targets, LossOptions loss,
                                 std::string name)
    : FactorGroup(std::move(name), "m", loss), network_(network), targets_(std::move(targets)) {}

void ScanTargetGroup::AddResiduals(Scene& scene, ceres::Problem& problem) {
  for (size_t i = 0; i < targets_.size(); ++i) {
    const ScanTarget& t = targets_[i];
    survey::SurveyPoint* point = network_ ? network_->Find(t.point_id) : nullptr;
    if (point == nullptr || !scene.HasScan(ScanId(t.scan))) {
      Skip();
      continue;
    }
    Rigid3d& pose = scene.Scan(ScanId(t.scan));
    AddBlock(problem,
             factors::ScanTargetCost::Create(t.measured, t.sigma),
             {pose.rotation.coeffs().data(), pose.translation.data(), point->xy_block(), point->z_block()}, t.sigma, i);
  }
}

ScanToScanGroup::ScanToScanGroup(std::vector<ScanPairPoint> points, LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "m", loss), points_(std::move(points)) {}

void ScanToScanGroup::AddResiduals(Scene& scene, ceres::Problem& problem) {
  for (size_t i = 0; i < points_.size(); ++i) {
    const ScanPairPoint& p = points_[i];
    Rigid3d& from = scene.Scan(ScanId(p.from));
    Rigid3d& to = scene.Scan(ScanId(p.to));
    AddBlock(problem,
             factors::ScanToScanCost::Create(p.point, p.normal, p.plane_point, p.sigma_m),
             {from.rotation.coeffs().data(), from.translation.data(), to.rotation.coeffs().data(), to.translation.data()},
             p.sigma_m, i);
  }
}

}  // namespace mmba::adjust
