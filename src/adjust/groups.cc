#include "mmba/adjust/groups.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "mmba/factors/reprojection_error.h"
#include "mmba/registration/mi/mi_prior.h"

namespace mmba::adjust {
namespace {

/// Wraps a reprojection cost (blocks: rotation 4, translation 3, point 3, intrinsics) into
/// one on the survey point's blocks (rotation, translation, east-north 2, up 1, intrinsics).
class NetworkPointReprojectionCost : public ceres::CostFunction {
 public:
  explicit NetworkPointReprojectionCost(ceres::CostFunction* inner) : inner_(inner) {
    const std::vector<int32_t>& sizes = inner_->parameter_block_sizes();
    set_num_residuals(inner_->num_residuals());
    *mutable_parameter_block_sizes() = {sizes[0], sizes[1], 2, 1, sizes[3]};
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double point[3] = {parameters[2][0], parameters[2][1], parameters[3][0]};
    const double* inner_parameters[4] = {parameters[0], parameters[1], point, parameters[4]};
    if (jacobians == nullptr) return inner_->Evaluate(inner_parameters, residuals, nullptr);
    const int m = num_residuals();
    std::vector<double> j_point(m * 3);
    double* inner_jacobians[4] = {jacobians[0], jacobians[1],
                                  (jacobians[2] || jacobians[3]) ? j_point.data() : nullptr,
                                  jacobians[4]};
    if (!inner_->Evaluate(inner_parameters, residuals, inner_jacobians)) return false;
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    const Eigen::Map<const RowMajor> jp(j_point.data(), m, 3);
    if (jacobians[2]) Eigen::Map<RowMajor>(jacobians[2], m, 2) = jp.leftCols(2);
    if (jacobians[3]) Eigen::Map<RowMajor>(jacobians[3], m, 1) = jp.col(2);
    return true;
  }

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
};

/// Wraps a reprojection cost (rotation 4, translation 3, point 3, intrinsics) into one with a
/// baseline block subtracted from the translation: (rotation, translation, baseline 3, point,
/// intrinsics); t' = t − b, so ∂r/∂b = −∂r/∂t.
class BaselineReprojectionCost : public ceres::CostFunction {
 public:
  explicit BaselineReprojectionCost(ceres::CostFunction* inner) : inner_(inner) {
    const std::vector<int32_t>& sizes = inner_->parameter_block_sizes();
    set_num_residuals(inner_->num_residuals());
    *mutable_parameter_block_sizes() = {sizes[0], sizes[1], 3, sizes[2], sizes[3]};
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double t[3] = {parameters[1][0] - parameters[2][0], parameters[1][1] - parameters[2][1],
                         parameters[1][2] - parameters[2][2]};
    const double* inner_parameters[4] = {parameters[0], t, parameters[3], parameters[4]};
    if (jacobians == nullptr) return inner_->Evaluate(inner_parameters, residuals, nullptr);
    const int m = num_residuals();
    std::vector<double> j_t(m * 3);
    double* inner_jacobians[4] = {jacobians[0], (jacobians[1] || jacobians[2]) ? j_t.data() : nullptr,
                                  jacobians[3], jacobians[4]};
    if (!inner_->Evaluate(inner_parameters, residuals, inner_jacobians)) return false;
    for (int k = 0; k < m * 3; ++k) {
      if (jacobians[1]) jacobians[1][k] = j_t[k];
      if (jacobians[2]) jacobians[2][k] = -j_t[k];
    }
    return true;
  }

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
};

/// (q_cw, t_cw) = cam_from_rig ∘ rig_from_world, Eigen quaternion coefficient order (x, y, z, w).
struct ComposePoses {
  template <typename T>
  bool operator()(const T* q_rw, const T* t_rw, const T* q_cr, const T* t_cr, T* out) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rw(q_rw), cr(q_cr);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> trw(t_rw), tcr(t_cr);
    const Eigen::Quaternion<T> cw = cr * rw;
    const Eigen::Matrix<T, 3, 1> tcw = cr * trw + tcr;
    out[0] = cw.x();
    out[1] = cw.y();
    out[2] = cw.z();
    out[3] = cw.w();
    out[4] = tcw.x();
    out[5] = tcw.y();
    out[6] = tcw.z();
    return true;
  }
};

/// The reprojection cost of a rig camera: blocks (q_rw, t_rw, q_cr, t_cr, point, intrinsics);
/// the inner per-camera cost on the composed pose, chained with the composition's Jacobian
/// (automatic differentiation of ComposePoses).
class RigReprojectionCost : public ceres::CostFunction {
 public:
  explicit RigReprojectionCost(ceres::CostFunction* inner)
      : inner_(inner), compose_(new ComposePoses) {
    const std::vector<int32_t>& sizes = inner_->parameter_block_sizes();
    set_num_residuals(inner_->num_residuals());
    *mutable_parameter_block_sizes() = {4, 3, 4, 3, sizes[2], sizes[3]};
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    double composed[7];
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    RowMajor jc[4] = {RowMajor(7, 4), RowMajor(7, 3), RowMajor(7, 4), RowMajor(7, 3)};
    double* jc_data[4] = {jc[0].data(), jc[1].data(), jc[2].data(), jc[3].data()};
    const bool want_pose = jacobians && (jacobians[0] || jacobians[1] || jacobians[2] || jacobians[3]);
    if (!compose_.Evaluate(parameters, composed, want_pose ? jc_data : nullptr)) return false;
    const double* inner_parameters[4] = {composed, composed + 4, parameters[4], parameters[5]};
    if (jacobians == nullptr) return inner_->Evaluate(inner_parameters, residuals, nullptr);
    const int m = num_residuals();
    RowMajor jq(m, 4), jt(m, 3);
    double* inner_jacobians[4] = {want_pose ? jq.data() : nullptr, want_pose ? jt.data() : nullptr, jacobians[4],
                                  jacobians[5]};
    if (!inner_->Evaluate(inner_parameters, residuals, inner_jacobians)) return false;
    if (!want_pose) return true;
    // d r / d block = J_q · d q_cw / d block + J_t · d t_cw / d block.
    for (int b = 0; b < 4; ++b) {
      if (!jacobians[b]) continue;
      const int n = b % 2 == 0 ? 4 : 3;
      Eigen::Map<RowMajor>(jacobians[b], m, n) = jq * jc[b].topRows(4) + jt * jc[b].bottomRows(3);
    }
    return true;
  }

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
  ceres::AutoDiffCostFunction<ComposePoses, 7, 4, 3, 4, 3> compose_;
};

/// Pose prior: position of the source origin in the target frame and the rotation difference.
struct PosePriorCost {
  PosePriorCost(const Rigid3d& prior, double sigma_m, double sigma_rad)
      : prior_centre(prior.Inverse().translation), prior_rotation(prior.rotation), w_m(1 / sigma_m), w_rad(1 / sigma_rad) {}
  template <typename T>
  bool operator()(const T* q, const T* t, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(q);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t);
    // For a pose X_from_world the centre of X in the world is −Rᵀt.
    const Eigen::Matrix<T, 3, 1> centre = -(rotation.conjugate() * translation);
    for (int k = 0; k < 3; ++k) r[k] = (centre[k] - T(prior_centre[k])) * T(w_m);
    const Eigen::Quaternion<T> delta = prior_rotation.cast<T>().conjugate() * rotation;
    T angle_axis[3];
    const T quaternion[4] = {delta.w(), delta.x(), delta.y(), delta.z()};
    ceres::QuaternionToAngleAxis(quaternion, angle_axis);
    for (int k = 0; k < 3; ++k) r[3 + k] = angle_axis[k] * T(w_rad);
    return true;
  }
  Eigen::Vector3d prior_centre;
  Eigen::Quaterniond prior_rotation;
  double w_m, w_rad;
};

