#include "mmba/orientation/intersection.h"

#include <algorithm>
#include <cmath>

#include <Eigen/SVD>
#include <ceres/ceres.h>

#include "mmba/factors/reprojection_error.h"
#include "mmba/orientation/resection.h"

namespace mmba::orientation {
namespace {

/// Homogeneous linear triangulation (Hartley & Zisserman 2003, §12.2): for each ray with
/// normalised coordinates (u, v) and P = [R | t], u·P₃ − P₁ and v·P₃ − P₂ are rows of A; X is
/// the right singular vector of A's smallest singular value.
bool Linear(const std::vector<Ray>& rays, Eigen::Vector3d* point) {
  Eigen::MatrixXd a(2 * rays.size(), 4);
  for (size_t i = 0; i < rays.size(); ++i) {
    const Eigen::Vector3d ray = rays[i].camera->CamFromImg(rays[i].xy_px);
    if (!ray.allFinite() || !(ray.z() > 0)) return false;
    const Eigen::Matrix<double, 3, 4> p = rays[i].cam_from_world.ToMatrix3x4();
    a.row(2 * i) = ray.x() / ray.z() * p.row(2) - p.row(0);
    a.row(2 * i + 1) = ray.y() / ray.z() * p.row(2) - p.row(1);
  }
  const Eigen::Vector4d x = Eigen::JacobiSVD<Eigen::MatrixXd>(a, Eigen::ComputeFullV).matrixV().col(3);
  if (std::abs(x[3]) < 1e-12) return false;
  *point = x.head<3>() / x[3];
  return point->allFinite();
}

void Refine(const std::vector<Ray>& rays, Eigen::Vector3d* point) {
  ceres::Problem problem;
  std::vector<Rigid3d> poses;
  std::vector<std::vector<double>> params;
  poses.reserve(rays.size());
  params.reserve(rays.size());
  for (const Ray& r : rays) {
    poses.push_back(r.cam_from_world);
    params.push_back(r.camera->params);
    Rigid3d& pose = poses.back();
    problem.AddResidualBlock(factors::CreateReprojectionCost(r.camera->model_id, r.xy_px, 1.0, params.back().data()),
                             nullptr, pose.rotation.coeffs().data(), pose.translation.data(), point->data(),
                             params.back().data());
    problem.SetParameterBlockConstant(pose.rotation.coeffs().data());
    problem.SetParameterBlockConstant(pose.translation.data());
    problem.SetParameterBlockConstant(params.back().data());
  }
  ceres::Solver::Options options;
  options.max_num_iterations = 20;
  options.linear_solver_type = ceres::DENSE_QR;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
}

}  // namespace

IntersectionResult Intersect(const std::vector<Ray>& rays, double min_angle_deg) {
  IntersectionResult result;
  if (rays.size() < 2 || !Linear(rays, &result.point_in_world)) return result;
  for (const Ray& r : rays) {
    if (!((r.cam_from_world * result.point_in_world).z() > 0)) return result;
  }
  Refine(rays, &result.point_in_world);
  std::vector<Eigen::Vector3d> directions;
  for (const Ray& r : rays) {
    const Eigen::Vector3d in_cam = r.cam_from_world * result.point_in_world;
    if (!(in_cam.z() > 0)) return result;
    directions.push_back((result.point_in_world - r.cam_from_world.TargetOriginInSource()).normalized());
    result.max_error_px =
        std::max(result.max_error_px, ReprojectionErrorPx(*r.camera, r.cam_from_world, r.xy_px, result.point_in_world));
  }
  for (size_t i = 0; i < directions.size(); ++i) {
    for (size_t j = i + 1; j < directions.size(); ++j) {
      const double c = std::clamp(directions[i].dot(directions[j]), -1.0, 1.0);
      result.max_angle_deg = std::max(result.max_angle_deg, std::acos(c) * 180.0 / M_PI);
    }
  }
  result.ok = result.max_angle_deg >= min_angle_deg;
  return result;
}

}  // namespace mmba::orientation
