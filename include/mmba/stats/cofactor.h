#pragma once

// The cofactor matrix Q = N⁻¹ of an adjustment (N = JᵀJ of the whitened problem), held either
// whole (small networks, ceres::Covariance, the Schur path over cameras) or as its selected
// inverse: the entries on the pattern of the sparse Cholesky factor only (Takahashi, Fagan &
// Chen 1973; Erisman & Tinney 1975). That pattern holds every pair of unknowns that share an
// observation, which is all redundancy numbers h_ii = j_iᵀ Q j_i and point covariances need,
// so memory grows with the factor's non-zeros, not with the square of the unknowns.
// An entry outside the pattern is computed when asked, by one solve with the factor.

#include <memory>
#include <mutex>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCholesky>

namespace mmba::stats {

class Cofactor {
 public:
  using Factor = Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>;

  Cofactor() = default;
  /// The whole matrix.
  explicit Cofactor(Eigen::MatrixXd dense);
  /// Selected inverse of N = D⁻¹·ns·D⁻¹ from the factor of the scaled normal matrix ns
  /// (D = diag(scale)⁻¹): Q(a, b) = scale(a)·scale(b)·ns⁻¹(a, b).
  static Cofactor Selected(std::shared_ptr<const Factor> factor, Eigen::VectorXd scale);

  int rows() const { return n_; }
  int cols() const { return n_; }
  bool IsDense() const { return factor_ == nullptr; }
  /// Q(a, b): exact wherever it lies (a solve with the factor outside the stored pattern).
  double operator()(int a, int b) const;
  /// The whole matrix (n×n doubles: for tests and small networks).
  Eigen::MatrixXd Dense() const;
  /// Stored entries (n² when dense).
  size_t StoredEntries() const;
  /// Frees the storage; rows() becomes 0.
  void Clear();

 private:
  double Stored(int i, int j) const;  // permuted indices, i >= j, (i, j) on the pattern or -1
  double Solved(int a, int b) const;  // by a solve for column b

  int n_ = 0;
  Eigen::MatrixXd dense_;
  // Selected inverse Z = ns⁻¹ in the factor's permuted order: diagonal, and the strict lower
  // triangle on the pattern of L in compressed columns with sorted row indices.
  std::shared_ptr<const Factor> factor_;
  Eigen::VectorXd scale_;
  std::vector<int> permuted_;  // original column -> permuted index
  Eigen::VectorXd diagonal_;
  std::vector<int> start_;     // column starts, size n + 1
  std::vector<int> row_;
  std::vector<double> value_;
  // Column solved last (entries outside the pattern are asked for a few at a time per
  // column); shared by copies, which share the factor too.
  struct SolvedColumn {
    std::mutex mutex;
    int column = -1;
    Eigen::VectorXd values;
  };
  std::shared_ptr<SolvedColumn> solved_;
};

}  // namespace mmba::stats