/// The Gauss–Markov innovation of two consecutive poses' prior errors e (PosePriorCost with
/// unit σ): (e_k − φ e_{k−1}) / (σ √(1 − φ²)).
struct GaussMarkovPosePriorCost {
  GaussMarkovPosePriorCost(const Rigid3d& previous, const Rigid3d& current, double phi, double sigma_m, double sigma_rad)
      : previous(previous, 1.0, 1.0),
        current(current, 1.0, 1.0),
        phi(phi),
        w_m(1 / (sigma_m * std::sqrt(1 - phi * phi))),
        w_rad(1 / (sigma_rad * std::sqrt(1 - phi * phi))) {}
  template <typename T>
  bool operator()(const T* q_previous, const T* t_previous, const T* q, const T* t, T* r) const {
    T e_previous[6], e[6];
    if (!previous(q_previous, t_previous, e_previous) || !current(q, t, e)) return false;
    for (int k = 0; k < 6; ++k) r[k] = (e[k] - T(phi) * e_previous[k]) * T(k < 3 ? w_m : w_rad);
    return true;
  }
  PosePriorCost previous, current;
  double phi, w_m, w_rad;
};

/// n·(scan_from_world·X − q)/σ: a world point on a scan's local plane (n, q in the scan frame).
struct ScanPointToPlaneCost {
  ScanPointToPlaneCost(const Eigen::Vector3d& normal, const Eigen::Vector3d& point, double sigma)
      : n(normal / sigma), q(point) {}
  template <typename T>
  bool operator()(const T* q_sw, const T* t_sw, const T* x, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(q_sw);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t_sw), world(x);
    const Eigen::Matrix<T, 3, 1> in_scan = rotation * world + translation - q.cast<T>();
    r[0] = n.cast<T>().dot(in_scan);
    return true;
  }
  Eigen::Vector3d n, q;
};

