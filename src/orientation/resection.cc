#include "mmba/orientation/resection.h"

#include <cmath>
#include <limits>

#include <ceres/ceres.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "mmba/factors/reprojection_error.h"
#include "mmba/geometry/pose_manifold.h"

namespace mmba::orientation {

bool ResectionOptions::Check(std::string* error) const {
  if (!(max_error_px > 0 && max_error_px <= 1000)) {
    *error = "max_error_px: " + std::to_string(max_error_px) + ", expected a pixel threshold in (0, 1000]";
  } else if (max_iterations < 1) {
    *error = "max_iterations: " + std::to_string(max_iterations) + ", expected >= 1";
  } else if (min_inliers < 4) {
    *error = "min_inliers: " + std::to_string(min_inliers) + ", expected >= 4";
  } else {
    return true;
  }
  return false;
}

size_t ResectionResult::num_inliers() const {
  size_t n = 0;
  for (bool b : inlier) n += b;
  return n;
}

double ReprojectionErrorPx(const sensors::Camera& camera, const Rigid3d& cam_from_world, const Eigen::Vector2d& xy_px,
                           const Eigen::Vector3d& point_in_world) {
  const Eigen::Vector3d in_cam = cam_from_world * point_in_world;
  if (!(in_cam.z() > 0)) return std::numeric_limits<double>::infinity();
  const auto projected = camera.ImgFromCam(in_cam);
  return projected ? (*projected - xy_px).norm() : std::numeric_limits<double>::infinity();
}

double RefinePose(const sensors::Camera& camera, const std::vector<Eigen::Vector2d>& xy_px,
                  const std::vector<Eigen::Vector3d>& point_in_world, Rigid3d* cam_from_world) {
  std::vector<double> params = camera.params;
  std::vector<Eigen::Vector3d> points = point_in_world;
  ceres::Problem problem;
  double* q = cam_from_world->rotation.coeffs().data();
  double* t = cam_from_world->translation.data();
  for (size_t i = 0; i < xy_px.size(); ++i) {
    problem.AddResidualBlock(factors::CreateReprojectionCost(camera.model_id, xy_px[i], 1.0, params.data()), nullptr, q,
                             t, points[i].data(), params.data());
    problem.SetParameterBlockConstant(points[i].data());
  }
  if (xy_px.empty()) return 0.0;
  problem.SetParameterBlockConstant(params.data());
  problem.SetManifold(q, CreateQuaternionManifold().release());
  ceres::Solver::Options options;
  options.max_num_iterations = 50;
  options.linear_solver_type = ceres::DENSE_QR;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  cam_from_world->rotation.normalize();
  double sum = 0.0;
  for (size_t i = 0; i < xy_px.size(); ++i) {
    const double e = ReprojectionErrorPx(camera, *cam_from_world, xy_px[i], point_in_world[i]);
    sum += e * e;
  }
  return std::sqrt(sum / xy_px.size());
}

ResectionResult Resect(const sensors::Camera& camera, const std::vector<Eigen::Vector2d>& xy_px,
                       const std::vector<Eigen::Vector3d>& point_in_world, const ResectionOptions& options) {
  ResectionResult result;
  result.inlier.assign(xy_px.size(), false);
  std::vector<cv::Point2d> image;
  std::vector<cv::Point3d> world;
  std::vector<size_t> index;
  for (size_t i = 0; i < xy_px.size(); ++i) {
    const Eigen::Vector3d ray = camera.CamFromImg(xy_px[i]);
    if (!ray.allFinite() || !(ray.z() > 0)) continue;
    image.emplace_back(ray.x() / ray.z(), ray.y() / ray.z());
    const Eigen::Vector3d& p = point_in_world[i];
    world.emplace_back(p.x(), p.y(), p.z());
    index.push_back(i);
  }
  if (static_cast<int>(image.size()) < options.min_inliers) {
    result.reason = std::to_string(image.size()) + " points of known coordinates, " + std::to_string(options.min_inliers) +
                    " needed";
    return result;
  }
  // Normalised coordinates: K = I, the threshold in units of the focal length.
  const cv::Mat k = cv::Mat::eye(3, 3, CV_64F);
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  const double threshold = options.max_error_px / camera.MeanFocalLength();
  const bool found = cv::solvePnPRansac(world, image, k, cv::noArray(), rvec, tvec, false, options.max_iterations,
                                        static_cast<float>(threshold), 0.9999, inliers,
                                        image.size() >= 6 ? cv::SOLVEPNP_EPNP : cv::SOLVEPNP_P3P);
  if (!found || static_cast<int>(inliers.size()) < options.min_inliers) {
    result.reason = "no pose with " + std::to_string(options.min_inliers) + " consistent points (RANSAC: " +
                    std::to_string(inliers.size()) + " inliers of " + std::to_string(image.size()) + ")";
    return result;
  }
  cv::Mat r;
  cv::Rodrigues(rvec, r);
  Eigen::Matrix3d rotation;
  cv::cv2eigen(r, rotation);
  result.cam_from_world = Rigid3d(Eigen::Quaterniond(rotation), Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
  // Refine on the inliers in pixels, then take every point within the threshold.
  std::vector<Eigen::Vector2d> xy;
  std::vector<Eigen::Vector3d> xyz;
  for (int i : inliers) {
    xy.push_back(xy_px[index[i]]);
    xyz.push_back(point_in_world[index[i]]);
  }
  RefinePose(camera, xy, xyz, &result.cam_from_world);
  xy.clear();
  xyz.clear();
  for (size_t i = 0; i < xy_px.size(); ++i) {
    result.inlier[i] = ReprojectionErrorPx(camera, result.cam_from_world, xy_px[i], point_in_world[i]) < options.max_error_px;
    if (result.inlier[i]) {
      xy.push_back(xy_px[i]);
      xyz.push_back(point_in_world[i]);
    }
  }
  if (static_cast<int>(xy.size()) < options.min_inliers) {
    result.reason = "the refined pose keeps " + std::to_string(xy.size()) + " points within " +
                    std::to_string(options.max_error_px) + " px";
    return result;
  }
  result.rms_px = RefinePose(camera, xy, xyz, &result.cam_from_world);
  result.ok = true;
  return result;
}

}  // namespace mmba::orientation
