#include "mmba/stats/statistics.h"

#include <cmath>
#include <random>

#include <Eigen/Dense>
#include <gtest/gtest.h>

namespace mmba::stats {
namespace {

// A levelling factor: (h_to − h_from − dh) / σ.
struct LevelResidual {
  double dh, sigma;
  template <typename T>
  bool operator()(const T* from, const T* to, T* r) const {
    r[0] = (to[0] - from[0] - T(dh)) / T(sigma);
    return true;
  }
};

struct Level {
  int from, to;
  double dh, sigma;
};

class LevelGroup : public FactorGroup {
 public:
  LevelGroup(std::string name, std::vector<Level> obs, std::vector<double>* heights)
      : FactorGroup(std::move(name), "m", LossOptions()), obs_(std::move(obs)), h_(heights) {}
  void AddResiduals(Scene&, ceres::Problem& problem) override {
    for (size_t i = 0; i < obs_.size(); ++i) {
      const Level& o = obs_[i];
      auto* cost = new ceres::AutoDiffCostFunction<LevelResidual, 1, 1, 1>(
          new LevelResidual{o.dh, o.sigma});
      AddBlock(problem, cost, {&(*h_)[o.from], &(*h_)[o.to]}, o.sigma, i);
    }
  }

 private:
  std::vector<Level> obs_;
  std::vector<double>* h_;
};

struct Fixture {
  std::vector<double> h = {100.0, 100.0, 100.0, 100.0};
  std::vector<Level> a = {{0, 1, 1.003, 0.002}, {1, 2, 2.001, 0.002}, {2, 0, -2.996, 0.003}};
  std::vector<Level> b = {{1, 3, 0.502, 0.004}, {3, 2, 1.497, 0.004}, {0, 3, 1.508, 0.005}};
  ceres::Problem problem;
  Scene scene;
  std::unique_ptr<LevelGroup> ga, gb;