/// A point p of one scan on another scan's plane (n, q): n·(S_to·S_from⁻¹·p − q)/σ, with
/// S = scan_from_world.
struct ScanToScanCost {
  explicit ScanToScanCost(const ScanPairPoint& p) : p(p.point), n(p.normal / p.sigma_m), q(p.plane_point) {}
  template <typename T>
  bool operator()(const T* q_from, const T* t_from, const T* q_to, const T* t_to, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> r_from(q_from), r_to(q_to);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> tr_from(t_from), tr_to(t_to);
    const Eigen::Matrix<T, 3, 1> world = r_from.conjugate() * (p.cast<T>() - tr_from);
    r[0] = n.cast<T>().dot(r_to * world + tr_to - q.cast<T>());
    return true;
  }
  Eigen::Vector3d p, n, q;
};

/// (scan_from_world·X − x)/σ with X = (east, north) block and up block of a survey point.
struct ScanTargetCost {
  ScanTargetCost(const Eigen::Vector3d& measured, double sigma) : x(measured), w(1 / sigma) {}
  template <typename T>
  bool operator()(const T* q_sw, const T* t_sw, const T* en, const T* up, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(q_sw);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t_sw);
    const Eigen::Matrix<T, 3, 1> world(en[0], en[1], up[0]);
    const Eigen::Matrix<T, 3, 1> d = rotation * world + translation - x.cast<T>();
    for (int k = 0; k < 3; ++k) r[k] = d[k] * T(w);
    return true;
  }
  Eigen::Vector3d x;
  double w;
};

class ScalarPriorCost : public ceres::SizedCostFunction<1, 3> {
 public:
  ScalarPriorCost(int index, double prior, double sigma) : index_(index), prior_(prior), sigma_(sigma) {}
  bool Evaluate(double const* const* p, double* r, double** j) const override {
    r[0] = (p[0][index_] - prior_) / sigma_;
    if (j && j[0]) {
      for (int k = 0; k < 3; ++k) j[0][k] = k == index_ ? 1.0 / sigma_ : 0.0;
    }
    return true;
  }

 private:
  int index_;
  double prior_, sigma_;
};

