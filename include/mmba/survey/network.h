#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geodesy/geodesy.h"

namespace mmba::survey {

/// Role of one coordinate (xy pair or z) of a survey point (GNU Gama's point types).
enum class CoordStatus {
  kUnused,       ///< not part of the adjustment (no fix/adj given)
  kFixed,        ///< held at its given value
  kAdjusted,     ///< free unknown
  kConstrained,  ///< free unknown that takes part in the minimum-norm datum (free network)
  kRemoved,      ///< adjusted or constrained in the input, but the observations cannot
                 ///< determine it: left out of the adjustment with a warning (GNU Gama's
                 ///< "removed points"), its observations passive
};
const char* CoordStatusName(CoordStatus status);

/// The horizontal axes of the input frame: where +x and +y point, e.g. "ne" (Gama's
/// default: x north, y east), "sw", "en". World coordinates inside mmba are east, north,
/// up (DESIGN.md); the axes are applied only when reading and writing.
struct InputAxes {
  std::string code = "ne";
  Eigen::Matrix2d en_from_xy = (Eigen::Matrix2d() << 0, 1, 1, 0).finished();
  /// Parses one of ne, sw, es, wn, en, nw, se, ws; false otherwise.
  static bool Parse(const std::string& code, InputAxes* axes);
  Eigen::Vector2d EnFromXy(const Eigen::Vector2d& xy) const { return en_from_xy * xy; }
  Eigen::Vector2d XyFromEn(const Eigen::Vector2d& en) const {
    return en_from_xy.transpose() * en;
  }
};

/// A survey point with a string id. `coords` = (east, north, up) in metres in the world
/// (input plane) frame; the factor groups use `coords.data()` (xy block, 2 doubles) and
/// `coords.data() + 2` (z block, 1 double) as Ceres parameter blocks, so a SurveyNetwork
/// must not move its points after the problem is built.
struct SurveyPoint {
  std::string id;
  Eigen::Vector3d coords = Eigen::Vector3d::Zero();
  bool has_xy = false;  ///< horizontal position known (given or approximated)
  bool has_z = false;   ///< height known (given or approximated)
  bool given_xy = false;  ///< given in the input (not approximated)
  bool given_z = false;
  CoordStatus xy = CoordStatus::kUnused;
  CoordStatus z = CoordStatus::kUnused;
  int line = 0;  ///< input line of its definition
  Eigen::Vector3d approx = Eigen::Vector3d::Zero();  ///< approximate values before the solve

  double* xy_block() { return coords.data(); }
  double* z_block() { return coords.data() + 2; }
  bool xy_free() const { return xy == CoordStatus::kAdjusted || xy == CoordStatus::kConstrained; }
  bool z_free() const { return z == CoordStatus::kAdjusted || z == CoordStatus::kConstrained; }
};

/// Observation kinds of gama-local (all of them).
enum class ObsKind {
  kDirection,      ///< horizontal direction, clockwise, minus the set's orientation [rad]
  kAngle,          ///< horizontal angle bs -> fs, clockwise [rad]
  kDistance,       ///< horizontal distance [m]
  kSlopeDistance,  ///< slope distance between instrument and target [m]
  kZenithAngle,    ///< zenith angle [rad]
  kAzimuth,        ///< azimuth from north, clockwise [rad]
  kHeightDiff,     ///< levelled height difference z_to - z_from [m]
  kCoordX,         ///< observed coordinate x of the input frame [m]
  kCoordY,
  kCoordZ,
  kVectorX,        ///< coordinate difference x_to - x_from in the input frame [m]
  kVectorY,
  kVectorZ,
};
const char* ObsKindName(ObsKind kind);  ///< Gama's element name: direction, distance, ...
bool ObsKindIsAngle(ObsKind kind);

/// One scalar observation. Angles are stored clockwise in radians (right-handed input is
/// negated at the io boundary), lengths in metres, σ in the same units.
struct Observation {
  ObsKind kind = ObsKind::kDistance;
  std::string from;  ///< station (or the point of a coordinate observation)
  std::string to;    ///< target (angle: backsight)
  std::string fs;    ///< angle only: foresight
  double value = 0.0;
  double sigma = 0.0;       ///< a-priori standard deviation (diagonal of the cluster cov)
  double from_dh = 0.0;     ///< instrument height [m]
  double to_dh = 0.0;       ///< target (reflector) height [m]
  double fs_dh = 0.0;       ///< angle foresight target height [m]
  double dist_km = 0.0;     ///< levelling: section length [km] (information only)
  bool active = true;       ///< false when dropped (reason in `passive_reason`)
  std::string passive_reason;
  int line = 0;
};

/// A cluster of observations with one covariance matrix (Gama's <obs>, <height-differences>,
/// <coordinates>, <vectors>). Directions of an <obs> cluster share one orientation unknown.
struct Cluster {
  enum class Type { kStandpoint, kHeightDifferences, kCoordinates, kVectors };
  Type type = Type::kStandpoint;
  std::string station;  ///< kStandpoint only
  std::vector<Observation> observations;
  /// Covariance of the observations in SI units (rad², m²), full symmetric, when
  /// `correlated`; empty otherwise, the variances being the observations' σ². Only a
  /// correlated cluster costs n² memory (its whitening needs the whole matrix), so that a set
  /// or levelling line of many uncorrelated observations stays O(n). Read it through
  /// Covariance().
  Eigen::MatrixXd covariance;
  bool correlated = false;  ///< a <cov-mat> with off-diagonal band was given
  double orientation = 0.0;  ///< kStandpoint: orientation unknown [rad] (bearing − direction)
  bool has_orientation = false;  ///< the cluster has >= 2 active directions
  bool orientation_known = false;  ///< approximate value available
  int line = 0;

  /// Element (a, b) of the covariance: the matrix when it is held, σ_a² on the diagonal and
  /// 0 off it otherwise.
  double Covariance(size_t a, size_t b) const;
  /// Scales the σ of observation `i` by `factor` (row and column i of a held matrix).
  void ScaleObservationSigma(size_t i, double factor);
};

/// A survey network: points, observation clusters and Gama's adjustment parameters.
struct SurveyNetwork {
  std::string source;  ///< file name, for messages
  std::string description;
  std::vector<SurveyPoint> points;
  std::map<std::string, size_t> point_index;
  std::vector<Cluster> clusters;

  InputAxes axes;
  bool angles_left_handed = true;  ///< angles clockwise in the input (Gama's default)
  bool output_gons = true;         ///< angles written in gon (Gama `angles="400"`) or degrees
  double sigma0_apriori = 10.0;    ///< Gama's sigma-apr (in the units of its σ: mm, cc)
  double confidence = 0.95;        ///< conf-pr
  bool sigma_act_apriori = false;  ///< sigma-act="apriori"
  bool update_constrained = false; ///< update-constrained-coordinates
  double tol_abs_mm = 1000.0;      ///< tol-abs (information)

  /// Georeferenced network: coordinates are the local tangent plane (ENU) at `origin`
  /// (in the input axes), and every observation is predicted in its station's own local
  /// vertical with Earth curvature (and refraction `refraction_k` on zenith angles).
  /// Without an origin the input plane is used as GNU Gama does.
  bool geodetic = false;
  geodesy::Geodetic origin;
  double refraction_k = 0.0;

  SurveyPoint* Find(const std::string& id);
  const SurveyPoint* Find(const std::string& id) const;
  /// Adds a point or returns the existing one.
  SurveyPoint& GetOrAdd(const std::string& id, int line);
};

}  // namespace mmba::survey
