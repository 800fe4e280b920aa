#include "mmba/survey/network.h"

namespace mmba::survey {

const char* CoordStatusName(CoordStatus status) {
  switch (status) {
    case CoordStatus::kUnused: return "unused";
    case CoordStatus::kFixed: return "fixed";
    case CoordStatus::kAdjusted: return "adjusted";
    case CoordStatus::kConstrained: return "constrained";
    case CoordStatus::kRemoved: return "removed";
  }
  return "?";
}

bool InputAxes::Parse(const std::string& code, InputAxes* axes) {
  if (code.size() != 2) return false;
  auto unit = [](char c, Eigen::Vector2d* v) {
    switch (c) {
      case 'e': *v = Eigen::Vector2d(1, 0); return true;
      case 'w': *v = Eigen::Vector2d(-1, 0); return true;
      case 'n': *v = Eigen::Vector2d(0, 1); return true;
      case 's': *v = Eigen::Vector2d(0, -1); return true;
    }
    return false;
  };
  Eigen::Vector2d x, y;
  if (!unit(code[0], &x) || !unit(code[1], &y)) return false;
  if (std::abs(x.dot(y)) > 0.5) return false;  // e.g. "ew", "nn"
  axes->code = code;
  axes->en_from_xy.col(0) = x;
  axes->en_from_xy.col(1) = y;
  return true;
}

const char* ObsKindName(ObsKind kind) {
  switch (kind) {
    case ObsKind::kDirection: return "direction";
    case ObsKind::kAngle: return "angle";
    case ObsKind::kDistance: return "distance";
    case ObsKind::kSlopeDistance: return "slope-distance";
    case ObsKind::kZenithAngle: return "zenith-angle";
    case ObsKind::kAzimuth: return "azimuth";
    case ObsKind::kHeightDiff: return "height-diff";
    case ObsKind::kCoordX: return "coordinate-x";
    case ObsKind::kCoordY: return "coordinate-y";
    case ObsKind::kCoordZ: return "coordinate-z";
    case ObsKind::kVectorX: return "dx";
    case ObsKind::kVectorY: return "dy";
    case ObsKind::kVectorZ: return "dz";
  }
  return "?";
}

bool ObsKindIsAngle(ObsKind kind) {
  return kind == ObsKind::kDirection || kind == ObsKind::kAngle ||
         kind == ObsKind::kZenithAngle || kind == ObsKind::kAzimuth;
}

double Cluster::Covariance(size_t a, size_t b) const {
  if (covariance.size() > 0) return covariance(a, b);
  return a == b ? observations[a].sigma * observations[a].sigma : 0.0;
}

void Cluster::ScaleObservationSigma(size_t i, double factor) {
  observations[i].sigma *= factor;
  if (covariance.size() > 0) {
    covariance.row(i) *= factor;
    covariance.col(i) *= factor;
  }
}

SurveyPoint* SurveyNetwork::Find(const std::string& id) {
  const auto it = point_index.find(id);
  return it == point_index.end() ? nullptr : &points[it->second];
}

const SurveyPoint* SurveyNetwork::Find(const std::string& id) const {
  const auto it = point_index.find(id);
  return it == point_index.end() ? nullptr : &points[it->second];
}

SurveyPoint& SurveyNetwork::GetOrAdd(const std::string& id, int line) {
  if (SurveyPoint* p = Find(id)) return *p;
  point_index[id] = points.size();
  SurveyPoint p;
  p.id = id;
  p.line = line;
  points.push_back(p);
  return points.back();
}

}  // namespace mmba::survey
