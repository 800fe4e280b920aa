// Stage of the cloud registration: the chosen pose's covariance and resolution.

#include "registration/cloud/registration_stages.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "mmba/core/logging.h"
#include "registration/cloud/fit_uncertainty.h"
#include "registration/cloud/point_to_plane_icp.h"

namespace mmba::registration::internal {

namespace {

// The fit's dependence on its last correspondence distance and on its objective, a
// systematic error the residuals' covariance does not contain: point-to-plane ICP ended at
// half and at twice that distance (at most the reach); after a plane-to-plane fit
// (`icp_plane_to_plane`) also point-to-plane's own answer, which differs where the two clouds'
// surfaces differ in detail (a plane proxy against a scan). On the simulated cathedral's plane
// proxy → LiDAR the point-to-plane pose moved 3.1 cm (twice) and 18.6 cm (half) from one 8 cm
// off the truth whose covariance said 0.7 cm. Without ICP (--no-icp) the pose is a sample
// consensus's, not the fit's optimum: its distance to that optimum (the same ICP it skipped)
// enters whole, so that the stated σ covers the error it left (Stanford bun000 → bun045:
// 0.66 mm RMS off, σ 0.09 mm without this term). Returns (ICP end distance, weight) pairs.
std::vector<std::pair<double, double>> SystematicMoves(const CloudRegistrationOptions& options, const Finalist& f) {
  std::vector<std::pair<double, double>> moves =
      options.icp ? std::vector<std::pair<double, double>>{{0.5 * f.icp_end, 0.5},
                                                           {2.0 * f.icp_end, 0.5}}
                  : std::vector<std::pair<double, double>>{
                        {options.icp_distance_spacing * f.spacing, 1.0}};
  // After a plane-to-plane fit, also point-to-plane's own answer, whole.
  if (options.icp && options.icp_plane_to_plane) {
    moves.push_back({options.icp_distance_spacing * f.spacing, 1.0});
  }
  return moves;
}

// Adds the systematic moves' second moments to the result's covariance, sets
// gate_sensitivity_m (their RMS over the source), and the σ and weakest motion of the sum.
void AddSystematicError(RegistrationContext& ctx, const Finalist& f, const FitUncertainty& u, double reach,
                        Vector6d* weakest) {
  const CloudRegistrationOptions& options = ctx.options;
  CloudRegistrationResult& result = ctx.result;
  const Eigen::Matrix4d inv = f.h.transform.inverse();
  const Matrix6d& metric = u.metric;
  Matrix6d systematic = Matrix6d::Zero();
  double sum_sq = 0.0;
  for (const auto& [distance, weight] : SystematicMoves(options, f)) {
    const double end = std::min(reach, distance);
    const Eigen::Matrix4d moved = PointToPlaneIcp(
        ctx.fine_src, f.crop->level.points, f.crop->level.normals, *f.crop->index, f.h.transform,
        options.icp ? end : std::max(end, reach), end,
        options.icp_iterations, nullptr);
    const Eigen::Matrix4d delta = moved * inv;  // as MotionAbout(ξ, centre)
    const Eigen::Matrix3d r = delta.topLeftCorner<3, 3>();
    const Eigen::AngleAxisd aa(r);
    Vector6d xi;
    xi.head<3>() = aa.angle() * aa.axis();
    xi.tail<3>() = delta.topRightCorner<3, 1>() - u.centre + r * u.centre;
    systematic += weight * xi * xi.transpose();
    sum_sq += weight * xi.dot(metric * xi);
  }
  result.gate_sensitivity_m = std::sqrt(sum_sq);
  result.covariance += systematic;
  if (!options.icp) {
    std::ostringstream note;
    note << std::setprecision(3) << "not refined by ICP (--no-icp): the pose is "
         << result.gate_sensitivity_m
         << " m RMS over the source from the fit's optimum; its covariance includes that";
    result.notes.push_back(note.str());
  }
  const Eigen::LLT<Matrix6d> llt(metric);
  if (llt.info() == Eigen::Success) {
    const Matrix6d l = llt.matrixL();
    const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(l.transpose() * result.covariance * l);
    result.sigma_rms_m = std::sqrt(std::max(0.0, eig.eigenvalues()(5)));
    *weakest = l.transpose().triangularView<Eigen::Upper>().solve(eig.eigenvectors().col(5));
  } else {
    result.sigma_rms_m = std::hypot(u.sigma_rms, result.gate_sensitivity_m);
  }
}

// The σ per rotation axis and translation axis, and the weakest motion's description (at
// 1 σ, or at the resolution `bound` when unconstrained).
void RecordSigmas(CloudRegistrationResult& result, const FitUncertainty& u, const Vector6d& weakest,
                  double bound) {
  for (int k = 0; k < 3; ++k) {
    result.sigma_rotation_deg(k) = std::sqrt(result.covariance(k, k)) * 180.0 / M_PI;
    result.sigma_translation_m(k) = std::sqrt(result.covariance(3 + k, 3 + k));
  }
  std::ostringstream at_bound;
  at_bound << std::setprecision(3) << " (unconstrained; shown for " << bound
           << " m RMS, the resolution bound)";
  if (!weakest.isZero()) {
    result.weakest_motion =
        std::isfinite(u.sigma_rms) ? DescribeMotion(weakest, result.sigma_rms_m) + " (1 sigma)"
                                   : DescribeMotion(weakest, bound) + at_bound.str();
  }
}

// The pose's resolution along the axes (at the bound) and, when probed, along the fit's weak
// motions (at their own bound; the δ grid ·2 / ÷2 from there).
void ResolvePose(RegistrationContext& ctx, const Finalist& f, const FitUncertainty& u, double reach,
                 double bound) {
  const CloudRegistrationOptions& options = ctx.options;
  CloudRegistrationResult& result = ctx.result;
  BestTested& best_tested = ctx.best_tested;
  // The local search tested this pose at the bound already when it left it as the best.
  const bool tested = best_tested.crop == f.crop.get() && best_tested.spacing == f.spacing &&
                      best_tested.transform == f.h.transform;
  ctx.axis_resolution = PoseResolution(ctx.fine_src, ctx.fine_src_n, *f.crop, f.h.transform, f.residuals,
                                       f.agree, reach, ctx.fine_tau, ctx.support_radius, bound,
                                       ctx.support_radius, options.resolution_t, true, {}, nullptr,
                                       tested ? &best_tested.test : nullptr);
  if (options.probe_weak_motions && !u.weak_directions.empty()) {
    const double weak_bound = options.max_weak_motion_resolution_spacing * f.spacing;
    result.weak_motion_resolution_m = PoseResolution(
        ctx.fine_src, ctx.fine_src_n, *f.crop, f.h.transform, f.residuals, f.agree, reach, ctx.fine_tau,
        ctx.support_radius, weak_bound, ctx.support_radius, options.resolution_t, false,
        u.weak_directions);
    ctx.weak_motion = DescribeMotion(u.weak_directions.front(), bound);
  }
  result.resolution_m = std::max(ctx.axis_resolution, result.weak_motion_resolution_m);
}

}  // namespace

void EstimateUncertainty(RegistrationContext& ctx) {
  const CloudRegistrationOptions& options = ctx.options;
  CloudRegistrationResult& result = ctx.result;
  ctx.axis_resolution = std::numeric_limits<double>::infinity();
  if (options.paper_only) return;
  const Finalist& f = ctx.finalists.front();
  result.fine_spacing_m = f.spacing;
  const double reach = std::min(ctx.normal_radius, options.normal_radius_spacing * f.spacing);
  const FitUncertainty u = EstimateFitUncertainty(ctx.fine_src, *f.crop, f.h.transform, f.residuals,
                                                  f.agree, reach, ctx.fine_tau, ctx.support_radius);
  result.covariance = u.covariance;
  result.covariance_centre = u.centre;
  result.sigma_rms_m = u.sigma_rms;
  result.constraint_ratio = u.constraint_ratio;
  Vector6d weakest = u.weakest;
  if ((!options.icp || f.icp_end > 0) && std::isfinite(u.sigma_rms)) {
    AddSystematicError(ctx, f, u, reach, &weakest);
  }
  const double bound = options.max_resolution_spacing * f.spacing;
  RecordSigmas(result, u, weakest, bound);
  ResolvePose(ctx, f, u, reach, bound);
  spdlog::debug("registration: pose resolution {:.4g} m (axes {:.4g} m, weak motions {:.4g} m; "
                "fine spacing {:.4g} m), sigma {:.4g} m RMS over {} blocks, {:.4g} m with the "
                "ICP distance's {:.4g} m, constraint ratio {:.3g}, weakest motion {}",
                result.resolution_m, ctx.axis_resolution, result.weak_motion_resolution_m, f.spacing,
                u.sigma_rms, u.blocks, result.sigma_rms_m, result.gate_sensitivity_m,
                u.constraint_ratio, result.weakest_motion);
  ctx.EndStage("resolution");
}

}  // namespace mmba::registration::internal
