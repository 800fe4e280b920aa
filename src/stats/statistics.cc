#include "mmba/stats/statistics.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <utility>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/normal.hpp>
#include <boost/math/distributions/students_t.hpp>

namespace mmba::stats {

bool StatisticsOptions::Check(std::string* error) const {
  if (!(confidence > 0.0 && confidence < 1.0)) {
    *error = "confidence: found " + std::to_string(confidence) + ", expected 0 < p < 1";
    return false;
  }
  if (!(rank_tolerance > 0.0 && rank_tolerance < 1e-2)) {
    *error = "rank_tolerance: found " + std::to_string(rank_tolerance) + ", expected (0, 1e-2)";
    return false;
  }
  if (!eliminate.empty() && (!minimum_norm.empty() || use_ceres_covariance)) {
    *error = "eliminate: the Schur path supports neither a minimum-norm datum nor ceres::Covariance";
    return false;
  }
  for (const MinimumNormCoordinate& c : minimum_norm) {
    if (c.block == nullptr || c.index < 0) {
      *error = "minimum_norm: a null block or negative index";
      return false;
    }
  }
  return true;
}

double NetworkStatistics::Covariance(const double* a, int i, const double* b, int j) const {
  const auto ia = column.find(a);
  const auto ib = column.find(b);
  if (ia == column.end() || ib == column.end()) return 0.0;
  return scale_used * scale_used * cofactor(ia->second + i, ib->second + j);
}

std::string NetworkStatistics::BriefReport() const {
  std::ostringstream s;
  s << "equations " << num_equations << ", unknowns " << num_unknowns << ", defect " << defect
    << ", dof " << degrees_of_freedom << ", sigma0 ratio " << std::setprecision(4)
    << sigma0_ratio << " (chi2 bounds " << chi2_lower << ".." << chi2_upper << ": "
    << (chi2_passed ? "passed" : "failed") << ")";
  return s.str();
}

double ChiSquareQuantile(double p, int dof) {
  boost::math::chi_squared_distribution<double> d(dof);
  return boost::math::quantile(d, p);
}

double StudentUpperQuantile(double upper_tail, int dof) {
  boost::math::students_t_distribution<double> d(dof);
  return boost::math::quantile(boost::math::complement(d, upper_tail));
}

double NormalUpperQuantile(double upper_tail) {
  boost::math::normal_distribution<double> d;
  return boost::math::quantile(boost::math::complement(d, upper_tail));
}

ErrorEllipse StandardEllipse(const Eigen::Matrix2d& c) {
  // Eigen-decomposition in closed form, as GNU Gama's std_error_ellipse (network.cpp).
  ErrorEllipse e;
  const double c11 = c(0, 0), c22 = c(1, 1), c12 = c(0, 1);
  const double root = std::sqrt((c11 - c22) * (c11 - c22) + 4 * c12 * c12);
  const double small = std::max(0.0, (c11 + c22 - root) / 2);
  e.a = std::sqrt(small + root);
  e.b = std::sqrt(small);
  if (root == 0.0) return e;
  e.angle_rad = std::atan2(2 * c12, c11 - c22) / 2;
  if (e.angle_rad < 0) e.angle_rad += M_PI;
  return e;
}

void StandardEllipsoid(const Eigen::Matrix3d& covariance, Eigen::Vector3d* semi_axes,
                       Eigen::Matrix3d* axes) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(covariance);
  for (int i = 0; i < 3; ++i) {
    (*semi_axes)(i) = std::sqrt(std::max(0.0, eig.eigenvalues()(2 - i)));
    axes->col(i) = eig.eigenvectors().col(2 - i);
  }
}

