#pragma once

// Omega-phi-kappa exterior orientation, the photogrammetric convention (DBAT, PhotoModeler,
// Australis; Förstner & Wrobel 2004, Manual of Photogrammetry, Ch. 2.1.2):
//   R(ω, φ, κ) = R1(ω) · R2(φ) · R3(κ)      (rotations about moving x, y, z axes)
// with R1, R2, R3 the right-handed elementary rotations about x, y, z. R takes vectors of the
// photogrammetric camera frame (x right, y up, z back: the camera looks along −z) to the
// object frame; a point of the object X is at R^T (X − X0) in the camera frame, X0 the
// projection centre (DBAT eulerpinhole.m, eulerrotmat(ang, 123, false)).
//
// mmba's camera frame is x right, y down, z forward: the photogrammetric frame turned 180°
// about x, so   cam_from_world.rotation = diag(1, −1, −1) · R^T,
//               cam_from_world.translation = −cam_from_world.rotation · X0.

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"

namespace mmba {

/// Omega, phi, kappa (rad) and the projection centre in the object (world) frame.
struct OpkPose {
  double omega_rad = 0.0;
  double phi_rad = 0.0;
  double kappa_rad = 0.0;
  Eigen::Vector3d center_in_world = Eigen::Vector3d::Zero();
};

/// R(ω, φ, κ) = R1(ω) R2(φ) R3(κ): photogrammetric camera frame (x right, y up, z back) to
/// world.
Eigen::Matrix3d WorldFromPhotoCamRotation(double omega_rad, double phi_rad, double kappa_rad);

/// mmba's cam_from_world (x right, y down, z forward) of an omega-phi-kappa pose.
Rigid3d CamFromWorldFromOpk(const OpkPose& opk);

/// The inverse of CamFromWorldFromOpk: φ in [−90°, 90°], ω and κ in (−180°, 180°]. At
/// φ = ±90° (gimbal lock) ω is set to 0 and κ carries the remaining rotation.
OpkPose OpkFromCamFromWorld(const Rigid3d& cam_from_world);

}  // namespace mmba
