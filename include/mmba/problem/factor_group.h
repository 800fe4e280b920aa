#pragma once

#include <memory>
#include <string>
#include <vector>

#include <ceres/ceres.h>

#include "mmba/problem/scene.h"

namespace mmba {

/// Robust loss of a factor group. The loss acts on *whitened* residuals (divided by their
/// a-priori σ), so `scale` is in units of σ: a Huber scale of 2 means "quadratic up to 2σ".
/// For a group with σ = 1 px this is the same as pixels.
enum class LossType { kNone, kHuber, kCauchy, kSoftL1 };

struct LossOptions {
  LossType type = LossType::kNone;
  double scale = 1.0;  ///< > 0, in σ units (see above)

  /// Message names the field, value and constraint when invalid.
  bool Check(std::string* error) const;
  /// A new Ceres loss (nullptr for kNone); the problem takes ownership.
  ceres::LossFunction* Create() const;
  std::string ToString() const;
};

/// "none" | "huber" | "cauchy" | "soft_l1"; false when unknown.
bool ParseLossType(const std::string& name, LossType* type);
std::string LossTypeName(LossType type);

/// Residual of one observation after (or before) a solve.
struct ObservationResidual {
  std::vector<double> whitened;  ///< residual / σ, per component (no robust loss applied)
  double norm_whitened = 0.0;    ///< ‖residual / σ‖
  double norm_units = 0.0;       ///< ‖residual‖ in the group's unit (px, m, mgon, ...)
  bool outlier = false;          ///< norm_whitened > GroupEvaluation::outlier_threshold
};

/// What a group reports after evaluation: per observation, RMS, count, outliers.
struct GroupEvaluation {
  std::string name;
  std::string unit;                ///< unit of `rms_units` / `norm_units`
  size_t num_observations = 0;     ///< residual blocks in the problem
  size_t num_residuals = 0;        ///< scalar residuals
  size_t num_skipped = 0;          ///< observations filtered before the solve
  double rms_units = 0.0;          ///< sqrt(mean over observations of ‖r‖²), in `unit`
  double rms_whitened = 0.0;       ///< same on whitened residuals
  double mean_norm_units = 0.0;    ///< mean of ‖r‖ (COLMAP's "mean reprojection error")
  double outlier_threshold = 3.0;  ///< in σ units on ‖r/σ‖
  size_t num_outliers = 0;
  std::vector<ObservationResidual> observations;
};

/// What a group's observations are to the statistics of the adjustment.
enum class FactorRole {
  kMeasurement,  ///< observations: tested, snooped for blunders, re-weighted by variance components
  kPrior,        ///< a statement about parameters (a registration, a GNSS/INS trajectory, a nominal
                 ///< calibration, an MI pose): tested and snooped, its σ never re-weighted
  kConstraint,   ///< a modelling assumption or check observations: neither snooped nor re-weighted
};

/// A factor group: the unit every sensor implements. It adds its residual blocks, each with
/// its a-priori σ (residuals whitened) and the group's robust loss, to the one
/// `ceres::Problem`, and evaluates them afterwards.
///
/// A subclass implements AddResiduals() and calls AddBlock() for every observation it
/// keeps; observations it cannot use (a point behind a camera, a missing id) are counted
/// with Skip() and never silently dropped.
class FactorGroup {
 public:
  FactorGroup(std::string name, std::string unit, LossOptions loss);
  virtual ~FactorGroup() = default;
  FactorGroup(const FactorGroup&) = delete;
  FactorGroup& operator=(const FactorGroup&) = delete;

  const std::string& name() const { return name_; }
  const std::string& unit() const { return unit_; }
  const LossOptions& loss() const { return loss_; }
  /// kMeasurement unless set; the caller that adds the group states what it is.
  FactorRole role() const { return role_; }
  void set_role(FactorRole role) { role_ = role; }

  /// Adds every residual block to `problem`, parameter blocks taken from `scene`.
  virtual void AddResiduals(Scene& scene, ceres::Problem& problem) = 0;

  /// True when the group's observations tie the network to an external datum (control,
  /// GNSS, fixed stations); a free-network gauge is then not needed and not allowed.
  virtual bool FixesDatum() const { return false; }

  /// Evaluates every block at the current parameter values (no robust loss).
  GroupEvaluation Evaluate() const;

  /// The blocks in the order they were added, with their σ (for statistics).
  const std::vector<ceres::ResidualBlockId>& residual_blocks() const { return blocks_; }
  const std::vector<double>& block_sigmas() const { return sigmas_; }
  /// Index of the group's own observation each block came from.
  const std::vector<size_t>& block_observation_index() const { return observation_index_; }
  size_t num_skipped() const { return num_skipped_; }
  const ceres::Problem* problem() const { return problem_; }

  double outlier_threshold() const { return outlier_threshold_; }
  void set_outlier_threshold(double sigma_units) { outlier_threshold_ = sigma_units; }

 protected:
  /// Adds one block. `cost` must already return whitened residuals (residual / sigma);
  /// `sigma` converts them back to the group's unit for reports.
  ceres::ResidualBlockId AddBlock(ceres::Problem& problem, ceres::CostFunction* cost,
                                  const std::vector<double*>& parameter_blocks,
                                  double sigma, size_t observation_index);
  /// Counts an observation that could not be used.
  void Skip() { ++num_skipped_; }

 private:
  std::string name_;
  std::string unit_;
  LossOptions loss_;
  FactorRole role_ = FactorRole::kMeasurement;
  ceres::LossFunction* shared_loss_ = nullptr;  // owned by the problem
  ceres::Problem* problem_ = nullptr;
  std::vector<ceres::ResidualBlockId> blocks_;
  std::vector<double> sigmas_;
  std::vector<size_t> observation_index_;
  size_t num_skipped_ = 0;
  double outlier_threshold_ = 3.0;
};

}  // namespace mmba