namespace {

struct Linearization {
  std::vector<double*> blocks;
  std::vector<int> sizes;
  std::map<const double*, int> column;
  int n = 0;
  int m = 0;
  Eigen::SparseMatrix<double, Eigen::RowMajor> jacobian;
  std::vector<double> residuals;
};

Linearization Linearize(ceres::Problem& problem,
                        const std::vector<ceres::ResidualBlockId>* residual_blocks,
                        const std::set<const double*>& last = {}) {
  Linearization lin;
  std::vector<double*> all;
  problem.GetParameterBlocks(&all);
  std::stable_partition(all.begin(), all.end(), [&](double* b) { return last.count(b) == 0; });
  for (double* block : all) {
    if (problem.IsParameterBlockConstant(block)) continue;
    const int size = problem.ParameterBlockTangentSize(block);
    if (size == 0) continue;
    lin.column[block] = lin.n;
    lin.blocks.push_back(block);
    lin.sizes.push_back(size);
    lin.n += size;
  }
  ceres::Problem::EvaluateOptions options;
  options.parameter_blocks = lin.blocks;
  if (residual_blocks) options.residual_blocks = *residual_blocks;
  options.apply_loss_function = false;
  options.num_threads = 1;
  ceres::CRSMatrix crs;
  double cost = 0.0;
  problem.Evaluate(options, &cost, &lin.residuals, nullptr, &crs);
  lin.m = crs.num_rows;
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(crs.values.size());
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) {
      triplets.emplace_back(r, crs.cols[k], crs.values[k]);
    }
  }
  lin.jacobian.resize(crs.num_rows, crs.num_cols);
  lin.jacobian.setFromTriplets(triplets.begin(), triplets.end());
  return lin;
}

std::string Describe(const Linearization& lin, const StatisticsOptions& options, int col) {
  for (size_t b = 0; b < lin.blocks.size(); ++b) {
    const int start = lin.column.at(lin.blocks[b]);
    if (col >= start && col < start + lin.sizes[b]) {
      if (options.describe) return options.describe(lin.blocks[b], col - start);
      std::ostringstream s;
      s << "parameter block " << b << " component " << col - start;
      return s.str();
    }
  }
  return "parameter " + std::to_string(col);
}

/// Result of the rank analysis.
struct Inverse {
  int defect = 0;
  Cofactor cofactor;           // n×n
  Eigen::MatrixXd null_space;  // n×defect (original units)
  Eigen::MatrixXd projector;   // P (n×n) when defect > 0
};

