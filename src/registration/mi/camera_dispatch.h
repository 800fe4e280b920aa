#pragma once

// The camera model of a view as a type: the renderer and the point-sample accumulation are
// templates on the model (sensors/camera_models.h), chosen once per view.

#include <glog/logging.h>

#include "mmba/sensors/camera_models.h"

namespace mmba::registration::mi::internal {

/// Calls `body(Model())` with the model struct of `model_id`; LOG(FATAL) on an unknown id.
/// Always inlined, so that a caller compiled per instruction set (target_clones) gets the
/// model's code compiled for each of them.
template <typename Body>
[[gnu::always_inline]] inline void WithCameraModel(sensors::CameraModelId model_id, Body&& body) {
  switch (model_id) {
#define MMBA_WITH_CAMERA_MODEL_CASE(Model) \
  case Model::kModelId:                    \
    body(Model());                         \
    break;
    MMBA_FOR_EACH_CAMERA_MODEL(MMBA_WITH_CAMERA_MODEL_CASE)
#undef MMBA_WITH_CAMERA_MODEL_CASE
    default:
      LOG(FATAL) << "unknown camera model";
  }
}

}  // namespace mmba::registration::mi::internal