  explicit Fixture(bool fix_first) {
    ga = std::make_unique<LevelGroup>("short", a, &h);
    gb = std::make_unique<LevelGroup>("long", b, &h);
    ga->AddResiduals(scene, problem);
    gb->AddResiduals(scene, problem);
    if (fix_first) problem.SetParameterBlockConstant(&h[0]);
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::DENSE_QR;
    options.function_tolerance = 1e-16;
    options.parameter_tolerance = 1e-16;
    options.gradient_tolerance = 1e-16;
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
  }
};

// The same adjustment by hand: A, P, x = (AᵀPA)⁻¹AᵀPl with h0 fixed.
TEST(Statistics, MatchesHandComputedLeastSquares) {
  Fixture f(/*fix_first=*/true);
  std::vector<Level> all = f.a;
  all.insert(all.end(), f.b.begin(), f.b.end());
  const int m = static_cast<int>(all.size());
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(m, 3);
  Eigen::VectorXd l(m), w(m);
  for (int i = 0; i < m; ++i) {
    if (all[i].to > 0) A(i, all[i].to - 1) += 1;
    if (all[i].from > 0) A(i, all[i].from - 1) -= 1;
    l(i) = all[i].dh + (all[i].from == 0 ? 100.0 : 0.0) - (all[i].to == 0 ? 100.0 : 0.0);
    w(i) = 1.0 / (all[i].sigma * all[i].sigma);
  }
  const Eigen::MatrixXd N = A.transpose() * w.asDiagonal() * A;
  const Eigen::MatrixXd Q = N.inverse();
  const Eigen::VectorXd x = Q * A.transpose() * w.asDiagonal() * l;
  const Eigen::VectorXd v = A * x - l;
  const double vpv = v.transpose() * w.asDiagonal() * v;
  const int dof = m - 3;

  StatisticsOptions options;
  options.confidence = 0.95;
  const NetworkStatistics st = ComputeStatistics(f.problem, {f.ga.get(), f.gb.get()}, options);
  EXPECT_EQ(st.num_equations, m);
  EXPECT_EQ(st.num_unknowns, 3);
  EXPECT_EQ(st.degrees_of_freedom, dof);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(f.h[k + 1], x(k), 1e-9);
  EXPECT_NEAR(st.sum_squares, vpv, 1e-9 * vpv);
  EXPECT_NEAR(st.sigma0_ratio, std::sqrt(vpv / dof), 1e-9);
  const double s2 = vpv / dof;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      EXPECT_NEAR(st.Covariance(&f.h[a + 1], 0, &f.h[b + 1], 0), s2 * Q(a, b), 1e-12);
    }
  }
  EXPECT_EQ(st.Covariance(&f.h[0], 0, &f.h[1], 0), 0.0);  // fixed
  // Redundancy numbers r = diag(I − A Q Aᵀ P), Σ r = dof; studentized v/(s σ sqrt r).
  const Eigen::MatrixXd R = Eigen::MatrixXd::Identity(m, m) - A * Q * A.transpose() * w.asDiagonal();
  double sum_r = 0.0;
  int max_i = 0;
  for (int i = 0; i < m; ++i) {
    EXPECT_NEAR(st.rows[i].redundancy, R(i, i), 1e-9);
    EXPECT_NEAR(st.rows[i].residual, v(i), 1e-10);
    const double t = v(i) / (std::sqrt(s2) * all[i].sigma * std::sqrt(R(i, i)));
    EXPECT_NEAR(st.rows[i].studentized, t, 1e-6);
    if (std::abs(t) > std::abs(v(max_i) / (all[max_i].sigma * std::sqrt(R(max_i, max_i))))) {
      max_i = i;
    }
    sum_r += st.rows[i].redundancy;
  }
  EXPECT_NEAR(sum_r, dof, 1e-9);
  EXPECT_EQ(st.max_row, max_i);
  // Variance components per group: Σ e² / Σ r; their redundancy-weighted mean is σ0².
  ASSERT_EQ(st.groups.size(), 2u);
  const double pooled = (st.groups[0].variance_component * st.groups[0].redundancy +
                         st.groups[1].variance_component * st.groups[1].redundancy) / dof;
  EXPECT_NEAR(pooled, s2, 1e-9);
  // χ² bounds: sqrt(χ²(0.025, 3)/3), sqrt(χ²(0.975, 3)/3) with χ² = 0.2158, 9.3484.
  EXPECT_NEAR(st.chi2_lower, std::sqrt(0.215795 / 3), 1e-5);
  EXPECT_NEAR(st.chi2_upper, std::sqrt(9.348404 / 3), 1e-5);
  EXPECT_NEAR(st.critical_value, 3.182446, 1e-5);  // Student t(0.975, 3)
}

