// The resolution test of the cloud registration.

#include "registration/cloud/pose_resolution.h"

#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

#include "registration/cloud/score_significance.h"

namespace mmba::registration::internal {

double PoseResolution(const std::vector<Eigen::Vector3d>& src,
                      const std::vector<Eigen::Vector3d>& src_n, const TargetCrop& crop,
                      const Eigen::Matrix4d& t, const std::vector<double>& base_residuals,
                      const std::vector<bool>& base_agree, double reach, double tau, double block,
                      double bound, double max_delta, double t_min, bool principal_axes,
                      const std::vector<Vector6d>& extra_directions,
                      BoundTest* open_at_bound,
                      const BoundTest* known_at_bound) {
  if (src.size() < 10) return std::numeric_limits<double>::infinity();
  Eigen::Vector3d c;
  Eigen::Matrix3d cov;
  RegisteredMoments(src, t, &c, &cov);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  // Motions ξ = (ω, t) about c with an RMS displacement of 1 m over the source.
  std::vector<Vector6d> dirs;
  for (int k = 0; k < 3 && principal_axes; ++k) {
    const Eigen::Vector3d a = eig.eigenvectors().col(k);
    // RMS distance of the source from the axis a through c: sqrt(trace(cov) − aᵀ·cov·a).
    const double radius = std::sqrt(std::max(0.0, cov.trace() - a.dot(cov * a)));
    for (double sign : {1.0, -1.0}) {
      Vector6d shift = Vector6d::Zero();
      shift.tail<3>() = sign * a;
      dirs.push_back(shift);
      if (radius > 0) {
        Vector6d turn = Vector6d::Zero();
        turn.head<3>() = sign * a / radius;
        dirs.push_back(turn);
      }
    }
  }
  for (const Vector6d& xi : extra_directions) {
    if (!xi.allFinite() || xi.isZero()) continue;
    dirs.push_back(xi);
    dirs.push_back(-xi);
  }
  if (dirs.empty()) return 0.0;
  auto resolved = [&](const Vector6d& xi, double delta) {
    std::vector<double> residuals;
    std::vector<bool> agree;
    FineResiduals(src, src_n, crop, MotionAbout(delta * xi, c) * t, reach, &residuals, &agree);
    return ScoreSignificance(src, base_residuals, base_agree, residuals, agree, tau, block) >=
           t_min;
  };
  // The directions in `which` tested at delta on two threads (each verdict is independent, so
  // the result is the same as one by one); returns those not resolved, in order.
  auto unresolved = [&](const std::vector<size_t>& which, double delta) {
    std::vector<char> ok(which.size(), 0);
    const long n = static_cast<long>(which.size());
#pragma omp parallel for num_threads(2) schedule(dynamic, 1)
    for (long k = 0; k < n; ++k) ok[k] = resolved(dirs[which[k]], delta) ? 1 : 0;
    std::vector<size_t> still;
    for (size_t k = 0; k < which.size(); ++k) {
      if (!ok[k]) still.push_back(which[k]);
    }
    return still;
  };
  std::vector<size_t> all(dirs.size());
  for (size_t d = 0; d < dirs.size(); ++d) all[d] = d;
  std::vector<size_t> open =
      known_at_bound != nullptr ? known_at_bound->open : unresolved(all, bound);
  if (open_at_bound != nullptr) {
    open_at_bound->open = open;
    open_at_bound->directions.clear();
    for (size_t d : open) open_at_bound->directions.push_back(dirs[d]);
    return open.empty() ? bound : std::numeric_limits<double>::infinity();
  }
  if (open.empty()) {
    double delta = bound;
    for (int k = 0; k < 3; ++k) {
      if (!unresolved(all, delta / 2.0).empty()) break;
      delta /= 2.0;
    }
    return delta;
  }
  // 2·bound, 4·bound, … and max_delta itself last (the doubling need not land on it).
  for (double delta = bound; delta < max_delta * 0.9999;) {
    delta = std::min(2.0 * delta, max_delta);
    open = unresolved(open, delta);
    if (open.empty()) return delta;
  }
  return std::numeric_limits<double>::infinity();
}

}  // namespace mmba::registration::internal
