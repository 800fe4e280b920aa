#pragma once

// A survey network from reduced field observations (survey/face_reduction.h): one direction
// set per set-up and round, with its slope distances and zenith angles, the instrument and
// reflector heights, known points fixed, approximate coordinates of every other point.

#include <string>
#include <vector>

#include "mmba/survey/face_reduction.h"
#include "mmba/survey/network.h"

namespace mmba::survey {

/// Builds the network of `reduction`:
///  - each ReducedSet becomes one <obs> cluster (own orientation unknown) holding, per target,
///    a direction, a slope distance and a zenith angle with from_dh = instrument height and
///    to_dh = reflector height (the heights enter the model, not the values); σ from `options`
///    (distance σ = a + b·D);
///  - `known` points that occur in the network are fixed in the coordinates they carry (xy,
///    z); the others are adjusted. Without known horizontal positions every point's xy is
///    constrained (GNU Gama's free network: minimum norm of the changes from the
///    approximations); without known heights likewise every z;
///  - approximate coordinates: the network placed freely from its first station (0, 0, 0, its
///    first round's zero direction as north) set by set — an oriented station places its
///    targets (polar), a station seeing two placed targets is placed (2-D Helmert without
///    scale), heights by trigonometric levelling — then moved onto the known points (rotation
///    and translation from their horizontal positions, a shift from their heights). Points not
///    reached are left to AdjustNetwork's approximations.
/// Throws InputError when `known` is not empty and none of its points is in the network.
SurveyNetwork BuildFieldNetwork(const FaceReduction& reduction, const std::vector<KnownPoint>& known,
                                const FaceReductionOptions& options, const std::string& source);

}  // namespace mmba::survey