Inverse Analyze(const Linearization& lin, const StatisticsOptions& options, bool want_inverse) {
  Inverse out;
  const int n = lin.n;
  if (n == 0) return out;
  const Eigen::SparseMatrix<double> jt = lin.jacobian.transpose();
  Eigen::SparseMatrix<double> normal = jt * lin.jacobian;
  Eigen::VectorXd diag = normal.diagonal();
  double max_diag = diag.maxCoeff();
  for (int j = 0; j < n; ++j) {
    if (!(diag(j) > 1e-30 * std::max(1.0, max_diag))) {
      throw DegenerateNetworkError("singular network: no observation determines " +
                                   Describe(lin, options, j));
    }
  }
  const Eigen::VectorXd scale = diag.cwiseSqrt().cwiseInverse();
  if (n <= options.dense_limit) {
    Eigen::MatrixXd ns = Eigen::MatrixXd(normal);
    ns = scale.asDiagonal() * ns * scale.asDiagonal();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(ns);
    const Eigen::VectorXd& lambda = eig.eigenvalues();  // ascending
    const double lmax = lambda(n - 1);
    std::vector<int> null;
    for (int i = 0; i < n; ++i) {
      if (lambda(i) < options.rank_tolerance * lmax) null.push_back(i);
    }
    out.defect = static_cast<int>(null.size());
    if (out.defect > 0) {
      // Undetermined parameters: the largest components of the null vectors.
      Eigen::MatrixXd g(n, out.defect);
      for (int k = 0; k < out.defect; ++k) g.col(k) = eig.eigenvectors().col(null[k]);
      if (options.minimum_norm.empty()) {
        std::vector<std::pair<double, int>> weight;
        for (int j = 0; j < n; ++j) weight.emplace_back(g.row(j).norm(), j);
        std::sort(weight.rbegin(), weight.rend());
        std::ostringstream s;
        s << "singular network: datum defect " << out.defect
          << " and no constrained coordinates; undetermined: ";
        for (size_t k = 0; k < std::min<size_t>(4, weight.size()); ++k) {
          s << (k ? ", " : "") << Describe(lin, options, weight[k].second);
        }
        s << "; fix or constrain points";
        throw DegenerateNetworkError(s.str());
      }
      out.null_space = scale.asDiagonal() * g;  // original units
      Eigen::VectorXd e = Eigen::VectorXd::Zero(n);
      for (const MinimumNormCoordinate& c : options.minimum_norm) {
        const auto it = lin.column.find(c.block);
        if (it == lin.column.end()) continue;  // a fixed coordinate
        e(it->second + c.index) = 1.0;
      }
      const Eigen::MatrixXd ge = e.asDiagonal() * out.null_space;
      const Eigen::MatrixXd m = out.null_space.transpose() * ge;
      Eigen::JacobiSVD<Eigen::MatrixXd> svd(m);
      const Eigen::VectorXd sv = svd.singularValues();
      if (sv(sv.size() - 1) < 1e-10 * std::max(1e-300, sv(0)) || sv(0) == 0.0) {
        throw DegenerateNetworkError(
            "singular network: datum defect " + std::to_string(out.defect) +
            " is not removed by the constrained coordinates (too few or badly placed)");
      }
      out.projector = Eigen::MatrixXd::Identity(n, n) -
                      out.null_space * m.inverse() * ge.transpose();
    }
    if (want_inverse) {
      Eigen::VectorXd inv_lambda = Eigen::VectorXd::Zero(n);
      for (int i = 0; i < n; ++i) {
        if (!(lambda(i) < options.rank_tolerance * lmax)) inv_lambda(i) = 1.0 / lambda(i);
      }
      const Eigen::MatrixXd& v = eig.eigenvectors();
      Eigen::MatrixXd pinv = v * inv_lambda.asDiagonal() * v.transpose();
      pinv = scale.asDiagonal() * pinv * scale.asDiagonal();
      out.cofactor = Cofactor(out.defect > 0 ? Eigen::MatrixXd(out.projector * pinv *
                                                               out.projector.transpose())
                                             : pinv);
    }
    return out;
  }
  // Large problems: sparse LDLᵀ of the scaled normal matrix (no datum defect allowed).
  Eigen::SparseMatrix<double> ns = scale.asDiagonal() * normal * scale.asDiagonal();
  auto factor = std::make_shared<Cofactor::Factor>(ns);
  const Cofactor::Factor& ldlt = *factor;
  if (ldlt.info() != Eigen::Success) {
    throw DegenerateNetworkError("singular network: the normal matrix cannot be factorized");
  }
  const Eigen::VectorXd d = ldlt.vectorD();
  const double dmax = d.maxCoeff();
  for (int i = 0; i < n; ++i) {
    if (!(d(i) > options.rank_tolerance * dmax)) {
      const int col = ldlt.permutationPinv().indices()(i);
      if (!options.minimum_norm.empty()) {
        throw DegenerateNetworkError(
            "free network with " + std::to_string(n) +
            " unknowns is beyond the dense minimum-norm path (dense_limit); fix points");
      }
      throw DegenerateNetworkError("singular network (datum defect): undetermined " +
                                   Describe(lin, options, col) + "; fix or constrain points");
    }
  }
  if (want_inverse) out.cofactor = Cofactor::Selected(std::move(factor), scale);
  return out;
}

/// The Schur path of StatisticsOptions::eliminate: cofactor of the kept blocks (the first
/// `kept` columns of `lin`) and h_ii of every row.
struct SchurInverse {
  int kept = 0;  // columns of the kept blocks
  Eigen::MatrixXd cofactor;
  std::vector<double> h;
};

using RowIt = Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator;

/// Which eliminated block each row of `lin` touches. The kept blocks are the first `kept`
/// columns; an eliminated block is named by its first column.
struct EliminatedRows {
  int kept = 0;                                 // columns of the kept blocks
  std::vector<int> row_point;                   // eliminated block of each row; -1 = none
  std::map<int, std::vector<int>> rows_of_point;  // first column -> rows
  std::map<int, int> point_size;                // first column -> size
};

/// Assigns each row to the one eliminated block it touches; throws std::invalid_argument if
/// a row touches two.
EliminatedRows AssignRowsToEliminated(const Linearization& lin,
                                      const StatisticsOptions& options) {
  EliminatedRows e;
  int kept_blocks = 0;
  for (size_t b = 0; b < lin.blocks.size(); ++b) {
    if (options.eliminate.count(lin.blocks[b]) == 0) {
      e.kept += lin.sizes[b];
      ++kept_blocks;
    }
  }
  const int nc = e.kept;
  e.row_point.assign(lin.m, -1);
  for (size_t b = kept_blocks; b < lin.blocks.size(); ++b) {
    e.point_size[lin.column.at(lin.blocks[b])] = lin.sizes[b];
  }
  for (int r = 0; r < lin.m; ++r) {
    for (RowIt it(lin.jacobian, r); it; ++it) {
      if (it.col() < nc || it.value() == 0.0) continue;
      const int first = std::prev(e.point_size.upper_bound(it.col()))->first;
      if (e.row_point[r] >= 0 && e.row_point[r] != first) {
        throw std::invalid_argument("eliminate: a residual block touches two eliminated blocks");
      }
      e.row_point[r] = first;
    }
    if (e.row_point[r] >= 0) e.rows_of_point[e.row_point[r]].push_back(r);
  }
  return e;
}

