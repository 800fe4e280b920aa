#pragma once
// JSON of one trial of RegisterCloudsOverScales, shared by `register-cloud --scale-range` and
// `mmba adjust`'s placement of a photo block on the LiDAR (report.json).

#include <nlohmann/json.hpp>

#include "mmba/registration/cloud/feature_registration.h"

namespace mmba::registration {

inline nlohmann::ordered_json ScaleTrialJson(const ScaleTrial& t) {
  nlohmann::ordered_json trial = {{"scale", t.scale}, {"status", t.status}, {"fitness", t.fitness}};
  if (t.from_refinement) trial["from_refinement"] = true;
  if (t.refined) {
    trial["refined_scale"] = t.refined_scale;
    trial["refined_fitness"] = t.refined_fitness;
  }
  return trial;
}

}  // namespace mmba::registration
