#pragma once

#include <string>

#include "mmba/survey/network.h"

namespace mmba::io {

/// Reads the plain CSV form of a survey network (docs/formats.md). One record a line,
/// comma separated as RFC 4180 (a field in double quotes may hold commas and doubled quotes,
/// e.g. a point id "P ""A"", north"; CRLF line ends and a UTF-8 byte order mark as
/// spreadsheets write them), '#' outside quotes starts a comment:
///   param,<name>,<value>        sigma-apr | conf-pr | sigma-act | axes-xy | angles |
///                               refraction (coefficient k of zenith angles)
///   param,origin,<lat>,<lon>,<h>  georeferenced network: WGS84 origin of the local tangent
///                               plane; observations then use each station's own vertical
///   point,<id>,<x>,<y>,<z>,<fix>,<adj>   empty fields allowed; fix/adj as gama-local
///   gpoint,<id>,<lat>,<lon>,<h>,<fix>,<adj>  WGS84 geodetic coordinates (needs the origin)
///   set,<station>               starts a direction set (its own orientation unknown)
///   <kind>,<from>,<to>,<value>,<sigma>[,<from_dh>,<to_dh>]
/// with kind = direction (inside a set), distance, s-distance, z-angle, azimuth, dh,
/// angle (<to> = "bs/fs"). Angles in gon (or d-m-s, σ then in seconds), σ of angles in
/// cc, of lengths in mm. Same conventions and errors as ReadGamaLocal; also an InputError
/// for a file without records or without observations, and for a point id given by two
/// point/gpoint records (both lines named).
survey::SurveyNetwork ReadSurveyCsv(const std::string& path);
survey::SurveyNetwork ParseSurveyCsv(const std::string& text, const std::string& file);

}  // namespace mmba::io
