#pragma once

// adjusted.json of `mmba survey` (docs/commands/survey.md): the adjusted network with its
// statistics, in the input's axes and angle unit.

#include <string>

#include <nlohmann/json.hpp>

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
nlohmann::json ResultToJson(const std::string& input, const SurveyNetwork& net,
                            const SurveyAdjustment& adj);

}  // namespace mmba::survey
