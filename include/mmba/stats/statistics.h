#pragma once

#include <functional>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <ceres/ceres.h>

#include "mmba/problem/factor_group.h"
#include "mmba/stats/cofactor.h"

namespace mmba::stats {

/// A factor group whose residual blocks are whitened with a full covariance C = L·Lᵀ
/// (correlated observations) implements this so that statistics report residuals in the
/// observations' own units: residual = L · whitened. Groups without it use σ·I.
class CorrelatedBlockSource {
 public:
  virtual ~CorrelatedBlockSource() = default;
  /// L of block `block` (lower triangular, size = the block's residual count).
  virtual Eigen::MatrixXd BlockSqrtCovariance(size_t block) const = 0;
};

/// One scalar of a parameter block taking part in the minimum-norm datum of a free network
/// (GNU Gama's "constrained" coordinates).
struct MinimumNormCoordinate {
  double* block = nullptr;
  int index = 0;
};

/// The network is singular (a datum defect not removed, or a parameter no observation
/// determines); the message names the parameters.
class DegenerateNetworkError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct StatisticsOptions {
  double confidence = 0.95;          ///< in (0, 1): χ² test and data-snooping level
  bool use_apriori_sigma0 = false;   ///< scale covariances by σ0 a-priori (1) instead of
                                     ///< the a-posteriori estimate (Gama's sigma-act)
  /// Coordinates in the minimum-norm datum; empty = the network must have no datum defect.
  std::vector<MinimumNormCoordinate> minimum_norm;
  double rank_tolerance = 1e-9;      ///< relative eigenvalue below which a direction is null
  int dense_limit = 2500;            ///< unknowns up to which the dense eigen path is used
  /// Covariance from ceres::Covariance (SPARSE_QR, SuiteSparse) over all pairs of free
  /// blocks instead of the explicit normal-matrix inverse; only for networks without datum
  /// defect (the minimum-norm datum needs the explicit path). Slower for large networks.
  bool use_ceres_covariance = false;
  /// Blocks eliminated by the Schur complement (the tie points of a bundle block, Triggs et
  /// al. 2000, Sec. 6.1): the normal matrix N = [U W; Wᵀ V] is reduced to S = U − W V⁻¹ Wᵀ,
  /// `cofactor` is S⁻¹ over the other blocks only (eliminated blocks are not in `blocks`),
  /// and each row's h_ii = z S⁻¹ zᵀ + b V_p⁻¹ bᵀ with z = a − b V_p⁻¹ W_pᵀ (a, b: the row's
  /// Jacobian on the kept and on its eliminated block). Every residual block may touch at
  /// most one eliminated block; no datum defect (minimum_norm must be empty).
  std::set<const double*> eliminate;
  /// Names a parameter scalar in error messages ("y of point 12"); optional.
  std::function<std::string(const double* block, int index)> describe;

