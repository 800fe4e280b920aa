// The datum of a photo_measurements block without control: inner constraints (free network,
// minimum trace over the object points), and every point's covariance.
//
// The solve fixes a minimal datum (ProblemBuilder's gauge: the first image's pose and its
// distance to the second, or the first pose with the scale from scale bars). Both outputs of
// it are then carried into the inner-constraints datum by Baarda's S-transformation (Baarda
// 1973, "S-transformations and criterion matrices"; Förstner & Wrobel 2016, "Photogrammetric
// Computer Vision", Sect. 4.5.3, Eqs. 4.225-4.232; Luhmann et al. 2020, "Close-Range
// Photogrammetry and 3D Imaging", Sect. 4.4.3.3), with the object points as datum points:
//  - the coordinates: the solution moved by the similarity (rotation, translation and, without
//    scale bars, scale; Umeyama 1991) that brings its points closest to their approximations
//    x⁰ in the least-squares sense. Its first-order conditions are the inner constraints
//    Gᵀ(x − x⁰) = 0 (Σ shifts = 0, Σ x⁰ × shifts = 0, and to second order Σ x⁰ᵀ shifts = 0);
//  - the covariance: Σ_S = S Σ Sᵀ, S = I − G (G_Pᵀ G_P)⁻¹ G_Pᵀ (P: the point rows), G the
//    tangent of the similarities at the solution (7 columns: translation, rotation, scale;
//    6 with scale bars). Among all datums it gives the smallest trace of the points' covariance.
// The minimal-datum covariance comes from stats::ComputeStatistics, whose Schur path holds
// the cofactor C of the kept blocks (poses, intrinsics, scale-bar ends) only. For an
// eliminated point j with normal blocks V_j and W_j (Triggs et al. 2000, Sect. 6.1):
// Σ_jj = V_j⁻¹ + E_j C E_jᵀ, Σ_jK = −E_j C, Σ_ij = E_i C E_jᵀ, with E_j = V_j⁻¹ W_jᵀ. Writing
// L_j = −E_j (a selector row for a kept point) and D_j = V_j⁻¹ (0 for a kept point), every
// sum the S-transformation needs has the size of the kept blocks:
//   F = Σ_j G_jᵀ L_j,  M = Σ_j G_jᵀ D_j G_j,  Q = Σ_jk G_jᵀ Σ_jk G_k = F C Fᵀ + M,
//   B_j = Σ_i G_iᵀ Σ_ij = F C L_jᵀ + G_jᵀ D_j,
//   Σ_S,jj = Σ_jj − G_j H⁻¹ B_j − B_jᵀ H⁻¹ G_jᵀ + G_j H⁻¹ Q H⁻¹ G_jᵀ,  H = Σ_j G_jᵀ G_j,
// and likewise the kept blocks (B_K = F C) and the first image, held in the minimal datum.
#include <cmath>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <ceres/manifold.h>

#include "blocks.h"
#include "mmba/stats/cofactor.h"
#include "photo_measurements.h"

