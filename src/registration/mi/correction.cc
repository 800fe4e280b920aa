#include "mmba/registration/mi/mi_registration.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "registration/mi/mi_internal.h"

namespace mmba::registration::mi {

using internal::kDegToRad;

namespace {

Eigen::Matrix3d RotationFromRollPitchYawDeg(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw * kDegToRad, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch * kDegToRad, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll * kDegToRad, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

}  // namespace

const char* ParameterName(int axis) {
  static const char* kNames[6] = {"tx", "ty", "tz", "roll", "pitch", "yaw"};
  return axis >= 0 && axis < 6 ? kNames[axis] : "?";
}

Rigid3d ApplyCorrection(const Rigid3d& cam_from_lidar_start, const Vector6d& correction) {
  const Rigid3d lidar_from_cam = cam_from_lidar_start.Inverse();
  const Eigen::Matrix3d delta =
      RotationFromRollPitchYawDeg(correction[3], correction[4], correction[5]);
  Rigid3d corrected(Eigen::Quaterniond(delta * lidar_from_cam.rotation.toRotationMatrix()),
                    lidar_from_cam.translation + correction.head<3>());
  return corrected.Inverse();
}

Vector6d CorrectionBetween(const Rigid3d& cam_from_lidar_start, const Rigid3d& corrected) {
  const Rigid3d a = cam_from_lidar_start.Inverse();
  const Rigid3d b = corrected.Inverse();
  const Eigen::Matrix3d delta =
      b.rotation.toRotationMatrix() * a.rotation.toRotationMatrix().transpose();
  // ZYX Euler angles: delta = Rz(yaw)·Ry(pitch)·Rx(roll).
  const double pitch = std::asin(std::clamp(-delta(2, 0), -1.0, 1.0));
  const double roll = std::atan2(delta(2, 1), delta(2, 2));
  const double yaw = std::atan2(delta(1, 0), delta(0, 0));
  Vector6d correction;
  correction.head<3>() = b.translation - a.translation;
  correction[3] = roll / kDegToRad;
  correction[4] = pitch / kDegToRad;
  correction[5] = yaw / kDegToRad;
  return correction;
}

}  // namespace mmba::registration::mi
