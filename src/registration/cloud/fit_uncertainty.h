#pragma once

// How well the inliers of the fine fit determine the pose: the covariance of a small
// correction of the registered source, its weakest motions, and the motions in words.

#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "registration/cloud/verification.h"

namespace mmba::registration::internal {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

/// A small motion ξ = (ω, t) of registered points about a centre c: q ↦ c + Exp(ω)(q − c) + t
/// (ω a rotation vector, rad; t metres), as a 4×4 transform applied after the pose.
Eigen::Matrix4d MotionAbout(const Vector6d& xi, const Eigen::Vector3d& c);

/// RMS-displacement metric of the motions ξ about c over the registered points q:
/// (1/N) Σ ‖ω × (q − c) + t‖² = ξᵀ M ξ.
Matrix6d DisplacementMetric(const std::vector<Eigen::Vector3d>& q, const Eigen::Vector3d& c);

/// How well do the inliers of the fine fit determine the pose? The point-to-plane residual of
/// an inlier q with target normal n changes under ξ by Jᵀξ, J = ((q − c) × n, n) (Chen &
/// Medioni 1991; linearised as Low 2004, Eq. 6–8), so H = Σ J Jᵀ is the Gauss–Newton matrix of
/// the fit. A plane leaves the in-plane shifts and the turn about its normal in H's null space
/// (Gelfand et al., "Geometrically stable sampling for the ICP algorithm", 3DIM 2003, Sec. 3:
/// the eigenvectors of this matrix with small eigenvalues are the motions the points do not
/// constrain). The covariance of ξ is the cluster-robust sandwich H⁻¹ (Σ_b g_b g_bᵀ) H⁻¹
/// · B/(B − 1) over B blocks of `block` metres of the source, g_b = Σ_{i∈b} J_i r_i (Liang &
/// Zeger 1986; White 1980): a reconstruction's errors are correlated over its smoothing
/// window, and a block of such points is one observation, not hundreds. With fewer than 12
/// blocks (a 6×6 meat estimated from fewer than 2 blocks per parameter is rank-poor and would
/// claim certainty in the motions it does not see) the plain s² H⁻¹ is used, inflated by the
/// points per block. Everything is expressed in the RMS metric M of DisplacementMetric
/// (M = L Lᵀ, η = Lᵀ ξ: ‖η‖ is the RMS displacement of the source), where the eigenvalues of
/// H and of the covariance compare motions of equal size.
struct FitUncertainty {
  Matrix6d covariance = Matrix6d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Matrix6d metric = Matrix6d::Zero();  // M about `centre` (set whenever sigma_rms is finite)
  double sigma_rms = std::numeric_limits<double>::infinity();
  double constraint_ratio = 0.0;
  Vector6d weakest = Vector6d::Zero();  // the least-determined motion, unit RMS
  std::vector<Vector6d> weak_directions;  // H's two weakest motions (unit RMS), for the probes
  int blocks = 0;
};

/// FitUncertainty of the pose `t` from the fine residuals of `src` against `crop` (inliers:
/// |r| < `tau` with agreeing normals and a target point within `reach`), blocks of `block`
/// metres of the source.
FitUncertainty EstimateFitUncertainty(const std::vector<Eigen::Vector3d>& src,
                                      const TargetCrop& crop, const Eigen::Matrix4d& t,
                                      const std::vector<double>& residuals,
                                      const std::vector<bool>& agree, double reach, double tau,
                                      double block);

/// "a turn of 1.9° about (0, 0, 1) and a shift of 0.35 m along (0.7, 0.7, 0)" for scale·ξ (a
/// part below 1e-6 of the other is left out).
std::string DescribeMotion(const Vector6d& xi, double scale);

/// Centroid c and covariance (1/N) Σ (q − c)(q − c)ᵀ of the source points registered by t.
void RegisteredMoments(const std::vector<Eigen::Vector3d>& src, const Eigen::Matrix4d& t,
                       Eigen::Vector3d* c, Eigen::Matrix3d* cov);

}  // namespace mmba::registration::internal
