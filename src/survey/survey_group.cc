#include "mmba/survey/survey_group.h"

#include <algorithm>
#include <map>

#include <Eigen/Cholesky>

#include "mmba/factors/survey_residual.h"

namespace mmba::survey {

namespace {

factors::SurveyRow::Kind RowKind(ObsKind kind) {
  switch (kind) {
    case ObsKind::kDirection: return factors::SurveyRow::kDirection;
    case ObsKind::kAngle: return factors::SurveyRow::kAngle;
    case ObsKind::kDistance: return factors::SurveyRow::kDistance;
    case ObsKind::kSlopeDistance: return factors::SurveyRow::kSlopeDistance;
    case ObsKind::kZenithAngle: return factors::SurveyRow::kZenithAngle;
    case ObsKind::kAzimuth: return factors::SurveyRow::kAzimuth;
    case ObsKind::kHeightDiff: return factors::SurveyRow::kHeightDiff;
    case ObsKind::kCoordX: return factors::SurveyRow::kCoordX;
    case ObsKind::kCoordY: return factors::SurveyRow::kCoordY;
    case ObsKind::kCoordZ: return factors::SurveyRow::kCoordZ;
    case ObsKind::kVectorX: return factors::SurveyRow::kVectorX;
    case ObsKind::kVectorY: return factors::SurveyRow::kVectorY;
    case ObsKind::kVectorZ: return factors::SurveyRow::kVectorZ;
  }
  return factors::SurveyRow::kDistance;
}

bool NeedsXy(ObsKind kind) {
  return kind != ObsKind::kHeightDiff && kind != ObsKind::kCoordZ && kind != ObsKind::kVectorZ;
}
bool NeedsZ(ObsKind kind) {
  return kind == ObsKind::kSlopeDistance || kind == ObsKind::kZenithAngle ||
         kind == ObsKind::kHeightDiff || kind == ObsKind::kCoordZ || kind == ObsKind::kVectorZ;
}

}  // namespace

ceres::CostFunction* CreateSurveyBlockCost(SurveyNetwork* network, const BlockSpec& spec,
                                           std::vector<double*>* parameter_blocks,
                                           Eigen::MatrixXd* sqrt_covariance) {
  Cluster& cluster = network->clusters[spec.cluster];
  std::vector<size_t> active;
  for (size_t i : spec.observations) {
    if (cluster.observations[i].active) active.push_back(i);
  }
  if (active.empty()) return nullptr;
  parameter_blocks->clear();
  std::vector<int> sizes;
  std::map<double*, int> index;
  auto param = [&](double* block, int size) {
    const auto it = index.find(block);
    if (it != index.end()) return it->second;
    const int i = static_cast<int>(parameter_blocks->size());
    index[block] = i;
    parameter_blocks->push_back(block);
    sizes.push_back(size);
    return i;
  };
  std::vector<factors::SurveyRow> rows;
  for (size_t i : active) {
    const Observation& o = cluster.observations[i];
    factors::SurveyRow row;
    row.kind = RowKind(o.kind);
    row.value = o.value;
    row.from_dh = o.from_dh;
    row.to_dh = o.to_dh;
    row.fs_dh = o.fs_dh;
    SurveyPoint* from = network->Find(o.from);
    SurveyPoint* to = o.to.empty() ? nullptr : network->Find(o.to);
    SurveyPoint* fs = o.fs.empty() ? nullptr : network->Find(o.fs);
    const bool is_coordinate = o.kind == ObsKind::kCoordX || o.kind == ObsKind::kCoordY ||
                               o.kind == ObsKind::kCoordZ || o.kind == ObsKind::kVectorX ||
                               o.kind == ObsKind::kVectorY || o.kind == ObsKind::kVectorZ;
    const bool geodetic = network->geodetic && !is_coordinate;
    if (NeedsXy(o.kind) || (geodetic && from->has_xy && (!to || to->has_xy))) {
      row.from_xy = param(from->xy_block(), 2);
      if (to) row.to_xy = param(to->xy_block(), 2);
      if (fs) row.fs_xy = param(fs->xy_block(), 2);
    }
    if (NeedsZ(o.kind) || geodetic) {
      // In a geodetic network the station's vertical tilts horizontal observations too.
      if (NeedsZ(o.kind) || from->has_z) row.from_z = param(from->z_block(), 1);
      if (to && (NeedsZ(o.kind) || to->has_z)) row.to_z = param(to->z_block(), 1);
      if (fs && fs->has_z) row.fs_z = param(fs->z_block(), 1);
    }
    if (geodetic) {
      const geodesy::LocalTangentPlane plane(network->origin);
      row.station_from_world = plane.StationEnuFromWorld(from->coords);
      const SurveyPoint* target = to ? to : from;
      const Eigen::Vector3d d = row.station_from_world * (target->coords - from->coords);
      const double latitude = plane.GeodeticFromEnu(from->coords).latitude_deg;
      row.curvature_radius_m = geodesy::NormalSectionRadius(latitude, std::atan2(d.x(), d.y()));
      row.refraction_k = network->refraction_k;
    }
    if (o.kind == ObsKind::kDirection) row.orientation = param(&cluster.orientation, 1);
    rows.push_back(row);
  }
  const int n = static_cast<int>(active.size());
  Eigen::MatrixXd cov(n, n);
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) cov(a, b) = cluster.Covariance(active[a], active[b]);
  }
  const Eigen::MatrixXd l = cov.llt().matrixL();
  *sqrt_covariance = l;
  const Eigen::MatrixXd l_inv =
      l.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd::Identity(n, n));
  return factors::SurveyBlockResidual::Create(std::move(rows), l_inv,
                                              network->axes.en_from_xy, sizes);
}

