#include "mmba/registration/mi/mi_registration.h"

#include <cmath>
#include <random>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include "mmba/core/logging.h"
#include "registration/mi/mi_internal.h"

namespace mmba::registration::mi {

namespace {

// Σ JᵀJ of the points' pixel Jacobians: the information the points' pixels hold on the
// correction (RaiseToPixelFloor, WeaklyObservedDirection).
Eigen::Matrix<double, 6, 6> PixelInformation(
    const std::vector<Eigen::Matrix<double, 2, 6>>& jacobians) {
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  for (const Eigen::Matrix<double, 2, 6>& j : jacobians) information += j.transpose() * j;
  return information;
}

}  // namespace

Eigen::Matrix<double, 6, 6> RaiseToPixelFloor(
    const Eigen::Matrix<double, 6, 6>& covariance,
    const std::vector<Eigen::Matrix<double, 2, 6>>& jacobians, double mean_variance,
    int* raised) {
  *raised = 0;
  if (jacobians.empty() || !(mean_variance > 0)) return covariance;
  const Eigen::Matrix<double, 6, 6> information =
      PixelInformation(jacobians) / static_cast<double>(jacobians.size());
  Eigen::LLT<Eigen::Matrix<double, 6, 6>> information_llt(information);
  if (information_llt.info() != Eigen::Success) return covariance;
  const Eigen::Matrix<double, 6, 6> floor =
      (mean_variance / 6.0) * information_llt.solve(Eigen::Matrix<double, 6, 6>::Identity());
  Eigen::LLT<Eigen::Matrix<double, 6, 6>> floor_llt(floor);
  if (floor_llt.info() != Eigen::Success) return covariance;
  const Eigen::Matrix<double, 6, 6> l = floor_llt.matrixL();
  const Eigen::Matrix<double, 6, 6> l_inv =
      l.triangularView<Eigen::Lower>().solve(Eigen::Matrix<double, 6, 6>::Identity());
  const Eigen::Matrix<double, 6, 6> whitened = l_inv * covariance * l_inv.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(
      0.5 * (whitened + whitened.transpose()));
  Vector6d values = eigen.eigenvalues();
  for (int i = 0; i < 6; ++i) {
    if (values[i] < 1.0) {
      values[i] = 1.0;
      ++*raised;
    }
  }
  const Eigen::Matrix<double, 6, 6> raised_whitened =
      eigen.eigenvectors() * values.asDiagonal() * eigen.eigenvectors().transpose();
  const Eigen::Matrix<double, 6, 6> result = l * raised_whitened * l.transpose();
  return 0.5 * (result + result.transpose());
}

Vector6d WeaklyObservedDirection(const std::vector<Eigen::Matrix<double, 2, 6>>& jacobians,
                                 const Vector6d& bound) {
  if (jacobians.empty()) return Vector6d::Zero();
  const Eigen::Matrix<double, 6, 6> scaled =
      bound.asDiagonal() * PixelInformation(jacobians) * bound.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(scaled);
  if (eigen.info() != Eigen::Success) return Vector6d::Zero();
  spdlog::debug("MI weakly observed direction: eigenvalue {:.4g} (largest {:.4g})",
                eigen.eigenvalues()[0], eigen.eigenvalues()[5]);
  const Vector6d u = eigen.eigenvectors().col(0);  // eigenvalues ascending
  const double largest = u.cwiseAbs().maxCoeff();
  if (!(largest > 0)) return Vector6d::Zero();
  return bound.cwiseProduct(u) / largest;
}

namespace internal {

// Hessian of MI (nats) w.r.t. the correction (units m, deg): a full quadratic
// f(x + d) ≈ a + gᵀd + ½ dᵀHd fitted by least squares to samples on a ±2h star and random
// points of the box x ± 2h. The rendered metric is piecewise constant at the pixel scale, so
// a regression over many samples is far steadier than finite differences.
Eigen::Matrix<double, 6, 6> MiHessian(const FrameSetEvaluator& evaluator, const Rigid3d& start,
                                      const Vector6d& x, const MetricOptions& metric, int level,
                                      const FrameSetEvaluator::SampleSet* samples, int threads,
                                      int* evaluations) {
  Vector6d h;
  h << 0.04, 0.04, 0.04, 0.2, 0.2, 0.2;
  std::vector<Vector6d> offsets;  // in units of h
  offsets.push_back(Vector6d::Zero());
  for (int i = 0; i < 6; ++i) {
    for (double s : {-2.0, -1.0, 1.0, 2.0}) {
      Vector6d d = Vector6d::Zero();
      d[i] = s;
      offsets.push_back(d);
    }
  }
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> uniform(-2.0, 2.0);
  while (offsets.size() < 56) {
    Vector6d d;
    for (int i = 0; i < 6; ++i) d[i] = uniform(rng);
    offsets.push_back(d);
  }
  constexpr int kTerms = 1 + 6 + 21;
  Eigen::MatrixXd design(offsets.size(), kTerms);
  Eigen::VectorXd values(offsets.size());
  for (size_t k = 0; k < offsets.size(); ++k) {
    const Vector6d& d = offsets[k];  // scaled coordinates
    int col = 0;
    design(k, col++) = 1.0;
    for (int i = 0; i < 6; ++i) design(k, col++) = d[i];
    for (int i = 0; i < 6; ++i) {
      for (int j = i; j < 6; ++j) design(k, col++) = (i == j ? 0.5 : 1.0) * d[i] * d[j];
    }
  }
  ParallelFor(static_cast<int>(offsets.size()), threads, [&](int k) {
    values[k] = evaluator.Evaluate(ApplyCorrection(start, x + offsets[k].cwiseProduct(h)), level,
                                   metric, samples)
                    .mi *
                M_LN2;
  });
  *evaluations += static_cast<int>(offsets.size());
  const Eigen::VectorXd coef = design.colPivHouseholderQr().solve(values);
  Eigen::Matrix<double, 6, 6> hessian;
  int col = 7;
  for (int i = 0; i < 6; ++i) {
    for (int j = i; j < 6; ++j) {
      // Back from scaled coordinates: ∂²f/∂x_i∂x_j = H_scaled(i, j) / (h_i h_j).
      hessian(i, j) = hessian(j, i) = coef[col++] / (h[i] * h[j]);
    }
  }
  return hessian;
}

// Second derivative of MI (nats per unit²) along a unit direction of the correction: a
// parabola a + b·t + ½·c·t² fitted by least squares to 13 samples t ∈ [−0.3, 0.3].
double CurvatureAlong(const FrameSetEvaluator& evaluator, const Rigid3d& start, const Vector6d& x,
                      const Vector6d& direction, const MetricOptions& metric, int level,
                      const FrameSetEvaluator::SampleSet* samples, int threads,
                      int* evaluations) {
  constexpr int kSide = 6;
  constexpr double kStep = 0.05;
  Eigen::Matrix<double, 2 * kSide + 1, 3> design;
  Eigen::Matrix<double, 2 * kSide + 1, 1> values;
  for (int k = -kSide; k <= kSide; ++k) {
    const double t = k * kStep;
    design.row(k + kSide) << 1.0, t, 0.5 * t * t;
  }
  ParallelFor(2 * kSide + 1, threads, [&](int k) {
    const double t = (k - kSide) * kStep;
    values[k] =
        evaluator.Evaluate(ApplyCorrection(start, x + t * direction), level, metric, samples)
            .mi *
        M_LN2;
  });
  *evaluations += 2 * kSide + 1;
  return design.colPivHouseholderQr().solve(values)[2];
}

// Per point of `sample` (those that project at x ± the steps): ∂pixel/∂correction at x, in
// pixels of the frame's image per m and per degree (central differences).
std::vector<Eigen::Matrix<double, 2, 6>> PixelJacobians(
    const FrameSetEvaluator& evaluator, const Rigid3d& start, const Vector6d& x,
    const std::vector<FrameSetEvaluator::VisiblePoint>& sample) {
  Vector6d h;
  h << 1e-3, 1e-3, 1e-3, 1e-2, 1e-2, 1e-2;
  std::vector<Eigen::Matrix<double, 2, 6>> jacobians;
  for (const FrameSetEvaluator::VisiblePoint& point : sample) {
    const View& view = evaluator.frames()[point.frame].views[point.view];
    Eigen::Matrix<double, 2, 6> jacobian;
    bool ok = true;
    for (int k = 0; k < 6 && ok; ++k) {
      Vector6d a = x, b = x;
      a[k] += h[k];
      b[k] -= h[k];
      Eigen::Vector2d pa, pb;
      ok = evaluator.Project(point, ApplyCorrection(start, a), &pa) &&
           evaluator.Project(point, ApplyCorrection(start, b), &pb);
      if (ok) jacobian.col(k) = PixelDifference(view, pa, pb) / (2 * h[k]);
    }
    if (ok) jacobians.push_back(view.image_pixels_per_pixel * jacobian);
  }
  return jacobians;
}

// Per Jacobian J of PixelJacobians: the predicted pixel variance trace(J Σ Jᵀ), in pixels² of
// the frame's image.
std::vector<double> PredictedPixelVariances(
    const std::vector<Eigen::Matrix<double, 2, 6>>& jacobians,
    const Eigen::Matrix<double, 6, 6>& covariance) {
  std::vector<double> variances;
  for (const Eigen::Matrix<double, 2, 6>& jacobian : jacobians) {
    variances.push_back((jacobian * covariance * jacobian.transpose()).trace());
  }
  return variances;
}

}  // namespace internal

}  // namespace mmba::registration::mi