/// U = AᵀA over the first `nc` (kept) columns.
Eigen::MatrixXd KeptNormalMatrix(const Linearization& lin, int nc) {
  Eigen::MatrixXd s = Eigen::MatrixXd::Zero(nc, nc);
  for (int r = 0; r < lin.m; ++r) {
    for (RowIt a(lin.jacobian, r); a; ++a) {
      if (a.col() >= nc) continue;
      for (RowIt c(lin.jacobian, r); c; ++c) {
        if (c.col() < nc) s(a.col(), c.col()) += a.value() * c.value();
      }
    }
  }
  return s;
}

/// One eliminated point p of size q, seen by k kept columns.
struct PointBlock {
  std::vector<int> cols;     // kept columns its rows touch
  Eigen::MatrixXd v_inv;     // q×q
  Eigen::MatrixXd g;         // q×k: V⁻¹ W_pᵀ on `cols`
};

/// Eliminates point `first` (size q, observed by `rows`): forms V_p and W_p, inverts V_p
/// and subtracts W_p V_p⁻¹ W_pᵀ from the reduced matrix `s`.
PointBlock EliminatePoint(const Linearization& lin, const StatisticsOptions& options, int nc,
                          int first, int q, const std::vector<int>& rows, Eigen::MatrixXd* s) {
  PointBlock pb;
  std::map<int, int> local;
  for (int r : rows) {
    for (RowIt it(lin.jacobian, r); it; ++it) {
      if (it.col() < nc && !local.count(it.col())) {
        local[it.col()] = 0;
      }
    }
  }
  for (auto& [col, index] : local) {
    index = static_cast<int>(pb.cols.size());
    pb.cols.push_back(col);
  }
  const int k = static_cast<int>(pb.cols.size());
  Eigen::MatrixXd v = Eigen::MatrixXd::Zero(q, q);
  Eigen::MatrixXd w = Eigen::MatrixXd::Zero(k, q);
  for (int r : rows) {
    Eigen::VectorXd a = Eigen::VectorXd::Zero(k), b = Eigen::VectorXd::Zero(q);
    for (RowIt it(lin.jacobian, r); it; ++it) {
      if (it.col() < nc) a(local.at(it.col())) = it.value();
      else b(it.col() - first) = it.value();
    }
    v += b * b.transpose();
    w += a * b.transpose();
  }
  Eigen::FullPivLU<Eigen::MatrixXd> lu(v);
  if (lu.rank() < q) {
    throw DegenerateNetworkError("singular network: an eliminated point (" +
                                 Describe(lin, options, first) +
                                 ") is not determined by its observations");
  }
  pb.v_inv = lu.inverse();
  pb.g = pb.v_inv * w.transpose();
  const Eigen::MatrixXd update = w * pb.g;
  for (int i = 0; i < k; ++i) {
    for (int j = 0; j < k; ++j) (*s)(pb.cols[i], pb.cols[j]) -= update(i, j);
  }
  return pb;
}

/// S⁻¹ with Jacobi scaling; a non-positive pivot names the parameter.
Eigen::MatrixXd InvertReduced(const Eigen::MatrixXd& s, const Linearization& lin,
                              const StatisticsOptions& options) {
  const int nc = static_cast<int>(s.rows());
  Eigen::VectorXd diag = s.diagonal();
  for (int j = 0; j < nc; ++j) {
    if (!(diag(j) > 1e-30)) {
      throw DegenerateNetworkError("singular network: no observation determines " +
                                   Describe(lin, options, j));
    }
  }
  const Eigen::VectorXd scale = diag.cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd scaled = scale.asDiagonal() * s * scale.asDiagonal();
  Eigen::LDLT<Eigen::MatrixXd> ldlt(scaled);
  const Eigen::VectorXd pivots = ldlt.vectorD();
  for (int j = 0; j < nc; ++j) {
    if (!(pivots(j) > options.rank_tolerance)) {
      throw DegenerateNetworkError(
          "singular network (datum defect or an undetermined parameter) near " +
          Describe(lin, options, j));
    }
  }
  return scale.asDiagonal() * ldlt.solve(Eigen::MatrixXd::Identity(nc, nc)) *
         scale.asDiagonal();
}

