#pragma once

#include <string>

#include "mmba/survey/network.h"

namespace mmba::io {

/// A network as GNU Gama `gama-local` XML text, readable by Gama and by ReadGamaLocal:
/// <network axes-xy angles>, <parameters sigma-apr conf-pr>, every point with the
/// coordinates it has (x, y in the network's input axes) and its fix/adj code (lower case
/// adjusted, upper case constrained), and each standpoint cluster as one <obs from from_dh>
/// with <direction>, <angle>, <distance>, <s-distance>, <z-angle>, <azimuth>: angles in gon
/// with σ in cc, lengths in m with σ in mm, from_dh/to_dh as the observations carry them.
/// Height-difference, coordinate and vector clusters and correlated clusters are not
/// written (std::invalid_argument): the networks of field books hold none.
std::string GamaLocalText(const survey::SurveyNetwork& network);

}  // namespace mmba::io
