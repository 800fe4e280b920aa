#include "mmba/problem/problem_builder.h"

#include <algorithm>
#include <set>
#include <sstream>

#include "mmba/core/error.h"
#include "mmba/geometry/pose_manifold.h"

namespace mmba {

ProblemBuilder::ProblemBuilder(Scene* scene) : scene_(scene) {}

ProblemBuilder::~ProblemBuilder() = default;

FactorGroup& ProblemBuilder::AddGroup(std::unique_ptr<FactorGroup> group) {
  groups_.push_back(std::move(group));
  return *groups_.back();
}

ceres::Problem& ProblemBuilder::Build() {
  if (problem_) return *problem_;  // built already: the groups' blocks exist once
  CheckGauge();
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::TAKE_OWNERSHIP;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  problem_ = std::make_unique<ceres::Problem>(problem_options);
  for (auto& group : groups_) group->AddResiduals(*scene_, *problem_);

  ApplyParameterOptions();
  ApplyGauge();

  BuildOrdering();
  return *problem_;
}

void ProblemBuilder::CheckGauge() {
  const bool datum_fixed_by_groups =
      std::any_of(groups_.begin(), groups_.end(),
                  [](const auto& group) { return group->FixesDatum(); });
  if (gauge_.kind == GaugeOptions::Kind::kTwoPoses && datum_fixed_by_groups) {
    throw InputError::Message("gauge", "a two-pose gauge fixes a free network, but the "
                                       "observations already fix the datum");
  }
  if (gauge_.kind == GaugeOptions::Kind::kTwoPoses) {
    const std::vector<ImageId> ids = scene_->SortedImageIds();
    if (ids.size() < 2) {
      throw InputError::Message("gauge", "a two-pose gauge needs at least two images, found " +
                                             std::to_string(ids.size()));
    }
    if (!gauge_.first.IsValid()) gauge_.first = ids[0];
    if (!gauge_.second.IsValid()) gauge_.second = gauge_.first == ids[0] ? ids[1] : ids[0];
    for (ImageId id : {gauge_.first, gauge_.second}) {
      if (!scene_->HasImage(id)) {
        throw InputError::Message("gauge", "image " + std::to_string(id.value) +
                                               " is not in the model");
      }
    }
    if (gauge_.first == gauge_.second) {
      throw InputError::Message("gauge", "the two gauge images must differ");
    }
    // Solve in the frame of the first camera: its pose becomes the identity, and the
    // distance to the second camera is then the norm of the second camera's translation.
    gauge_from_world_ = scene_->Image(gauge_.first).cam_from_world;
    scene_->Transform(Sim3d(gauge_from_world_));
    gauge_transformed_ = true;
  }
  if (gauge_.kind == GaugeOptions::Kind::kFixedImages) {
    if (gauge_.fixed_images.empty()) {
      throw InputError::Message("gauge", "fixed-images gauge with an empty list of images");
    }
    for (ImageId id : gauge_.fixed_images) {
      if (!scene_->HasImage(id)) {
        throw InputError::Message("gauge", "image " + std::to_string(id.value) +
                                               " is not in the model");
      }
    }
  }

}

void ProblemBuilder::BuildOrdering() {
  ordering_ = std::make_shared<ceres::ParameterBlockOrdering>();
  // Group 0 must be an independent set: a point that shares a residual block with another
  // point (a measured distance, a scale bar) goes with the other blocks.
  std::set<const double*> points, linked;
  for (auto& [id, point] : scene_->points()) points.insert(point.data());
  std::vector<ceres::ResidualBlockId> residual_blocks;
  problem_->GetResidualBlocks(&residual_blocks);
  std::vector<double*> parameters;
  for (const ceres::ResidualBlockId id : residual_blocks) {
    problem_->GetParameterBlocksForResidualBlock(id, &parameters);
    const auto n = std::count_if(parameters.begin(), parameters.end(), [&](double* b) { return points.count(b) > 0; });
    for (double* b : parameters) {
      if (n > 1 && points.count(b)) linked.insert(b);
    }
  }
  for (auto& [id, point] : scene_->points()) {
    if (problem_->HasParameterBlock(point.data()) && !linked.count(point.data())) {
      ordering_->AddElementToGroup(point.data(), 0);
    }
  }
  std::vector<double*> blocks;
  problem_->GetParameterBlocks(&blocks);
  for (double* block : blocks) {
    if (!ordering_->IsMember(block)) ordering_->AddElementToGroup(block, 1);
  }
}

void ProblemBuilder::ApplyParameterOptions() {
  ApplyIntrinsics();
  ApplyImagesAndPoints();
  ApplySensorPoses();
}

void ProblemBuilder::ApplyIntrinsics() {
  const ParameterOptions& o = parameter_options_;
  for (auto& [id, camera] : scene_->cameras()) {
    double* params = camera.params.data();
    if (!problem_->HasParameterBlock(params)) continue;
    std::vector<int> constant;
    auto hold = [&constant](const std::vector<int>& idxs) {
      constant.insert(constant.end(), idxs.begin(), idxs.end());
    };
    hold(sensors::CameraModelFixedIdxs(camera.model_id));  // e.g. a pixel pitch: never estimated
    const auto held = o.held_intrinsics.find(id);
    if (held != o.held_intrinsics.end()) {
      hold(held->second);
    } else {
      if (!o.refine_focal) hold(sensors::CameraModelFocalIdxs(camera.model_id));
      if (!o.refine_principal_point) hold(sensors::CameraModelPrincipalIdxs(camera.model_id));
      if (!o.refine_extra) hold(sensors::CameraModelExtraIdxs(camera.model_id));
    }
    const int size = static_cast<int>(camera.params.size());
    if (o.constant_cameras.count(id) || static_cast<int>(constant.size()) == size) {
      problem_->SetParameterBlockConstant(params);
    } else if (!constant.empty()) {
      std::sort(constant.begin(), constant.end());
      constant.erase(std::unique(constant.begin(), constant.end()), constant.end());
      problem_->SetManifold(params, new ceres::SubsetManifold(size, constant));
    }
  }
}

void ProblemBuilder::ApplyImagesAndPoints() {
  const ParameterOptions& o = parameter_options_;
  for (auto& [id, image] : scene_->images()) {
    ApplyPose(image.cam_from_world, !o.refine_poses || o.constant_images.count(id) > 0);
  }
  for (auto& [id, point] : scene_->points()) {
    if (problem_->HasParameterBlock(point.data()) &&
        (!o.refine_points || o.constant_points.count(id))) {
      problem_->SetParameterBlockConstant(point.data());
    }
  }
}

void ProblemBuilder::ApplyPose(Rigid3d& pose, bool constant) {
  double* rotation = pose.rotation.coeffs().data();
  double* translation = pose.translation.data();
  if (problem_->HasParameterBlock(rotation)) {
    problem_->SetManifold(rotation, CreateQuaternionManifold().release());
    if (constant) problem_->SetParameterBlockConstant(rotation);
  }
  if (constant && problem_->HasParameterBlock(translation)) {
    problem_->SetParameterBlockConstant(translation);
  }
}

void ProblemBuilder::ApplySensorPoses() {
  const ParameterOptions& o = parameter_options_;
  for (auto& [id, pose] : scene_->rig_frames()) ApplyPose(pose, o.constant_rig_frames.count(id) > 0);
  for (auto& [id, pose] : scene_->cams_from_rig()) {
    ApplyPose(pose, o.constant_cams_from_rig.count(id) > 0);
  }
  for (auto& [id, pose] : scene_->scans()) ApplyPose(pose, o.constant_scans.count(id) > 0);
  for (auto& [id, pose] : scene_->mounts()) ApplyPose(pose, o.constant_mounts.count(id) > 0);
  std::vector<TrajectoryNode>& nodes = scene_->trajectory_nodes();
  for (size_t i = 0; i < nodes.size(); ++i) {
    if (problem_->HasParameterBlock(nodes[i].correction) &&
        o.constant_trajectory_nodes.count(TrajectoryNodeId(i))) {
      problem_->SetParameterBlockConstant(nodes[i].correction);
    }
  }
}

void ProblemBuilder::ApplyGauge() {
  std::ostringstream description;
  switch (gauge_.kind) {
    case GaugeOptions::Kind::kNone:
      description << "datum fixed by the observations (no free-network gauge)";
      break;
    case GaugeOptions::Kind::kTwoPoses: {
      ImagePose& first = scene_->Image(gauge_.first);
      ImagePose& second = scene_->Image(gauge_.second);
      for (double* block : {first.cam_from_world.rotation.coeffs().data(),
                            first.cam_from_world.translation.data()}) {
        if (problem_->HasParameterBlock(block)) problem_->SetParameterBlockConstant(block);
      }
      double* t2 = second.cam_from_world.translation.data();
      const double distance = second.cam_from_world.translation.norm();
      if (problem_->HasParameterBlock(t2) && !problem_->IsParameterBlockConstant(t2)) {
        if (distance <= 0.0) {
          throw InputError::Message(
              "gauge", "images " + std::to_string(gauge_.first.value) + " and " +
                           std::to_string(gauge_.second.value) +
                           " share a projection centre; choose other gauge images");
        }
        problem_->SetManifold(t2, CreateFixedNormManifold().release());
      }
      description << "free network: pose of image " << gauge_.first.value
                  << " fixed, distance from image " << gauge_.first.value << " to image "
                  << gauge_.second.value << " fixed at " << distance
                  << " (model units); 7 datum defects removed";
      break;
    }
    case GaugeOptions::Kind::kFixedImages: {
      description << "poses of image(s)";
      for (ImageId id : gauge_.fixed_images) {
        ImagePose& image = scene_->Image(id);
        for (double* block : {image.cam_from_world.rotation.coeffs().data(),
                              image.cam_from_world.translation.data()}) {
          if (problem_->HasParameterBlock(block)) problem_->SetParameterBlockConstant(block);
        }
        description << " " << id.value;
      }
      description << " held fixed"
                  << (gauge_.fixed_images.size() < 2 ? " (one pose: scale is free)" : "");
      break;
    }
  }
  gauge_description_ = description.str();
}

void ProblemBuilder::Finish() {
  if (gauge_transformed_) {
    scene_->Transform(Sim3d(gauge_from_world_.Inverse()));
    gauge_transformed_ = false;
  }
}

}  // namespace mmba