/// h_ii of the rows of point `first`, given the cofactor of the kept columns.
void PointRowsLeverage(const Linearization& lin, int nc, int first, const PointBlock& pb,
                       const std::vector<int>& rows, const Eigen::MatrixXd& cofactor,
                       std::vector<double>* h) {
  const int k = static_cast<int>(pb.cols.size());
  Eigen::MatrixXd m(k, k);
  for (int i = 0; i < k; ++i) {
    for (int j = 0; j < k; ++j) m(i, j) = cofactor(pb.cols[i], pb.cols[j]);
  }
  std::map<int, int> local;
  for (int i = 0; i < k; ++i) local[pb.cols[i]] = i;
  // h = zᵀMz + bᵀV⁻¹b with z = a − gᵀb, expanded so that each row costs the square of its
  // own few columns, not of all k columns of its point (k is every frame that sees the
  // point): h = aᵀMa − 2aᵀ(Mgᵀ)b + bᵀ(gMgᵀ + V⁻¹)b, Mgᵀ (k×q) and gMgᵀ (q×q) once per point.
  const Eigen::MatrixXd m_gt = m * pb.g.transpose();
  const Eigen::MatrixXd inner = pb.g * m_gt + pb.v_inv;
  const int q = static_cast<int>(pb.v_inv.rows());
  std::vector<std::pair<int, double>> a;
  for (int r : rows) {
    Eigen::VectorXd b = Eigen::VectorXd::Zero(q);
    a.clear();
    for (RowIt it(lin.jacobian, r); it; ++it) {
      if (it.col() < nc) a.emplace_back(local.at(it.col()), it.value());
      else b(it.col() - first) = it.value();
    }
    double ama = 0.0;
    Eigen::VectorXd a_mgt = Eigen::VectorXd::Zero(q);
    for (const auto& [i, vi] : a) {
      for (const auto& [j, vj] : a) ama += vi * vj * m(i, j);
      a_mgt += vi * m_gt.row(i).transpose();
    }
    (*h)[r] = ama - 2.0 * a_mgt.dot(b) + b.dot(inner * b);
  }
}

SchurInverse AnalyzeSchur(const Linearization& lin, const StatisticsOptions& options) {
  SchurInverse out;
  const EliminatedRows e = AssignRowsToEliminated(lin, options);
  out.kept = e.kept;
  const int nc = out.kept;
  // S = U − Σ_p W_p V_p⁻¹ W_pᵀ.
  Eigen::MatrixXd s = KeptNormalMatrix(lin, nc);
  std::map<int, PointBlock> points;
  for (const auto& [first, rows] : e.rows_of_point) {
    points[first] = EliminatePoint(lin, options, nc, first, e.point_size.at(first), rows, &s);
  }
  out.cofactor = InvertReduced(s, lin, options);
  // h_ii per row.
  out.h.assign(lin.m, 0.0);
  for (const auto& [first, pb] : points) {
    PointRowsLeverage(lin, nc, first, pb, e.rows_of_point.at(first), out.cofactor, &out.h);
  }
  for (int r = 0; r < lin.m; ++r) {
    if (e.row_point[r] >= 0) continue;
    double h = 0.0;
    for (RowIt a(lin.jacobian, r); a; ++a) {
      for (RowIt c(lin.jacobian, r); c; ++c) h += a.value() * c.value() * out.cofactor(a.col(), c.col());
    }
    out.h[r] = h;
  }
  return out;
}

std::vector<ceres::ResidualBlockId> AllBlocks(const std::vector<const FactorGroup*>& groups) {
  std::vector<ceres::ResidualBlockId> ids;
  for (const FactorGroup* g : groups) {
    ids.insert(ids.end(), g->residual_blocks().begin(), g->residual_blocks().end());
  }
  return ids;
}

}  // namespace

int CheckDatum(ceres::Problem& problem, const StatisticsOptions& options) {
  const Linearization lin = Linearize(problem, nullptr);
  return Analyze(lin, options, /*want_inverse=*/false).defect;
}