/// (x_axis − value)/σ on the point's east-north block (axis 0, 1) or up block (axis 2).
class GnssAxisCost : public ceres::CostFunction {
 public:
  GnssAxisCost(int axis, double value, double sigma) : index_(axis < 2 ? axis : 0), value_(value), sigma_(sigma) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->push_back(axis < 2 ? 2 : 1);
  }
  bool Evaluate(double const* const* p, double* r, double** j) const override {
    r[0] = (p[0][index_] - value_) / sigma_;
    if (j && j[0]) {
      const int size = parameter_block_sizes()[0];
      for (int k = 0; k < size; ++k) j[0][k] = k == index_ ? 1.0 / sigma_ : 0.0;
    }
    return true;
  }

 private:
  int index_;
  double value_, sigma_;
};

/// n·(X − p)/σ (point-to-plane, Chen & Medioni 1992).
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
  Eigen::Vector3d n_;
  double d_;
};

}  // namespace

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
    AddBlock(problem, new NetworkPointReprojectionCost(inner),
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
    AddBlock(problem, new BaselineReprojectionCost(inner),
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
    AddBlock(problem, new ScalarPriorCost(k, prior_(k), sigma_), {value_->data()}, sigma_, k);
  }
}

RigReprojectionGroup::RigReprojectionGroup(std::vector<RigObservation> observations,
                                           std::vector<Rigid3d>* rig_from_world, std::vector<Rigid3d>* cam_from_rig,
                                           std::vector<CameraId> cameras, LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "px", loss),
      observations_(std::move(observations)),
      rig_from_world_(rig_from_world),
      cam_from_rig_(cam_from_rig),
      cameras_(std::move(cameras)) {}

void RigReprojectionGroup::AddResiduals(Scene& scene, ceres::Problem& problem) {
  for (size_t i = 0; i < observations_.size(); ++i) {
    const RigObservation& o = observations_[i];
    if (!scene.HasPoint(o.point3D_id) || o.frame >= rig_from_world_->size() || o.camera >= cam_from_rig_->size()) {
      Skip();
      continue;
    }
    Rigid3d& rw = (*rig_from_world_)[o.frame];
    Rigid3d& cr = (*cam_from_rig_)[o.camera];
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
    AddBlock(problem, new RigReprojectionCost(inner),
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
               new ceres::AutoDiffCostFunction<PosePriorCost, 6, 4, 3>(new PosePriorCost(priors_[i], sigma_m_, sigma_rad_)),
               {poses_[i]->rotation.coeffs().data(), poses_[i]->translation.data()}, 1.0, i);
      continue;
    }
    const size_t j = order[k - 1];
    AddBlock(problem,
             new ceres::AutoDiffCostFunction<GaussMarkovPosePriorCost, 6, 4, 3, 4, 3>(
                 new GaussMarkovPosePriorCost(priors_[j], priors_[i], phi, sigma_m_, sigma_rad_)),
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
               new GnssAxisCost(axis, points_[i].enu(axis), points_[i].sigma(axis)),
               {axis < 2 ? point->xy_block() : point->z_block()}, points_[i].sigma(axis), 3 * i + axis);
    }
  }
}

namespace {

/// One axis of the antenna position of a camera: (R(q)ᵀ·(lever − t))[axis] − value, over σ.
struct GnssCameraAxisCost {
  GnssCameraAxisCost(int axis, const Eigen::Vector3d& lever, double value, double sigma)
      : axis(axis), lever(lever), value(value), sigma(sigma) {}
  template <typename T>
  bool operator()(const T* q_xyzw, const T* t, T* r) const {
    const Eigen::Quaternion<T> q = Eigen::Quaternion<T>(q_xyzw[3], q_xyzw[0], q_xyzw[1], q_xyzw[2]).normalized();
    const Eigen::Matrix<T, 3, 1> d = lever.cast<T>() - Eigen::Map<const Eigen::Matrix<T, 3, 1>>(t);
    const Eigen::Matrix<T, 3, 1> antenna = q.conjugate() * d;
    r[0] = (antenna[axis] - T(value)) / T(sigma);
    return true;
  }
  static ceres::CostFunction* Create(int axis, const Eigen::Vector3d& lever, double value, double sigma) {
    return new ceres::AutoDiffCostFunction<GnssCameraAxisCost, 1, 4, 3>(new GnssCameraAxisCost(axis, lever, value, sigma));
  }
  int axis;
  Eigen::Vector3d lever;
  double value, sigma;
};

}  // namespace

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
      AddBlock(problem, GnssCameraAxisCost::Create(axis, c.lever_arm, c.enu(axis), c.sigma(axis)),
               {pose.rotation.coeffs().data(), pose.translation.data()}, c.sigma(axis), 3 * i + axis);
    }
  }
}

