#pragma once

#include <memory>
#include <string>
#include <vector>

#include <ceres/ceres.h>

#include "mmba/problem/factor_group.h"
#include "mmba/stats/statistics.h"
#include "mmba/survey/network.h"

namespace mmba::survey {

/// Which observations of which cluster form one residual block: one observation when the
/// cluster is uncorrelated, the cluster's active observations when it has a <cov-mat>.
struct BlockSpec {
  size_t cluster = 0;
  std::vector<size_t> observations;
};

/// Builds the whitened cost function of a block and its parameter blocks (point xy/z blocks
/// and the orientation of a direction set, from `network`). Returns nullptr when the block
/// has no active observation.
ceres::CostFunction* CreateSurveyBlockCost(SurveyNetwork* network, const BlockSpec& spec,
                                           std::vector<double*>* parameter_blocks,
                                           Eigen::MatrixXd* sqrt_covariance);

/// Survey observations as a factor group of the one Ceres problem: total-station
/// directions (one orientation unknown per set), angles, zenith angles, slope and
/// horizontal distances, azimuths, levelled height differences, coordinate observations
/// with covariance and GNSS vectors with covariance. Parameters live in the
/// SurveyNetwork (taken by pointer; it must outlive the problem). Fixed coordinates are
/// set constant by `SetSurveyParameterStates`, not here.
class SurveyGroup : public FactorGroup, public stats::CorrelatedBlockSource {
 public:
  SurveyGroup(SurveyNetwork* network, std::string name, std::string unit,
              std::vector<BlockSpec> specs, LossOptions loss = LossOptions());

  void AddResiduals(Scene& scene, ceres::Problem& problem) override;
  /// True when the network has fixed or constrained coordinates (the datum is then given
  /// by the network itself, with a minimum-norm regularisation for constrained points).
  bool FixesDatum() const override;
  Eigen::MatrixXd BlockSqrtCovariance(size_t block) const override;

  /// The spec of each block added (same order as residual_blocks()).
  const std::vector<BlockSpec>& added_specs() const { return added_specs_; }

 private:
  SurveyNetwork* network_;
  std::vector<BlockSpec> specs_;
  std::vector<BlockSpec> added_specs_;
  std::vector<Eigen::MatrixXd> sqrt_covariances_;
};

/// Splits the network's active observations into groups by kind (directions, angles,
/// distances, slope distances, zenith angles, azimuths, height differences, coordinates,
/// vectors; correlated <obs> sets in their own group), so that variance components are
/// estimated per kind.
std::vector<std::unique_ptr<SurveyGroup>> MakeSurveyGroups(SurveyNetwork* network,
                                                           LossOptions loss = LossOptions());

/// Holds fixed coordinates (and unused ones) constant in `problem`.
void SetSurveyParameterStates(SurveyNetwork* network, ceres::Problem& problem);

}  // namespace mmba::survey
