#pragma once

#include <string>

#include "mmba/survey/network.h"

namespace mmba::io {

/// Reads a GNU Gama `gama-local` XML network (the format of Gama's GKF parser, all of it):
///   <gama-local> <network axes-xy angles epoch> <description/> <parameters sigma-apr conf-pr
///   tol-abs sigma-act update-constrained-coordinates angles algorithm cov-band latitude
///   ellipsoid/> <points-observations distance-stdev direction-stdev angle-stdev
///   zenith-angle-stdev azimuth-stdev> with <point id x y z fix adj/>, <obs from orientation
///   from_dh> (direction, distance, angle, s-distance, z-angle, azimuth, cov-mat),
///   <height-differences> (dh, cov-mat), <coordinates> (point, cov-mat), <vectors> (vec,
///   cov-mat).
/// Conventions as Gama: angles in gon unless written d-m-s (then σ in sexagesimal seconds,
/// otherwise in cc), distances' σ in mm, distance-stdev "a b c" = a + b·D[km]^c mm, dh σ
/// defaults to sigma-apr·sqrt(dist[km]). Coordinates are converted to (east, north, up) and
/// angles to clockwise radians here; the network keeps the input axes for writing back.
/// Throws InputError (file:line, element/attribute, value, expectation) on any error:
/// unknown element or attribute, unparseable number, missing/zero/negative σ, unknown point,
/// a point id defined twice (both lines named), observation from a point to itself,
/// covariance not positive definite, text that is not UTF-8 or XML, nesting deeper than 256.
survey::SurveyNetwork ReadGamaLocal(const std::string& path);
/// Same from a string (`file` names it in messages).
survey::SurveyNetwork ParseGamaLocal(const std::string& text, const std::string& file);

/// Parses Gama's sexagesimal "d-m-s" (e.g. "359-59-50.00", "-0-0-2") into degrees; false
/// when `text` is not in that form.
bool ParseDms(const std::string& text, double* degrees);

}  // namespace mmba::io
