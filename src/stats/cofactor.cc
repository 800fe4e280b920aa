#include "mmba/stats/cofactor.h"

#include <algorithm>
#include <stdexcept>
#include <utility>

namespace mmba::stats {

Cofactor::Cofactor(Eigen::MatrixXd dense) : n_(static_cast<int>(dense.rows())), dense_(std::move(dense)) {
  if (dense_.rows() != dense_.cols()) throw std::invalid_argument("Cofactor: a square matrix expected");
}

Cofactor Cofactor::Selected(std::shared_ptr<const Factor> factor, Eigen::VectorXd scale) {
  Cofactor q;
  const int n = static_cast<int>(scale.size());
  q.n_ = n;
  q.scale_ = std::move(scale);
  q.permuted_.resize(n);
  const auto& p = factor->permutationP().indices();
  for (int a = 0; a < n; ++a) q.permuted_[a] = p.size() == n ? p(a) : a;
  // L (unit lower, strict part stored) in compressed columns with sorted rows.
  const auto& l = factor->matrixL().nestedExpression();
  q.start_.assign(n + 1, 0);
  for (int j = 0; j < n; ++j) {
    int count = 0;
    for (Eigen::SparseMatrix<double>::InnerIterator it(l, j); it; ++it) count += it.row() > j;
    q.start_[j + 1] = q.start_[j] + count;
  }
  q.row_.resize(q.start_[n]);
  std::vector<double> lvalue(q.start_[n]);
  std::vector<std::pair<int, double>> column;
  for (int j = 0; j < n; ++j) {
    column.clear();
    for (Eigen::SparseMatrix<double>::InnerIterator it(l, j); it; ++it) {
      if (it.row() > j) column.emplace_back(static_cast<int>(it.row()), it.value());
    }
    std::sort(column.begin(), column.end());
    for (size_t k = 0; k < column.size(); ++k) {
      q.row_[q.start_[j] + k] = column[k].first;
      lvalue[q.start_[j] + k] = column[k].second;
    }
  }
  // Takahashi's recurrence for Z = (L D Lᵀ)⁻¹, columns from the last: for i > j on the
  // pattern of L(:, j),  Z(i, j) = −Σ_k Z(i, k)·L(k, j),  Z(j, j) = 1/D(j) − Σ_k L(k, j)·Z(k, j),
  // k over the pattern of L(:, j). Every Z(i, k) needed lies on the pattern of a later column
  // (the rows of a column of L form a clique of the filled graph).
  const Eigen::VectorXd d = factor->vectorD();
  q.diagonal_.resize(n);
  q.value_.assign(q.start_[n], 0.0);
  for (int j = n - 1; j >= 0; --j) {
    const int begin = q.start_[j], end = q.start_[j + 1];
    for (int a = begin; a < end; ++a) {
      const int i = q.row_[a];
      double sum = 0.0;
      for (int b = begin; b < end; ++b) {
        const int k = q.row_[b];
        sum += (i == k ? q.diagonal_(i) : q.Stored(std::max(i, k), std::min(i, k))) * lvalue[b];
      }
      q.value_[a] = -sum;
    }
    double diagonal = 1.0 / d(j);
    for (int a = begin; a < end; ++a) diagonal -= lvalue[a] * q.value_[a];
    q.diagonal_(j) = diagonal;
  }
  q.factor_ = std::move(factor);
  q.solved_ = std::make_shared<SolvedColumn>();
  return q;
}

double Cofactor::Stored(int i, int j) const {
  const auto first = row_.begin() + start_[j], last = row_.begin() + start_[j + 1];
  const auto it = std::lower_bound(first, last, i);
  if (it == last || *it != i) throw std::logic_error("Cofactor: an entry outside the pattern");
  return value_[it - row_.begin()];
}

double Cofactor::operator()(int a, int b) const {
  if (a < 0 || b < 0 || a >= n_ || b >= n_) throw std::out_of_range("Cofactor: index out of range");
  if (factor_ == nullptr) return dense_(a, b);
  const int i = std::max(permuted_[a], permuted_[b]), j = std::min(permuted_[a], permuted_[b]);
  const double s = scale_(a) * scale_(b);
  if (i == j) return s * diagonal_(i);
  const auto first = row_.begin() + start_[j], last = row_.begin() + start_[j + 1];
  const auto it = std::lower_bound(first, last, i);
  if (it != last && *it == i) return s * value_[it - row_.begin()];
  return Solved(a, b);
}

double Cofactor::Solved(int a, int b) const {
  std::lock_guard<std::mutex> lock(solved_->mutex);
  if (solved_->column != b) {
    Eigen::VectorXd unit = Eigen::VectorXd::Zero(n_);
    unit(b) = 1.0;
    solved_->values = factor_->solve(unit);
    solved_->column = b;
  }
  return scale_(a) * scale_(b) * solved_->values(a);
}

Eigen::MatrixXd Cofactor::Dense() const {
  if (factor_ == nullptr) return dense_;
  Eigen::MatrixXd out(n_, n_);
  for (int b = 0; b < n_; ++b) {
    Eigen::VectorXd unit = Eigen::VectorXd::Zero(n_);
    unit(b) = 1.0;
    out.col(b) = factor_->solve(unit).cwiseProduct(scale_) * scale_(b);
  }
  return out;
}

size_t Cofactor::StoredEntries() const {
  if (factor_ == nullptr) return static_cast<size_t>(dense_.size());
  return static_cast<size_t>(n_) + value_.size();
}

void Cofactor::Clear() { *this = Cofactor(); }

}  // namespace mmba::stats
