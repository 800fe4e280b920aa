#include "mmba/orientation/relative_orientation.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace mmba::orientation {

RelativeOrientationResult RelativeOrientation(const sensors::Camera& camera1, const sensors::Camera& camera2,
                                              const std::vector<Eigen::Vector2d>& xy1_px,
                                              const std::vector<Eigen::Vector2d>& xy2_px, double max_error_px) {
  RelativeOrientationResult result;
  result.inlier.assign(xy1_px.size(), false);
  std::vector<cv::Point2d> a, b;
  std::vector<size_t> index;
  for (size_t i = 0; i < xy1_px.size(); ++i) {
    const Eigen::Vector3d r1 = camera1.CamFromImg(xy1_px[i]), r2 = camera2.CamFromImg(xy2_px[i]);
    if (!r1.allFinite() || !r2.allFinite() || !(r1.z() > 0) || !(r2.z() > 0)) continue;
    a.emplace_back(r1.x() / r1.z(), r1.y() / r1.z());
    b.emplace_back(r2.x() / r2.z(), r2.y() / r2.z());
    index.push_back(i);
  }
  if (a.size() < 8) {
    result.reason = std::to_string(a.size()) + " common points, 8 needed";
    return result;
  }
  const double threshold = max_error_px / (0.5 * (camera1.MeanFocalLength() + camera2.MeanFocalLength()));
  cv::Mat mask;
  const cv::Mat e = cv::findEssentialMat(a, b, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, 0.9999, threshold, mask);
  if (e.rows != 3 || e.cols != 3) {
    result.reason = "no essential matrix";
    return result;
  }
  cv::Mat r, t;
  const int good = cv::recoverPose(e, a, b, cv::Mat::eye(3, 3, CV_64F), r, t, mask);
  if (good < 5) {
    result.reason = std::to_string(good) + " points in front of both cameras, 5 needed";
    return result;
  }
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  cv::cv2eigen(r, rotation);
  cv::cv2eigen(t, translation);
  result.cam2_from_cam1 = Rigid3d(Eigen::Quaterniond(rotation), translation.normalized());
  for (int i = 0; i < mask.rows; ++i) result.inlier[index[i]] = mask.at<uchar>(i) != 0;
  result.ok = true;
  return result;
}

}  // namespace mmba::orientation
