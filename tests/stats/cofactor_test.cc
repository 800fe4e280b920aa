#include "mmba/stats/cofactor.h"

#include <random>

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <gtest/gtest.h>

namespace mmba::stats {
namespace {

// A sparse SPD matrix like a levelling network's normal matrix: a chain of n unknowns plus
// `extra` random links, with a weight on the first unknown (the datum).
Eigen::SparseMatrix<double> Network(int n, int extra, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  std::uniform_real_distribution<double> weight(0.5, 2.0);
  std::vector<Eigen::Triplet<double>> t;
  auto link = [&](int a, int b) {
    const double w = weight(rng);
    t.emplace_back(a, a, w);
    t.emplace_back(b, b, w);
    t.emplace_back(a, b, -w);
    t.emplace_back(b, a, -w);
  };
  for (int i = 1; i < n; ++i) link(i - 1, i);
  for (int k = 0; k < extra;) {
    const int a = pick(rng), b = pick(rng);
    if (a != b) link(a, b), ++k;
  }
  t.emplace_back(0, 0, 10.0);
  Eigen::SparseMatrix<double> m(n, n);
  m.setFromTriplets(t.begin(), t.end());
  return m;
}

Cofactor SelectedOf(const Eigen::SparseMatrix<double>& n, const Eigen::VectorXd& scale) {
  Eigen::SparseMatrix<double> ns = scale.asDiagonal() * n * scale.asDiagonal();
  auto factor = std::make_shared<Cofactor::Factor>(ns);
  EXPECT_EQ(factor->info(), Eigen::Success);
  return Cofactor::Selected(std::move(factor), scale);
}

// Every entry of the selected inverse, on the factor's pattern and off it, equals the dense
// inverse D·ns⁻¹·D; Dense() gives the whole matrix.
TEST(Cofactor, SelectedInverseEqualsTheDenseInverse) {
  const int n = 120;
  const Eigen::SparseMatrix<double> normal = Network(n, 60, 3);
  Eigen::VectorXd scale = Eigen::MatrixXd(normal).diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd truth = Eigen::MatrixXd(normal).inverse();
  const Cofactor q = SelectedOf(normal, scale);
  ASSERT_FALSE(q.IsDense());
  ASSERT_EQ(q.rows(), n);
  const double tol = 1e-10 * truth.cwiseAbs().maxCoeff();
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) ASSERT_NEAR(q(a, b), truth(a, b), tol) << a << ", " << b;
  }
  EXPECT_LT((q.Dense() - truth).cwiseAbs().maxCoeff(), tol);
}

// Every pair of unknowns that share an observation (a non-zero of N) is on the stored pattern,
// and a sparse network stores far fewer entries than n².
TEST(Cofactor, StoresTheNormalMatrixPatternNotTheSquare) {
  const int n = 2000;
  const Eigen::SparseMatrix<double> normal = Network(n, 200, 5);
  const Cofactor q = SelectedOf(normal, Eigen::VectorXd::Ones(n));
  EXPECT_LT(q.StoredEntries(), static_cast<size_t>(n) * n / 20);
  EXPECT_GE(q.StoredEntries(), static_cast<size_t>(normal.nonZeros() + n) / 2);
  // A column of the inverse by a dense solve, checked on the pattern of N.
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(normal);
  for (int b : {0, 777, 1999}) {
    Eigen::VectorXd unit = Eigen::VectorXd::Zero(n);
    unit(b) = 1.0;
    const Eigen::VectorXd column = ldlt.solve(unit);
    for (Eigen::SparseMatrix<double>::InnerIterator it(normal, b); it; ++it) {
      EXPECT_NEAR(q(it.row(), b), column(it.row()), 1e-9 * column.cwiseAbs().maxCoeff());
    }
  }
}

TEST(Cofactor, DenseAndClear) {
  Eigen::MatrixXd m(2, 2);
  m << 2, 1, 1, 3;
  Cofactor q(m);
  EXPECT_TRUE(q.IsDense());
  EXPECT_EQ(q(0, 1), 1.0);
  EXPECT_EQ(q.StoredEntries(), 4u);
  EXPECT_THROW(q(2, 0), std::out_of_range);
  q.Clear();
  EXPECT_EQ(q.rows(), 0);
}

}  // namespace
}  // namespace mmba::stats
