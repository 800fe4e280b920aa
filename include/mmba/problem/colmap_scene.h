#pragma once

#include <vector>

#include "mmba/io/colmap_model.h"
#include "mmba/problem/reprojection_group.h"
#include "mmba/problem/scene.h"

namespace mmba {

/// Fills `scene` with the cameras, poses (quaternions normalised) and points of a COLMAP
/// model and returns one observation per track element, each with σ = `sigma_px`.
std::vector<ReprojectionObservation> SceneFromColmap(const io::ColmapModel& model,
                                                     double sigma_px, Scene* scene);

/// Copies adjusted cameras, poses and points from `scene` back into `model`, and updates
/// each point's ERROR (mean reprojection error of its track, px).
void UpdateColmapFromScene(const Scene& scene, io::ColmapModel* model);

}  // namespace mmba