int ApplyMinimumNorm(ceres::Problem& problem, const StatisticsOptions& options,
                     const std::vector<double>& reference) {
  if (options.minimum_norm.empty()) return 0;
  const Linearization lin = Linearize(problem, nullptr);
  const Inverse inv = Analyze(lin, options, /*want_inverse=*/false);
  if (inv.defect == 0) return 0;
  Eigen::VectorXd x(lin.n);
  for (size_t b = 0; b < lin.blocks.size(); ++b) {
    if (problem.ParameterBlockSize(lin.blocks[b]) != lin.sizes[b]) {
      throw std::invalid_argument("ApplyMinimumNorm: parameter blocks with manifolds");
    }
    for (int k = 0; k < lin.sizes[b]; ++k) x(lin.column.at(lin.blocks[b]) + k) = lin.blocks[b][k];
  }
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(lin.n);
  for (size_t i = 0; i < options.minimum_norm.size(); ++i) {
    const MinimumNormCoordinate& c = options.minimum_norm[i];
    const auto it = lin.column.find(c.block);
    if (it == lin.column.end()) continue;
    delta(it->second + c.index) = c.block[c.index] - reference.at(i);
  }
  // x_new = x − G (GᵀEG)⁻¹ GᵀE (x − x_ref): the projector P applied to the correction.
  x -= (Eigen::MatrixXd::Identity(lin.n, lin.n) - inv.projector) * delta;
  for (size_t b = 0; b < lin.blocks.size(); ++b) {
    for (int k = 0; k < lin.sizes[b]; ++k) lin.blocks[b][k] = x(lin.column.at(lin.blocks[b]) + k);
  }
  return inv.defect;
}