TEST(Statistics, SingularNetworkNamesTheCause) {
  Fixture f(/*fix_first=*/false);
  StatisticsOptions options;
  options.describe = [&](const double* block, int) {
    return "height " + std::to_string(block - f.h.data());
  };
  try {
    ComputeStatistics(f.problem, {f.ga.get(), f.gb.get()}, options);
    FAIL() << "expected DegenerateNetworkError";
  } catch (const DegenerateNetworkError& e) {
    EXPECT_NE(std::string(e.what()).find("datum defect 1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("height"), std::string::npos) << e.what();
  }
}

TEST(Statistics, MinimumNormDatumOnConstrainedPoints) {
  Fixture f(/*fix_first=*/false);
  // Heights 1 and 2 constrained: their changes from the reference sum to zero, as in GNU
  // Gama's free network.
  StatisticsOptions options;
  options.minimum_norm = {{&f.h[1], 0}, {&f.h[2], 0}};
  const std::vector<double> reference = {100.5, 101.5};
  EXPECT_EQ(ApplyMinimumNorm(f.problem, options, reference), 1);
  EXPECT_NEAR((f.h[1] - 100.5) + (f.h[2] - 101.5), 0.0, 1e-9);
  const NetworkStatistics st = ComputeStatistics(f.problem, {f.ga.get(), f.gb.get()}, options);
  EXPECT_EQ(st.defect, 1);
  EXPECT_EQ(st.degrees_of_freedom, 6 - 4 + 1);
  // The constrained heights' covariance sums to zero along the datum (σ²(h1+h2) = 0).
  const double var_sum = st.Covariance(&f.h[1], 0, &f.h[1], 0) +
                         2 * st.Covariance(&f.h[1], 0, &f.h[2], 0) +
                         st.Covariance(&f.h[2], 0, &f.h[2], 0);
  EXPECT_NEAR(var_sum, 0.0, 1e-12);
  EXPECT_GT(st.Covariance(&f.h[3], 0, &f.h[3], 0), 0.0);
}

// The Schur path (a block eliminated as the tie points of a bundle block) gives the same
// redundancy numbers, σ0 and cofactor of the kept blocks as the full inverse.
TEST(Statistics, SchurEliminationMatchesFullInverse) {
  Fixture f(/*fix_first=*/true);
  const NetworkStatistics full = ComputeStatistics(f.problem, {f.ga.get(), f.gb.get()}, StatisticsOptions());
  StatisticsOptions options;
  options.eliminate = {&f.h[3]};
  const NetworkStatistics schur = ComputeStatistics(f.problem, {f.ga.get(), f.gb.get()}, options);
  EXPECT_EQ(schur.degrees_of_freedom, full.degrees_of_freedom);
  EXPECT_NEAR(schur.sigma0_ratio, full.sigma0_ratio, 1e-12);
  ASSERT_EQ(schur.rows.size(), full.rows.size());
  for (size_t i = 0; i < full.rows.size(); ++i) {
    EXPECT_NEAR(schur.rows[i].redundancy, full.rows[i].redundancy, 1e-9) << "row " << i;
    EXPECT_NEAR(schur.rows[i].studentized, full.rows[i].studentized, 1e-9) << "row " << i;
  }
  for (int a : {1, 2}) {
    for (int b : {1, 2}) {
      EXPECT_NEAR(schur.Covariance(&f.h[a], 0, &f.h[b], 0), full.Covariance(&f.h[a], 0, &f.h[b], 0), 1e-15);
    }
  }
  EXPECT_FALSE(schur.IsFree(&f.h[3]));
  EXPECT_NEAR(schur.groups[1].redundancy, full.groups[1].redundancy, 1e-9);
  // h1 and h3 share an observation: they cannot both be eliminated.
  options.eliminate = {&f.h[1], &f.h[3]};
  EXPECT_THROW(ComputeStatistics(f.problem, {f.ga.get(), f.gb.get()}, options), std::invalid_argument);
}

// The sparse path (unknowns beyond dense_limit; the cofactor is the selected inverse on the
// factor's pattern, entries outside it solved when asked) gives the redundancy numbers
// diag(I − A Q Aᵀ P), the studentized residuals and the cofactor of a dense least-squares
// computation, and Σ r = dof.
TEST(Statistics, SparsePathMatchesDenseLeastSquares) {
  const int num_heights = 600;
  std::vector<double> h(num_heights, 100.0);
  std::vector<Level> levels;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_int_distribution<int> pick(0, num_heights - 1);
  for (int i = 1; i < num_heights; ++i) levels.push_back({i - 1, i, 0.1 + 0.002 * noise(rng), 0.002});
  while (static_cast<int>(levels.size()) < 3 * num_heights) {
    const int a = pick(rng), b = pick(rng);
    if (a == b) continue;
    levels.push_back({a, b, 0.1 * (b - a) + 0.003 * noise(rng), 0.003});
  }
  ceres::Problem problem;
  Scene scene;
  LevelGroup group("levels", levels, &h);
  group.AddResiduals(scene, problem);
  problem.SetParameterBlockConstant(&h[0]);
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver.function_tolerance = solver.parameter_tolerance = solver.gradient_tolerance = 1e-16;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);

  StatisticsOptions options;
  options.dense_limit = 0;  // the sparse path
  const NetworkStatistics st = ComputeStatistics(problem, {&group}, options);

  const int m = static_cast<int>(levels.size()), n = num_heights - 1;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(m, n);
  Eigen::VectorXd sigma(m), l(m);
  for (int i = 0; i < m; ++i) {
    if (levels[i].to > 0) A(i, levels[i].to - 1) += 1;
    if (levels[i].from > 0) A(i, levels[i].from - 1) -= 1;
    l(i) = levels[i].dh + (levels[i].from == 0 ? 100.0 : 0.0) - (levels[i].to == 0 ? 100.0 : 0.0);
    sigma(i) = levels[i].sigma;
  }
  const Eigen::MatrixXd Aw = sigma.cwiseInverse().asDiagonal() * A;  // whitened
  const Eigen::MatrixXd Q = (Aw.transpose() * Aw).ldlt().solve(Eigen::MatrixXd::Identity(n, n));
  const Eigen::VectorXd x = Q * Aw.transpose() * sigma.cwiseInverse().asDiagonal() * l;
  const Eigen::VectorXd v = A * x - l;
  const int dof = m - n;
  const double s0 = std::sqrt((v.cwiseQuotient(sigma)).squaredNorm() / dof);
  EXPECT_NEAR(st.sigma0_ratio, s0, 1e-9 * s0);
  ASSERT_EQ(st.degrees_of_freedom, dof);
  ASSERT_EQ(static_cast<int>(st.rows.size()), m);
  for (int a = 0; a < n; a += 37) {
    for (int b = 0; b < n; b += 53) {
      EXPECT_NEAR(st.cofactor(st.column.at(&h[a + 1]), st.column.at(&h[b + 1])), Q(a, b),
                  1e-10 * Q(a, a));
    }
  }
  double sum_r = 0.0;
  for (int i = 0; i < m; ++i) {
    const double r = 1.0 - Aw.row(i).dot(Q * Aw.row(i).transpose());
    EXPECT_NEAR(st.rows[i].redundancy, r, 1e-10) << "row " << i;
    EXPECT_NEAR(st.rows[i].residual, v(i), 1e-9) << "row " << i;
    const double t = v(i) / (s0 * sigma(i) * std::sqrt(r));
    EXPECT_NEAR(st.rows[i].studentized, t, 1e-6 * std::max(1.0, std::abs(t))) << "row " << i;
    sum_r += st.rows[i].redundancy;
  }
  EXPECT_NEAR(sum_r, dof, 1e-8);
}

TEST(Statistics, EllipseAndQuantiles) {
  Eigen::Matrix2d c;
  c << 4.0, 0.0, 0.0, 1.0;
  ErrorEllipse e = StandardEllipse(c);
  EXPECT_NEAR(e.a, 2.0, 1e-12);
  EXPECT_NEAR(e.b, 1.0, 1e-12);
  EXPECT_NEAR(e.angle_rad, 0.0, 1e-12);
  const double t = M_PI / 6;
  Eigen::Matrix2d r;
  r << std::cos(t), -std::sin(t), std::sin(t), std::cos(t);
  e = StandardEllipse(r * c * r.transpose());
  EXPECT_NEAR(e.a, 2.0, 1e-12);
  EXPECT_NEAR(e.angle_rad, t, 1e-12);
  Eigen::Vector3d axes;
  Eigen::Matrix3d dirs;
  StandardEllipsoid(Eigen::Vector3d(1, 9, 4).asDiagonal(), &axes, &dirs);
  EXPECT_NEAR(axes(0), 3.0, 1e-12);
  EXPECT_NEAR(axes(2), 1.0, 1e-12);
  EXPECT_NEAR(std::abs(dirs(1, 0)), 1.0, 1e-12);
  EXPECT_NEAR(NormalUpperQuantile(0.025), 1.959964, 1e-6);
  EXPECT_NEAR(StudentUpperQuantile(0.025, 37), 2.026192, 1e-6);  // Gama's confidence-scale
  EXPECT_NEAR(ChiSquareQuantile(0.975, 8), 17.534546, 1e-5);
}

}  // namespace
}  // namespace mmba::stats
