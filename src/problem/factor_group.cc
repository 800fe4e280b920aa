#include "mmba/problem/factor_group.h"

#include <cmath>
#include <sstream>

namespace mmba {

bool ParseLossType(const std::string& name, LossType* type) {
  if (name == "none" || name == "trivial") *type = LossType::kNone;
  else if (name == "huber") *type = LossType::kHuber;
  else if (name == "cauchy") *type = LossType::kCauchy;
  else if (name == "soft_l1") *type = LossType::kSoftL1;
  else return false;
  return true;
}

std::string LossTypeName(LossType type) {
  switch (type) {
    case LossType::kNone: return "none";
    case LossType::kHuber: return "huber";
    case LossType::kCauchy: return "cauchy";
    case LossType::kSoftL1: return "soft_l1";
  }
  return "?";
}

bool LossOptions::Check(std::string* error) const {
  if (!(scale > 0.0) || !std::isfinite(scale)) {
    *error = "loss scale: found " + std::to_string(scale) + ", expected a finite number > 0";
    return false;
  }
  return true;
}

ceres::LossFunction* LossOptions::Create() const {
  switch (type) {
    case LossType::kNone: return nullptr;
    case LossType::kHuber: return new ceres::HuberLoss(scale);
    case LossType::kCauchy: return new ceres::CauchyLoss(scale);
    case LossType::kSoftL1: return new ceres::SoftLOneLoss(scale);
  }
  return nullptr;
}

std::string LossOptions::ToString() const {
  if (type == LossType::kNone) return "none";
  std::ostringstream s;
  s << LossTypeName(type) << " (scale " << scale << " sigma)";
  return s.str();
}

FactorGroup::FactorGroup(std::string name, std::string unit, LossOptions loss)
    : name_(std::move(name)), unit_(std::move(unit)), loss_(loss) {}

ceres::ResidualBlockId FactorGroup::AddBlock(ceres::Problem& problem,
                                             ceres::CostFunction* cost,
                                             const std::vector<double*>& parameter_blocks,
                                             double sigma, size_t observation_index) {
  if (problem_ != &problem) {
    problem_ = &problem;
    shared_loss_ = loss_.Create();  // one loss shared by the group; the problem owns it
  }
  const ceres::ResidualBlockId id =
      problem.AddResidualBlock(cost, shared_loss_, parameter_blocks);
  blocks_.push_back(id);
  sigmas_.push_back(sigma);
  observation_index_.push_back(observation_index);
  return id;
}

GroupEvaluation FactorGroup::Evaluate() const {
  GroupEvaluation evaluation;
  evaluation.name = name_;
  evaluation.unit = unit_;
  evaluation.num_skipped = num_skipped_;
  evaluation.outlier_threshold = outlier_threshold_;
  evaluation.num_observations = blocks_.size();
  evaluation.observations.reserve(blocks_.size());
  double sum_sq_units = 0.0;
  double sum_sq_whitened = 0.0;
  std::vector<double> residuals;
  for (size_t i = 0; i < blocks_.size(); ++i) {
    const int size = problem_->GetCostFunctionForResidualBlock(blocks_[i])->num_residuals();
    residuals.assign(size, 0.0);
    double cost = 0.0;
    problem_->EvaluateResidualBlock(blocks_[i], /*apply_loss_function=*/false, &cost,
                                    residuals.data(), nullptr);
    ObservationResidual obs;
    obs.whitened = residuals;
    double sq = 0.0;
    for (double r : residuals) sq += r * r;
    obs.norm_whitened = std::sqrt(sq);
    obs.norm_units = obs.norm_whitened * sigmas_[i];
    obs.outlier = obs.norm_whitened > outlier_threshold_;
    evaluation.num_outliers += obs.outlier ? 1 : 0;
    evaluation.num_residuals += size;
    sum_sq_whitened += sq;
    sum_sq_units += sq * sigmas_[i] * sigmas_[i];
    evaluation.observations.push_back(std::move(obs));
  }
  if (evaluation.num_observations > 0) {
    const double n = static_cast<double>(evaluation.num_observations);
    evaluation.rms_units = std::sqrt(sum_sq_units / n);
    evaluation.rms_whitened = std::sqrt(sum_sq_whitened / n);
    double sum_norm = 0.0;
    for (const ObservationResidual& obs : evaluation.observations) sum_norm += obs.norm_units;
    evaluation.mean_norm_units = sum_norm / n;
  }
  return evaluation;
}

}  // namespace mmba