LidarSurfaceGroup::LidarSurfaceGroup(std::vector<SurfacePlane> planes, LossOptions loss, std::string name,
                                     std::vector<Rigid3d>* scan_from_world)
    : FactorGroup(std::move(name), "m", loss), planes_(std::move(planes)), scan_from_world_(scan_from_world) {}

void LidarSurfaceGroup::AddResiduals(Scene& scene, ceres::Problem& problem) {
  for (size_t i = 0; i < planes_.size(); ++i) {
    const SurfacePlane& plane = planes_[i];
    if (!scene.HasPoint(plane.point3D_id) ||
        (plane.scan >= 0 && (!scan_from_world_ || static_cast<size_t>(plane.scan) >= scan_from_world_->size()))) {
      Skip();
      continue;
    }
    double* point = scene.Point(plane.point3D_id).data();
    if (plane.scan < 0) {
      AddBlock(problem, new PointToPlaneCost(plane.normal, plane.point, plane.sigma_m), {point}, plane.sigma_m, i);
      continue;
    }
    Rigid3d& pose = (*scan_from_world_)[plane.scan];
    AddBlock(problem,
             new ceres::AutoDiffCostFunction<ScanPointToPlaneCost, 1, 4, 3, 3>(
                 new ScanPointToPlaneCost(plane.normal, plane.point, plane.sigma_m)),
             {pose.rotation.coeffs().data(), pose.translation.data(), point}, plane.sigma_m, i);
  }
}

ScanTargetGroup::ScanTargetGroup(survey::SurveyNetwork* network, std::vector<ScanTarget> targets,
                                 std::vector<Rigid3d>* scan_from_world, LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "m", loss), network_(network), targets_(std::move(targets)), scan_from_world_(scan_from_world) {}

void ScanTargetGroup::AddResiduals(Scene&, ceres::Problem& problem) {
  for (size_t i = 0; i < targets_.size(); ++i) {
    const ScanTarget& t = targets_[i];
    survey::SurveyPoint* point = network_ ? network_->Find(t.point_id) : nullptr;
    if (point == nullptr || t.scan >= scan_from_world_->size()) {
      Skip();
      continue;
    }
    Rigid3d& pose = (*scan_from_world_)[t.scan];
    AddBlock(problem,
             new ceres::AutoDiffCostFunction<ScanTargetCost, 3, 4, 3, 2, 1>(new ScanTargetCost(t.measured, t.sigma)),
             {pose.rotation.coeffs().data(), pose.translation.data(), point->xy_block(), point->z_block()}, t.sigma, i);
  }
}

ScanToScanGroup::ScanToScanGroup(std::vector<ScanPairPoint> points, std::vector<Rigid3d>* scan_from_world,
                                 LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "m", loss), points_(std::move(points)), scan_from_world_(scan_from_world) {}

void ScanToScanGroup::AddResiduals(Scene&, ceres::Problem& problem) {
  for (size_t i = 0; i < points_.size(); ++i) {
    const ScanPairPoint& p = points_[i];
    Rigid3d& from = (*scan_from_world_)[p.from];
    Rigid3d& to = (*scan_from_world_)[p.to];
    AddBlock(problem,
             new ceres::AutoDiffCostFunction<ScanToScanCost, 1, 4, 3, 4, 3>(new ScanToScanCost(p)),
             {from.rotation.coeffs().data(), from.translation.data(), to.rotation.coeffs().data(), to.translation.data()},
             p.sigma_m, i);
  }
}

}  // namespace mmba::adjust
