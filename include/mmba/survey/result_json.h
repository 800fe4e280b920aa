#pragma once

// adjusted.json of `mmba survey` (docs/commands/survey.md): the adjusted network with its
// statistics, in the input's axes and angle unit.

#include <string>

#include <nlohmann/json.hpp>

#include "mmba/geodesy/crs_frame.h"
#include "mmba/survey/adjust.h"
#include "mmba/survey/network.h"

namespace mmba::survey {

/// The adjusted network `net` (as AdjustNetwork left it) with the result `adj`: `input` (the
/// file name as given), frame, σ0 a-priori/a-posteriori, dimensions, χ² test, datum,
/// iterations and removed observations; the used points (coordinates in the input axes,
/// status, σ, standard and confidence ellipses with the major axis angle from +x towards +y in
/// the input unit, WGS84 and UTM coordinates when georeferenced, the standard ellipsoid's
/// axes); the stations' orientations; the variance components per group. Holds no build or
/// time fields.
///
/// With `crs` (the network was given in that CRS, NetworkFromCrs): x, y, z are the CRS's
/// coordinates (x, y in the input axes, z the CRS's height), each point also has `local`
/// (east, north, up in the tangent plane the network was adjusted in), latitude_deg,
/// longitude_deg, ellipsoidal_height_m (on the CRS's datum) and `grid` (point_scale,
/// elevation_factor, combined_scale, convergence_deg: crs_frame.h); σ and ellipses stay in the
/// tangent plane (true north; grid north is `convergence_deg` east of it); the top level has
/// `crs` (CrsToJson) and `origin`.
nlohmann::json ResultToJson(const std::string& input, const SurveyNetwork& net,
                            const SurveyAdjustment& adj,
                            const geodesy::CrsFrame* crs = nullptr);

/// The `crs` block of a JSON output: definition, identifier ("EPSG:25832", "" when PROJ names
/// no authority code), epsg (the integer code, null for none or a compound h+v code), name,
/// wkt (WKT2:2019), axes, height_kind (ellipsoidal, orthometric, as given), geoid_grid (file
/// name or null).
nlohmann::json CrsToJson(const geodesy::Crs& crs);

/// report.md's section of a network given in a CRS: the CRS (name, code, height kind), the
/// tangent plane's origin, and per point the CRS coordinates, latitude, longitude, ellipsoidal
/// height and the combined grid scale.
std::string CrsPointsMarkdown(const SurveyNetwork& net, const geodesy::CrsFrame& frame);

/// A network whose coordinates are in the CRS of `frame` (x, y in the file's axes = easting,
/// northing or longitude, latitude; z the CRS's height) moved into the tangent plane of
/// `frame` through PROJ, and made geodetic at its origin (station verticals, Earth
/// curvature): observed distances and angles are taken as measured on the ground, no grid
/// scale is applied to them. A point without a height is placed at the mean height of the
/// others. InputError (naming `where`) when the network is already georeferenced (an origin
/// record) or holds coordinate or vector observations (they would be in the CRS too).
void NetworkFromCrs(const geodesy::CrsFrame& frame, const std::string& where, SurveyNetwork* net);

}  // namespace mmba::survey
