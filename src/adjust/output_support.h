// Helpers of the adjustment's output files shared by the sensor units (blocks/*.cc) and the
// common report (outputs.cc, truth.cc): JSON vectors, covariances of derived quantities,
// geodetic columns, the poses.csv row. Private to mmba_adjust.
#pragma once

#include <cmath>
#include <filesystem>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <ceres/problem.h>
#include <nlohmann/json.hpp>

#include "mmba/geodesy/crs_frame.h"
#include "mmba/geodesy/geodesy.h"
#include "mmba/geometry/rigid3d.h"
#include "mmba/stats/statistics.h"

namespace mmba::adjust::internal {

/// Degrees per radian.
constexpr double kDeg = 180.0 / M_PI;

/// [x, y, z] as a JSON array.
nlohmann::json Vec(const Eigen::Vector3d& v);
/// `v`, or 0 when it is not finite (JSON has no NaN).
inline double Num(double v) { return std::isfinite(v) ? v : 0.0; }

/// Ceres' EigenQuaternionManifold turns a rotation by twice its tangent vector: R ⊞ δ =
/// Exp(2δ)·R (the quaternion [cos|δ|, sin|δ| δ/|δ|]; Ceres' manifold tests say so). The
/// rotation vector's covariance is therefore 4 C_δ; kRotationPerTangent is that factor 2.
constexpr double kRotationPerTangent = 2.0;

/// Covariance of a camera centre c = −Rᵀt from the pose blocks' covariance (R ⊞ δ =
/// Exp(2δ)·R, so ∂c/∂δ = −2Rᵀ[t]×, ∂c/∂t = −Rᵀ).
Eigen::Matrix3d CentreCovariance(const stats::NetworkStatistics& st, const Rigid3d& cam_from_world);
/// σ of each ambient parameter of `block` (its covariance in the tangent space mapped through
/// the manifold's Plus Jacobian: a SubsetManifold's constant entries get 0).
std::vector<double> ParameterSigmas(const stats::NetworkStatistics& st, const ceres::Problem& problem,
                                    const double* block);
/// Covariance of a 3-vector parameter block.
Eigen::Matrix3d PointCovariance3(const stats::NetworkStatistics& st, const double* p);
/// Covariance of (rotation vector, translation) of the composed pose a·b (e.g. cam_from_lidar =
/// cam_from_rig · rig_from_lidar) from the blocks' joint covariance, by numerical first-order
/// propagation (rotation perturbations as on Ceres' quaternion manifold: Exp(2δ)·R).
Eigen::Matrix<double, 6, 6> ComposedPoseCovariance(const stats::NetworkStatistics& st, const Rigid3d& a,
                                                   const Rigid3d& b);
/// Rotation error (deg) and translation error (m) of an estimated pose against the truth.
std::pair<double, double> PoseError(const Rigid3d& estimate, const Rigid3d& truth);
/// {qvec_wxyz: [...], tvec: [...]} (10 significant digits), as the YAML inputs write a pose.
std::string YamlPose(const Rigid3d& p);
/// The horizontal standard error ellipse of an ENU covariance: a, b (m), azimuth from north.
nlohmann::json Ellipse(const Eigen::Matrix3d& enu);
/// The CSV columns latitude_deg,longitude_deg,height_m,utm_zone,utm_easting_m,utm_northing_m.
std::string Geo(const geodesy::LocalTangentPlane& plane, const Eigen::Vector3d& enu);
/// The CSV columns of the project CRS's coordinates, named by its EPSG code so that a GIS picks
/// them and their CRS from the header: ",easting_epsg25832_m,northing_epsg25832_m,
/// height_epsg25832_m" (a compound code "epsg25832_7837"; a geographic CRS "longitude_…_deg,
/// latitude_…_deg"; a CRS without a code "crs" in place of "epsgNNNN", its WKT in report.json).
std::string CrsColumns(const geodesy::Crs& crs);
/// The values of CrsColumns at a world point (",e,n,h", 4 decimals; 10 for degrees).
std::string CrsValues(const geodesy::CrsFrame& frame, const Eigen::Vector3d& point_in_world);
/// report.json's `crs` block (definition, identifier, epsg, name, wkt, axes, height_kind,
/// geoid_grid, columns).
nlohmann::json CrsJson(const geodesy::Crs& crs);
/// Writes `text` to `path` (binary); throws std::runtime_error when it cannot.
void WriteText(const std::filesystem::path& path, const std::string& text);

/// One row of poses.csv: name, sensor, centre (ENU), q = cam_from_world (w, x, y, z), the
/// geodetic columns, σ of the centre, the position and rotation corrections.
void AppendPoseRow(std::ostream& poses, const std::string& name, const std::string& sensor, const Eigen::Vector3d& centre,
                   const Eigen::Quaterniond& q, const geodesy::LocalTangentPlane& plane, const Eigen::Vector3d& sigma,
                   double d_position_m, double d_rotation_deg);

}  // namespace mmba::adjust::internal