NetworkStatistics ComputeStatistics(ceres::Problem& problem,
                                    const std::vector<const FactorGroup*>& groups,
                                    const StatisticsOptions& options) {
  std::string error;
  if (!options.Check(&error)) throw std::invalid_argument(error);
  const std::vector<ceres::ResidualBlockId> ids = AllBlocks(groups);
  const Linearization lin = Linearize(problem, &ids, options.eliminate);
  Inverse inv;
  std::vector<double> schur_h;
  std::vector<double*> kept_blocks = lin.blocks;
  std::map<const double*, int> kept_column = lin.column;
  if (!options.eliminate.empty()) {
    SchurInverse schur = AnalyzeSchur(lin, options);
    inv.cofactor = Cofactor(std::move(schur.cofactor));
    schur_h = std::move(schur.h);
    kept_blocks.clear();
    kept_column.clear();
    for (double* b : lin.blocks) {
      if (options.eliminate.count(b)) continue;
      kept_column[b] = lin.column.at(b);
      kept_blocks.push_back(b);
    }
  } else {
    inv = Analyze(lin, options, /*want_inverse=*/!options.use_ceres_covariance);
  }
  if (options.use_ceres_covariance) {
    if (inv.defect > 0) {
      throw std::invalid_argument(
          "use_ceres_covariance: the network has a datum defect (minimum-norm datum); use the "
          "explicit path");
    }
    ceres::Covariance::Options covariance_options;
    covariance_options.algorithm_type = ceres::SPARSE_QR;  // SuiteSparse QR
    covariance_options.num_threads = 1;
    ceres::Covariance covariance(covariance_options);
    std::vector<std::pair<const double*, const double*>> pairs;
    for (size_t a = 0; a < lin.blocks.size(); ++a) {
      for (size_t b = a; b < lin.blocks.size(); ++b) pairs.emplace_back(lin.blocks[a], lin.blocks[b]);
    }
    if (!covariance.Compute(pairs, &problem)) {
      throw DegenerateNetworkError(
          "ceres::Covariance failed: the Jacobian is rank deficient (a datum defect or a "
          "parameter no observation determines)");
    }
    Eigen::MatrixXd cofactor = Eigen::MatrixXd::Zero(lin.n, lin.n);
    for (size_t a = 0; a < lin.blocks.size(); ++a) {
      for (size_t b = a; b < lin.blocks.size(); ++b) {
        const int na = lin.sizes[a], nb = lin.sizes[b];
        Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> block(na, nb);
        covariance.GetCovarianceBlockInTangentSpace(lin.blocks[a], lin.blocks[b], block.data());
        const int ra = lin.column.at(lin.blocks[a]), rb = lin.column.at(lin.blocks[b]);
        cofactor.block(ra, rb, na, nb) = block;
        cofactor.block(rb, ra, nb, na) = block.transpose();
      }
    }
    inv.cofactor = Cofactor(std::move(cofactor));
  }

  NetworkStatistics st;
  st.confidence = options.confidence;
  st.num_equations = lin.m;
  st.num_unknowns = lin.n;
  st.defect = inv.defect;
  st.degrees_of_freedom = lin.m - lin.n + inv.defect;
  st.blocks = kept_blocks;
  st.column = kept_column;
  st.cofactor = std::move(inv.cofactor);
  for (double r : lin.residuals) st.sum_squares += r * r;
  const int dof = st.degrees_of_freedom;
  st.sigma0_ratio = dof > 0 ? std::sqrt(st.sum_squares / dof) : 0.0;
  st.scale_used = options.use_apriori_sigma0 ? 1.0 : st.sigma0_ratio;
  const double alpha = 1.0 - options.confidence;
  if (dof > 0) {
    st.chi2_lower = std::sqrt(ChiSquareQuantile(alpha / 2, dof) / dof);
    st.chi2_upper = std::sqrt(ChiSquareQuantile(1 - alpha / 2, dof) / dof);
    st.chi2_passed = st.sigma0_ratio >= st.chi2_lower && st.sigma0_ratio <= st.chi2_upper;
    st.critical_value = options.use_apriori_sigma0 ? NormalUpperQuantile(alpha / 2)
                                                   : StudentUpperQuantile(alpha / 2, dof);
  } else if (options.use_apriori_sigma0) {
    st.critical_value = NormalUpperQuantile(alpha / 2);
  }

  // Rows: residuals, redundancy h_ii = j_iᵀ Q j_i, studentized residuals (Baarda 1968; with
  // the a-posteriori σ0 Pope's τ), as GNU Gama's LocalNetwork::studentized_residual.
  int row_index = 0;
  double max_abs = -1.0;
  for (size_t g = 0; g < groups.size(); ++g) {
    const FactorGroup* group = groups[g];
    const auto* correlated = dynamic_cast<const CorrelatedBlockSource*>(group);
    GroupStatistic gs;
    gs.name = group->name();
    for (size_t b = 0; b < group->residual_blocks().size(); ++b) {
      const int size =
          problem.GetCostFunctionForResidualBlock(group->residual_blocks()[b])->num_residuals();
      Eigen::MatrixXd l;
      if (correlated) {
        l = correlated->BlockSqrtCovariance(b);
      } else {
        l = Eigen::MatrixXd::Identity(size, size) * group->block_sigmas()[b];
      }
      Eigen::VectorXd e(size);
      for (int k = 0; k < size; ++k) e(k) = lin.residuals[row_index + k];
      const Eigen::VectorXd v = l * e;
      for (int k = 0; k < size; ++k) {
        const int r = row_index + k;
        RowStatistic rs;
        rs.group = g;
        rs.block = b;
        rs.row = k;
        rs.whitened = e(k);
        rs.residual = v(k);
        rs.sigma = l.row(k).norm();
        double h = 0.0;
        if (!schur_h.empty()) {
          h = schur_h[r];
        } else {
          using RowIt = Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator;
          for (RowIt a(lin.jacobian, r); a; ++a) {
            for (RowIt c(lin.jacobian, r); c; ++c) h += a.value() * c.value() * st.cofactor(a.col(), c.col());
          }
        }
        h = std::min(1.0, std::max(0.0, h));
        rs.redundancy = 1.0 - h;
        rs.control = 100.0 * std::abs(1.0 - std::sqrt(h));
        const double denominator = st.scale_used * rs.sigma * std::sqrt(rs.redundancy);
        rs.studentized = denominator > 0 ? rs.residual / denominator : 0.0;
        rs.critical = dof > 0 && rs.control >= 0.1 && std::abs(rs.studentized) > st.critical_value;
        if (rs.control >= 0.1 && std::abs(rs.studentized) > max_abs) {
          max_abs = std::abs(rs.studentized);
          st.max_row = static_cast<int>(st.rows.size());
        }
        gs.rows += 1;
        gs.sum_squares += e(k) * e(k);
        gs.redundancy += rs.redundancy;
        st.rows.push_back(rs);
      }
      row_index += size;
    }
    gs.variance_component = gs.redundancy > 1e-12 ? gs.sum_squares / gs.redundancy : 0.0;
    st.groups.push_back(gs);
  }
  if (st.max_row >= 0) st.max_row_critical = st.rows[st.max_row].critical;
  return st;
}

}  // namespace mmba::stats