namespace mmba::adjust::internal {
namespace {

/// Finite step of the similarity's parameters whose tangent G is taken through each block's
/// manifold (its Minus); G is linear in the step, so the step only needs to stay well above
/// rounding (block values of order 1-1000).
constexpr double kStep = 1e-6;

/// The block's points that define the datum (every point not held).
std::vector<Point3DId> DatumPoints(const JointState& s) {
  std::vector<Point3DId> points;
  for (const auto& [name, id] : s.measured->point_of) {
    if (!s.measured->fixed_points.count(id)) points.push_back(id);
  }
  return points;
}

/// The motion of world points under the similarity parameter k (0-2 translation, 3-5
/// rotation, 6 scale) about the centroid c: dx = e_k, ω_k × (x − c), (x − c).
Eigen::Vector3d PointMotion(const Eigen::Vector3d& x, const Eigen::Vector3d& c, int k) {
  if (k < 3) return Eigen::Vector3d::Unit(k);
  if (k < 6) return Eigen::Vector3d::Unit(k - 3).cross(x - c);
  return x - c;
}

/// A pose cam_from_world (R, t) under the world motion of parameter k, step h: the image
/// is unchanged when R' = R Exp(−ω), t' = (1 + s) t − R τ', τ' = τ − ω × c − s c.
Rigid3d MovedPose(const Rigid3d& pose, const Eigen::Vector3d& c, int k, double h) {
  Rigid3d moved = pose;
  Eigen::Vector3d tau = Eigen::Vector3d::Zero();
  double scale = 0.0;
  if (k < 3) tau = h * Eigen::Vector3d::Unit(k);
  if (k >= 3 && k < 6) {
    const Eigen::Vector3d omega = h * Eigen::Vector3d::Unit(k - 3);
    tau = -omega.cross(c);
    moved.rotation = (pose.rotation * Eigen::Quaterniond(Eigen::AngleAxisd(-h, Eigen::Vector3d::Unit(k - 3)))).normalized();
  }
  if (k == 6) {
    scale = h;
    tau = -h * c;
  }
  moved.translation = (1.0 + scale) * pose.translation - pose.rotation * tau;
  return moved;
}

/// Tangent of `block` (values `before` → `after`) per unit step, through its manifold.
Eigen::VectorXd Tangent(const ceres::Problem& problem, const double* block, const double* before, const double* after,
                        int ambient) {
  const ceres::Manifold* manifold = problem.GetManifold(block);
  Eigen::VectorXd d(manifold ? manifold->TangentSize() : ambient);
  if (manifold) {
    manifold->Minus(after, before, d.data());
  } else {
    for (int i = 0; i < ambient; ++i) d[i] = after[i] - before[i];
  }
  return d / kStep;
}

/// The similarity's tangent G of every parameter block the datum touches: the block's points
/// (3 × m) and its images' rotation and translation blocks (tangent size × m).
struct Tangents {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  int m = 7;
  std::map<const double*, Eigen::MatrixXd> g;
};

Tangents SimilarityTangents(const JointState& s, const std::vector<Point3DId>& points) {
  const ceres::Problem& problem = s.builder->problem();
  Tangents t;
  t.m = s.project->scale_bars.empty() ? 7 : 6;
  for (const Point3DId id : points) t.centroid += s.scene.Point(id);
  t.centroid /= static_cast<double>(points.size());
  for (const Point3DId id : points) {
    Eigen::MatrixXd g(3, t.m);
    for (int j = 0; j < t.m; ++j) g.col(j) = PointMotion(s.scene.Point(id), t.centroid, j);
    t.g[s.scene.Point(id).data()] = g;
  }
  for (const auto& [name, id] : s.measured->image_of) {
    const Rigid3d& pose = s.scene.Image(id).cam_from_world;
    Eigen::MatrixXd gq(3, t.m), gt(3, t.m);  // translation in its 3 ambient coordinates (ExtendedColumns)
    for (int j = 0; j < t.m; ++j) {
      const Rigid3d moved = MovedPose(pose, t.centroid, j, kStep);
      gq.col(j) = Tangent(problem, pose.rotation.coeffs().data(), pose.rotation.coeffs().data(),
                          moved.rotation.coeffs().data(), 4);
      gt.col(j) = (moved.translation - pose.translation) / kStep;
    }
    t.g[pose.rotation.coeffs().data()] = gq;
    t.g[pose.translation.data()] = gt;
  }
  return t;
}

/// An eliminated point's rows folded into L = −V⁻¹Wᵀ (on the kept columns `cols`) and
/// D = V⁻¹, from the whitened Jacobians of its residual blocks (no loss, as the statistics).
struct EliminatedPoint {
  std::vector<int> cols;
  Eigen::MatrixXd l;  // 3 × cols
  Eigen::Matrix3d d = Eigen::Matrix3d::Zero();
};

EliminatedPoint Eliminate(const ceres::Problem& problem, const stats::NetworkStatistics& st, const double* point,
                          const std::vector<ceres::ResidualBlockId>& blocks) {
  Eigen::Matrix3d v = Eigen::Matrix3d::Zero();
  std::map<int, Eigen::RowVector3d> w_rows;  // kept column -> row of W
  for (const ceres::ResidualBlockId id : blocks) {
    std::vector<double*> params;
    problem.GetParameterBlocksForResidualBlock(id, &params);
    const int rows = problem.GetCostFunctionForResidualBlock(id)->num_residuals();
    std::vector<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac(params.size());
    std::vector<double*> jac_ptr(params.size(), nullptr);
    for (size_t k = 0; k < params.size(); ++k) {
      if (problem.IsParameterBlockConstant(params[k])) continue;
      jac[k].resize(rows, problem.ParameterBlockTangentSize(params[k]));
      jac_ptr[k] = jac[k].data();
    }
    std::vector<double> residuals(rows);
    double cost = 0.0;
    problem.EvaluateResidualBlock(id, false, &cost, residuals.data(), jac_ptr.data());
    Eigen::MatrixXd jp;
    for (size_t k = 0; k < params.size(); ++k) {
      if (params[k] == point) jp = jac[k];
    }
    v += jp.transpose() * jp;
    for (size_t k = 0; k < params.size(); ++k) {
      const auto col = st.column.find(params[k]);
      if (!jac_ptr[k] || params[k] == point || col == st.column.end()) continue;
      const Eigen::MatrixXd wk = jac[k].transpose() * jp;  // tangent × 3
      for (int i = 0; i < wk.rows(); ++i) {
        auto [it, inserted] = w_rows.emplace(col->second + i, Eigen::RowVector3d::Zero());
        it->second += wk.row(i);
      }
    }
  }
  EliminatedPoint e;
  e.d = v.inverse();
  e.l.resize(3, w_rows.size());
  for (const auto& [col, row] : w_rows) {
    e.l.col(static_cast<Eigen::Index>(e.cols.size())) = -e.d * row.transpose();
    e.cols.push_back(col);
  }
  return e;
}

/// The residual blocks of each of `points` (blocks touching one of them).
std::map<const double*, std::vector<ceres::ResidualBlockId>> BlocksByPoint(const ceres::Problem& problem,
                                                                           const std::set<const double*>& points) {
  std::map<const double*, std::vector<ceres::ResidualBlockId>> by_point;
  std::vector<ceres::ResidualBlockId> all;
  problem.GetResidualBlocks(&all);
  std::vector<double*> params;
  for (const ceres::ResidualBlockId id : all) {
    problem.GetParameterBlocksForResidualBlock(id, &params);
    for (const double* p : params) {
      if (points.count(p)) by_point[p].push_back(id);
    }
  }
  return by_point;
}

/// Sums of the S-transformation over the datum points (file comment): H, F, M, F C, Q.
struct Sums {
  Eigen::MatrixXd h, f, m, fc, q, h_inv;
};

/// Σ_S of one set of rows with minimal-datum covariance `sigma`, B (m × rows) and G.
Eigen::MatrixXd Transformed(const Eigen::MatrixXd& sigma, const Eigen::MatrixXd& b, const Eigen::MatrixXd& g, const Sums& u) {
  const Eigen::MatrixXd gab = g * u.h_inv * b;
  return sigma - gab - gab.transpose() + g * u.h_inv * u.q * u.h_inv * g.transpose();
}

/// The columns of the transformed cofactor: the statistics' kept columns, with a pose
/// translation that the minimal datum restricts to a sphere (its 2-D tangent, ProblemBuilder's
/// kTwoPoses) in its 3 coordinates, and the first image's pose (held in the minimal datum) added.
/// x_new = E x_old; C_new = E C Eᵀ; a row L over the old columns becomes L E⁺.
struct ExtendedColumns {
  Eigen::MatrixXd e, e_plus;  // N_new × N_old and its left inverse
  std::map<const double*, int> column;
  std::vector<double*> blocks;
};

ExtendedColumns Extend(const JointState& s, const stats::NetworkStatistics& st) {
  const ceres::Problem& problem = s.builder->problem();
  std::set<const double*> translations;
  for (const auto& [name, id] : s.measured->image_of) translations.insert(s.scene.Image(id).cam_from_world.translation.data());
  const Rigid3d& first = s.scene.Image(s.measured->image_of.at(s.measured->image_names.front())).cam_from_world;
  std::vector<double*> blocks = st.blocks;
  for (double* b : {const_cast<double*>(first.rotation.coeffs().data()), const_cast<double*>(first.translation.data())}) {
    if (!st.column.count(b)) blocks.push_back(b);
  }
  const int n_old = static_cast<int>(st.cofactor.rows());
  ExtendedColumns x;
  std::vector<std::pair<int, Eigen::MatrixXd>> maps;  // per block: old column (-1: none), new × old
  int n_new = 0;
  for (double* b : blocks) {
    const int tangent = problem.ParameterBlockTangentSize(b);
    const auto old = st.column.find(b);
    Eigen::MatrixXd m = Eigen::MatrixXd::Identity(tangent, tangent);
    if (translations.count(b) && tangent < 3 && problem.GetManifold(b)) {
      Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor> plus(3, tangent);
      problem.GetManifold(b)->PlusJacobian(b, plus.data());
      m = plus;
    }
    x.column[b] = n_new;
    x.blocks.push_back(b);
    maps.emplace_back(old == st.column.end() ? -1 : old->second, m);
    n_new += static_cast<int>(m.rows());
  }
  x.e = Eigen::MatrixXd::Zero(n_new, n_old);
  for (size_t k = 0; k < blocks.size(); ++k) {
    if (maps[k].first >= 0) x.e.block(x.column.at(blocks[k]), maps[k].first, maps[k].second.rows(), maps[k].second.cols()) = maps[k].second;
  }
  x.e_plus = (x.e.transpose() * x.e).ldlt().solve(x.e.transpose());
  return x;
}

/// An eliminated point's L from the old columns to the new ones (L E⁺, E⁺ row by row).
void Remap(const ExtendedColumns& x, EliminatedPoint* p) {
  std::map<int, Eigen::Vector3d> columns;
  for (size_t k = 0; k < p->cols.size(); ++k) {
    for (int j = 0; j < x.e_plus.cols(); ++j) {
      const double v = x.e_plus(p->cols[k], j);
      if (v != 0.0) {
        auto [it, inserted] = columns.emplace(j, Eigen::Vector3d::Zero());
        it->second += v * p->l.col(static_cast<Eigen::Index>(k));
      }
    }
  }
  p->cols.clear();
  p->l.resize(3, static_cast<Eigen::Index>(columns.size()));
  for (const auto& [j, v] : columns) {
    p->l.col(static_cast<Eigen::Index>(p->cols.size())) = v;
    p->cols.push_back(j);
  }
}

}  // namespace

void MovePhotoMeasurementsToDatum(JointState* s) {
  if (!s->measured || !s->measured->gauge_needed) return;
  MeasurementBlock& b = *s->measured;
  const std::vector<Point3DId> points = DatumPoints(*s);
  Eigen::Matrix3Xd solved(3, points.size()), approximate(3, points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    solved.col(i) = s->scene.Point(points[i]);
    approximate.col(i) = b.initial.points.at(b.point_name.at(points[i]));
  }
  const Eigen::Matrix4d t = Eigen::umeyama(solved, approximate, s->project->scale_bars.empty());
  const Eigen::Matrix3d a = t.topLeftCorner<3, 3>();  // scale · rotation
  const double scale = a.col(0).norm();
  const Eigen::Matrix3d rotation = a / scale;
  const Eigen::Vector3d shift = t.topRightCorner<3, 1>();
  for (const auto& [name, id] : b.point_of) {
    Eigen::Vector3d& x = s->scene.Point(id);
    x = a * x + shift;
  }
  for (const auto& [name, id] : b.image_of) {
    Rigid3d& pose = s->scene.Image(id).cam_from_world;
    const Eigen::Quaterniond r = (pose.rotation * Eigen::Quaterniond(rotation.transpose())).normalized();
    pose.translation = scale * pose.translation - (r * shift);
    pose.rotation = r;
  }
}

void TransformPhotoMeasurementCovariance(JointState* s, stats::NetworkStatistics* st) {
  if (!s->measured || !st->cofactor.rows()) return;
  MeasurementBlock& b = *s->measured;
  const ceres::Problem& problem = s->builder->problem();
  const std::vector<Point3DId> points = DatumPoints(*s);
  std::set<const double*> eliminated;
  for (const Point3DId id : points) {
    if (!st->column.count(s->scene.Point(id).data())) eliminated.insert(s->scene.Point(id).data());
  }
  const auto blocks = BlocksByPoint(problem, eliminated);
  Eigen::MatrixXd c = st->cofactor.Dense();
  const double scale2 = st->scale_used * st->scale_used;
  std::map<Point3DId, EliminatedPoint> folded;
  for (const Point3DId id : points) {
    const double* x = s->scene.Point(id).data();
    if (eliminated.count(x) && blocks.count(x)) folded[id] = Eliminate(problem, *st, x, blocks.at(x));
  }
  b.point_covariance.clear();
  b.point_gain.clear();
  if (!b.gauge_needed) {
    for (const auto& [id, e] : folded) b.point_covariance[id] = scale2 * (e.d + e.l * c(e.cols, e.cols) * e.l.transpose());
    for (const auto& [id, e] : folded) b.point_gain[id] = {e.cols, e.l};
    return;
  }
  const ExtendedColumns extended = Extend(*s, *st);
  c = extended.e * c * extended.e.transpose();
  for (auto& [id, e] : folded) Remap(extended, &e);
  st->column = extended.column;
  st->blocks = extended.blocks;
  const Tangents tg = SimilarityTangents(*s, points);
  const int n = static_cast<int>(c.rows()), m = tg.m;
  Sums u{Eigen::MatrixXd::Zero(m, m), Eigen::MatrixXd::Zero(m, n), Eigen::MatrixXd::Zero(m, m), {}, {}, {}};
  for (const Point3DId id : points) {
    const double* x = s->scene.Point(id).data();
    const Eigen::MatrixXd& g = tg.g.at(x);
    u.h += g.transpose() * g;
    const auto e = folded.find(id);
    if (e == folded.end()) {
      u.f.middleCols(st->column.at(x), 3) += g.transpose();
      continue;
    }
    for (size_t k = 0; k < e->second.cols.size(); ++k) u.f.col(e->second.cols[k]) += g.transpose() * e->second.l.col(k);
    u.m += g.transpose() * e->second.d * g;
  }
  u.fc = u.f * c;
  u.q = u.fc * u.f.transpose() + u.m;
  u.h_inv = u.h.inverse();
  // The kept blocks (poses, intrinsics, kept points): B_K = F C; G zero on the intrinsics.
  Eigen::MatrixXd gk = Eigen::MatrixXd::Zero(n, m);
  for (const auto& [block, column] : st->column) {
    const auto g = tg.g.find(block);
    if (g != tg.g.end()) gk.middleRows(column, g->second.rows()) = g->second;
  }
  const Eigen::MatrixXd c_s = Transformed(c, u.fc, gk, u);
  double trace_minimal = 0.0, trace = 0.0;
  for (const Point3DId id : points) {
    const double* x = s->scene.Point(id).data();
    const Eigen::MatrixXd& g = tg.g.at(x);
    const auto e = folded.find(id);
    if (e == folded.end()) {
      const int col = st->column.at(x);
      trace_minimal += c.block(col, col, 3, 3).trace();
      trace += c_s.block(col, col, 3, 3).trace();
      continue;
    }
    const EliminatedPoint& p = e->second;
    const Eigen::MatrixXd sigma = p.d + p.l * c(p.cols, p.cols) * p.l.transpose();
    const Eigen::MatrixXd bj = u.fc(Eigen::all, p.cols) * p.l.transpose() + g.transpose() * p.d;
    const Eigen::Matrix3d sigma_s = Transformed(sigma, bj, g, u);
    b.point_covariance[id] = scale2 * sigma_s;
    trace_minimal += sigma.trace();
    trace += sigma_s.trace();
  }
  st->cofactor = stats::Cofactor(c_s);
  std::ostringstream figures;
  figures << std::setprecision(6) << "; trace of the points' covariance " << scale2 * trace << " m² (minimal datum "
          << scale2 * trace_minimal << " m²)";
  b.datum = b.datum.substr(0, b.datum.find("; trace")) + figures.str();
}

}  // namespace mmba::adjust::internal
