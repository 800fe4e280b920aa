#pragma once

#include <string>

#include "mmba/survey/network.h"

namespace mmba::io {

/// Reads a GNU Gama `gama-local` XML network: every element and attribute of Gama's schema
/// (xml/gama-local.xsd 1.01):
///   <gama-local> <network axes-xy angles epoch> <description/> <parameters sigma-apr conf-pr
///   tol-abs sigma-act update-constrained-coordinates angles algorithm cov-band latitude
///   ellipsoid language encoding/> <points-observations distance-stdev direction-stdev
///   angle-stdev zenith-angle-stdev azimuth-stdev> with <point id x y z fix adj/>, <obs from
///   orientation from_dh> (direction, distance, angle, s-distance, z-angle, azimuth, cov-mat),
///   <height-differences> (dh, cov-mat), <coordinates extern> (point, cov-mat), <vectors>
///   (vec, cov-mat).
/// Read but without effect, as they carry no observation: epoch, algorithm, cov-band,
/// latitude, ellipsoid, language and encoding (of Gama's text output), and every `extern`
/// attribute (a label Gama passes through for other programs).
/// The file may be in any encoding its XML declaration names (ISO-8859-2, windows-1250,
/// Gama's "cp-1250" ...) or UTF-16 with a byte order mark; it is converted to UTF-8 first.
/// Conventions as Gama: angles in gon unless written d-m-s (then σ in sexagesimal seconds,
/// otherwise in cc), distances' σ in mm, distance-stdev "a b c" = a + b·D[km]^c mm, dh σ
/// defaults to sigma-apr·sqrt(dist[km]). Coordinates are converted to (east, north, up) and
/// angles to clockwise radians here; the network keeps the input axes for writing back.
/// Throws InputError (file:line, element/attribute, value, expectation) on any error:
/// unknown element or attribute, unparseable number, missing/zero/negative σ, unknown point,
/// a point id defined twice (both lines named), observation from a point to itself,
/// covariance not positive definite, an encoding iconv does not know, text that is not
/// UTF-8 (after conversion) or XML, nesting deeper than 256.
survey::SurveyNetwork ReadGamaLocal(const std::string& path);
/// Same from a string (`file` names it in messages).
survey::SurveyNetwork ParseGamaLocal(const std::string& text, const std::string& file);

/// Parses Gama's sexagesimal "d-m-s" (e.g. "359-59-50.00", "-0-0-2") into degrees; false
/// when `text` is not in that form.
bool ParseDms(const std::string& text, double* degrees);

}  // namespace mmba::io