  bool Check(std::string* error) const;
};

/// Statistics of one scalar residual (a row of a residual block).
struct RowStatistic {
  size_t group = 0;          ///< index into the groups given
  size_t block = 0;          ///< block index inside the group
  int row = 0;               ///< row inside the block
  double whitened = 0.0;     ///< whitened residual (prediction − observation)/σ (or L⁻¹·)
  double residual = 0.0;     ///< in the group's units (L·whitened)
  double sigma = 0.0;        ///< a-priori σ of the observation (sqrt C_ii)
  double redundancy = 0.0;   ///< r_i = 1 − h_ii (Förstner 1979; Σ r_i = dof)
  double studentized = 0.0;  ///< v_i / (s·σ_i·sqrt(r_i)), s = the σ0 used (Baarda w / Pope τ)
  double control = 0.0;      ///< Gama's obs control f = 100·|1 − sqrt(1 − r_i)| [%]
  bool critical = false;     ///< |studentized| > critical value
};

struct GroupStatistic {
  std::string name;
  size_t rows = 0;
  double sum_squares = 0.0;       ///< Σ whitened²
  double redundancy = 0.0;        ///< Σ r_i
  double variance_component = 0.0;  ///< σ̂²_k = Σ e² / Σ r_i (Förstner 1979), 0 if Σr = 0
};

/// Everything statistics says about an adjusted network. Covariances are in SI parameter
/// units: `cofactor` is (JᵀJ)⁻¹ (or the minimum-norm g-inverse) of the whitened problem,
/// i.e. the covariance for σ0 = 1; the reported covariance is scale_used² · cofactor.
struct NetworkStatistics {
  int num_equations = 0;
  int num_unknowns = 0;
  int defect = 0;
  int degrees_of_freedom = 0;
  double sum_squares = 0.0;      ///< Σ whitened² (= vᵀPv / σ0_apriori²)
  double sigma0_ratio = 0.0;     ///< a-posteriori / a-priori σ0 = sqrt(Σe²/dof) (0 if dof=0)
  double scale_used = 1.0;       ///< 1 (a-priori) or sigma0_ratio (a-posteriori)
  double confidence = 0.95;
  double chi2_lower = 0.0;       ///< bounds of sigma0_ratio at `confidence` (two-sided)
  double chi2_upper = 0.0;
  bool chi2_passed = false;      ///< dof > 0 and lower <= ratio <= upper
  double critical_value = 0.0;   ///< normal (a-priori) or Student t (a-posteriori) quantile
  int max_row = -1;              ///< row with the largest |studentized| (control >= 0.1 %)
  bool max_row_critical = false;
  std::vector<RowStatistic> rows;
  std::vector<GroupStatistic> groups;

  std::vector<double*> blocks;          ///< free parameter blocks, in column order
  std::map<const double*, int> column;  ///< first column of each block
  Cofactor cofactor;                    ///< n×n (whole, or its selected inverse)

  /// Covariance (scaled by scale_used²) of scalars (a, i) and (b, j); 0 when a block is
  /// not free (fixed).
  double Covariance(const double* a, int i, const double* b, int j) const;
  bool IsFree(const double* block) const { return column.count(block) > 0; }
  std::string BriefReport() const;
};

/// Computes the statistics at the current parameter values of `problem` (after a solve),
/// over the residual blocks of `groups` (which must be all the problem's blocks).
/// Throws DegenerateNetworkError when the normal matrix is singular beyond the minimum-norm
/// datum (names the parameters), std::invalid_argument on bad options.
NetworkStatistics ComputeStatistics(ceres::Problem& problem,
                                    const std::vector<const FactorGroup*>& groups,
                                    const StatisticsOptions& options);

/// Checks the rank of the problem at its current values: throws DegenerateNetworkError as
/// ComputeStatistics would, returns the defect (null-space dimension) otherwise.
int CheckDatum(ceres::Problem& problem, const StatisticsOptions& options);

/// Minimum-norm update: moves the free parameters along the null space so that the
/// minimum_norm coordinates have minimum change from `reference` (values of the same
/// scalars, in minimum_norm order). No-op without defect. Returns the defect.
int ApplyMinimumNorm(ceres::Problem& problem, const StatisticsOptions& options,
                     const std::vector<double>& reference);

/// Standard error ellipse of a 2×2 covariance (axes 1, 2): semi-axes a >= b and the angle
/// of a from axis 1 towards axis 2 in [0, π).
struct ErrorEllipse {
  double a = 0.0, b = 0.0, angle_rad = 0.0;
};
ErrorEllipse StandardEllipse(const Eigen::Matrix2d& covariance);
/// Semi-axes (descending) and their directions (columns) of a 3×3 covariance.
void StandardEllipsoid(const Eigen::Matrix3d& covariance, Eigen::Vector3d* semi_axes,
                       Eigen::Matrix3d* axes);

/// Quantiles: chi² (lower tail p, dof), Student t (upper tail p, dof), normal (upper tail p).
double ChiSquareQuantile(double p, int dof);
double StudentUpperQuantile(double upper_tail, int dof);
double NormalUpperQuantile(double upper_tail);

}  // namespace mmba::stats