SurveyGroup::SurveyGroup(SurveyNetwork* network, std::string name, std::string unit,
                         std::vector<BlockSpec> specs, LossOptions loss)
    : FactorGroup(std::move(name), std::move(unit), loss),
      network_(network),
      specs_(std::move(specs)) {}

void SurveyGroup::AddResiduals(Scene& /*scene*/, ceres::Problem& problem) {
  added_specs_.clear();
  sqrt_covariances_.clear();
  for (size_t s = 0; s < specs_.size(); ++s) {
    std::vector<double*> blocks;
    Eigen::MatrixXd l;
    ceres::CostFunction* cost = CreateSurveyBlockCost(network_, specs_[s], &blocks, &l);
    if (cost == nullptr) {
      Skip();
      continue;
    }
    const double sigma = std::sqrt(l.diagonal().squaredNorm() / l.rows());
    AddBlock(problem, cost, blocks, sigma, s);
    BlockSpec added = specs_[s];
    const Cluster& cluster = network_->clusters[added.cluster];
    added.observations.erase(
        std::remove_if(added.observations.begin(), added.observations.end(),
                       [&](size_t i) { return !cluster.observations[i].active; }),
        added.observations.end());
    added_specs_.push_back(added);
    sqrt_covariances_.push_back(l);
  }
}

bool SurveyGroup::FixesDatum() const {
  for (const SurveyPoint& p : network_->points) {
    if (p.xy == CoordStatus::kFixed || p.z == CoordStatus::kFixed ||
        p.xy == CoordStatus::kConstrained || p.z == CoordStatus::kConstrained) {
      return true;
    }
  }
  return false;
}

Eigen::MatrixXd SurveyGroup::BlockSqrtCovariance(size_t block) const {
  return sqrt_covariances_.at(block);
}

std::vector<std::unique_ptr<SurveyGroup>> MakeSurveyGroups(SurveyNetwork* network,
                                                           LossOptions loss) {
  struct Pending {
    std::string unit;
    std::vector<BlockSpec> specs;
  };
  std::vector<std::string> order;
  std::map<std::string, Pending> groups;
  auto add = [&](const std::string& name, const std::string& unit, BlockSpec spec) {
    if (!groups.count(name)) order.push_back(name);
    Pending& p = groups[name];
    p.unit = unit;
    p.specs.push_back(std::move(spec));
  };
  for (size_t c = 0; c < network->clusters.size(); ++c) {
    const Cluster& cluster = network->clusters[c];
    if (cluster.correlated) {
      BlockSpec spec;
      spec.cluster = c;
      for (size_t i = 0; i < cluster.observations.size(); ++i) spec.observations.push_back(i);
      switch (cluster.type) {
        case Cluster::Type::kStandpoint: add("correlated sets", "whitened", spec); break;
        case Cluster::Type::kHeightDifferences: add("height differences", "m", spec); break;
        case Cluster::Type::kCoordinates: add("coordinates", "m", spec); break;
        case Cluster::Type::kVectors: add("vectors", "m", spec); break;
      }
      continue;
    }
    for (size_t i = 0; i < cluster.observations.size(); ++i) {
      const ObsKind kind = cluster.observations[i].kind;
      std::string name;
      switch (kind) {
        case ObsKind::kDirection: name = "directions"; break;
        case ObsKind::kAngle: name = "angles"; break;
        case ObsKind::kDistance: name = "distances"; break;
        case ObsKind::kSlopeDistance: name = "slope distances"; break;
        case ObsKind::kZenithAngle: name = "zenith angles"; break;
        case ObsKind::kAzimuth: name = "azimuths"; break;
        case ObsKind::kHeightDiff: name = "height differences"; break;
        case ObsKind::kCoordX:
        case ObsKind::kCoordY:
        case ObsKind::kCoordZ: name = "coordinates"; break;
        case ObsKind::kVectorX:
        case ObsKind::kVectorY:
        case ObsKind::kVectorZ: name = "vectors"; break;
      }
      add(name, ObsKindIsAngle(kind) ? "rad" : "m", BlockSpec{c, {i}});
    }
  }
  std::vector<std::unique_ptr<SurveyGroup>> out;
  for (const std::string& name : order) {
    out.push_back(std::make_unique<SurveyGroup>(network, name, groups[name].unit,
                                                std::move(groups[name].specs), loss));
  }
  return out;
}


void SetSurveyParameterStates(SurveyNetwork* network, ceres::Problem& problem) {
  for (SurveyPoint& p : network->points) {
    if (problem.HasParameterBlock(p.xy_block()) && !p.xy_free()) {
      problem.SetParameterBlockConstant(p.xy_block());
    }
    if (problem.HasParameterBlock(p.z_block()) && !p.z_free()) {
      problem.SetParameterBlockConstant(p.z_block());
    }
  }
  for (Cluster& c : network->clusters) {
    if (problem.HasParameterBlock(&c.orientation) && !c.has_orientation) {
      problem.SetParameterBlockConstant(&c.orientation);
    }
  }
}

}  // namespace mmba::survey
