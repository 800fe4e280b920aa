// ProblemBuilder::Build() sets the manifolds and constant blocks of every parameter kind of the
// Scene from ParameterOptions: intrinsics subsets (with per-camera overrides), quaternion
// manifolds of rig frames, rig cameras, scans and mounts, and the constant sets.
#include "mmba/problem/problem_builder.h"

#include <memory>
#include <vector>

#include <ceres/ceres.h>
#include <gtest/gtest.h>

namespace mmba {
namespace {

/// One zero residual over the given blocks: puts them into the problem and nothing else.
class TouchCost : public ceres::CostFunction {
 public:
  explicit TouchCost(const std::vector<int>& sizes) {
    for (int size : sizes) mutable_parameter_block_sizes()->push_back(size);
    set_num_residuals(1);
  }
  bool Evaluate(double const* const*, double* residuals, double** jacobians) const override {
    residuals[0] = 0.0;
    if (jacobians == nullptr) return true;
    for (size_t b = 0; b < parameter_block_sizes().size(); ++b) {
      if (jacobians[b] == nullptr) continue;
      for (int i = 0; i < parameter_block_sizes()[b]; ++i) jacobians[b][i] = 0.0;
    }
    return true;
  }
};

/// A group that adds one TouchCost per listed block (block, size).
class TouchGroup : public FactorGroup {
 public:
  explicit TouchGroup(std::vector<std::pair<double*, int>> blocks)
      : FactorGroup("touch", "m", LossOptions()), blocks_(std::move(blocks)) {}
  void AddResiduals(Scene&, ceres::Problem& problem) override {
    for (size_t i = 0; i < blocks_.size(); ++i) {
      AddBlock(problem, new TouchCost({blocks_[i].second}), {blocks_[i].first}, 1.0, i);
    }
  }

 private:
  std::vector<std::pair<double*, int>> blocks_;
};

sensors::Camera MakeCamera(uint64_t id, sensors::CameraModelId model, std::vector<double> params) {
  sensors::Camera camera;
  camera.camera_id = CameraId(id);
  camera.model_id = model;
  camera.width = 1000;
  camera.height = 800;
  camera.params = std::move(params);
  return camera;
}

int Tangent(ceres::Problem& problem, const double* block) { return problem.ParameterBlockTangentSize(block); }

/// The rotation block has the quaternion manifold (4 → 3) and the translation none.
void ExpectPoseManifolds(ceres::Problem& problem, Rigid3d& pose) {
  const ceres::Manifold* manifold = problem.GetManifold(pose.rotation.coeffs().data());
  ASSERT_NE(manifold, nullptr);
  EXPECT_EQ(manifold->AmbientSize(), 4);
  EXPECT_EQ(manifold->TangentSize(), 3);
  EXPECT_EQ(problem.GetManifold(pose.translation.data()), nullptr);
  EXPECT_EQ(Tangent(problem, pose.translation.data()), 3);
}

void ExpectPoseConstant(ceres::Problem& problem, Rigid3d& pose, bool constant) {
  EXPECT_EQ(problem.IsParameterBlockConstant(pose.rotation.coeffs().data()), constant);
  EXPECT_EQ(problem.IsParameterBlockConstant(pose.translation.data()), constant);
}

TEST(ParameterOptions, BuildSetsManifoldsAndConstantBlocksOfEveryKind) {
  using sensors::CameraModelId;
  Scene scene;
  // OPENCV (fx fy cx cy k1 k2 p1 p2): principal point held by its override, the rest free.
  sensors::Camera& opencv = scene.AddCamera(MakeCamera(1, CameraModelId::kOpenCV, {500, 500, 500, 400, 0, 0, 0, 0}));
  // PINHOLE (fx fy cx cy): every index held by its override = constant.
  sensors::Camera& pinhole = scene.AddCamera(MakeCamera(2, CameraModelId::kPinhole, {500, 500, 500, 400}));
  // PINHOLE with an empty override: all free, although the refine flags would hold all.
  sensors::Camera& free_camera = scene.AddCamera(MakeCamera(3, CameraModelId::kPinhole, {500, 500, 500, 400}));
  // PINHOLE without an override: the refine flags (all held by default) make it constant.
  sensors::Camera& flagged = scene.AddCamera(MakeCamera(4, CameraModelId::kPinhole, {500, 500, 500, 400}));
  const Rigid3d pose(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
                     Eigen::Vector3d(1, 2, 3));
  Rigid3d& frame = scene.AddRigFrame(FrameId(0), pose);
  Rigid3d& unused_frame = scene.AddRigFrame(FrameId(1), pose);
  Rigid3d& cam_from_rig_fixed = scene.AddCamFromRig(CameraId(1), pose);
  Rigid3d& cam_from_rig_free = scene.AddCamFromRig(CameraId(3), pose);
  Rigid3d& scan = scene.AddScan(ScanId(0), pose);
  Rigid3d& scan_fixed = scene.AddScan(ScanId(1), pose);
  Rigid3d& mount = scene.AddMount(MountId(0), pose);
  scene.SetTrajectoryNodes(std::vector<TrajectoryNode>(2));
  std::vector<TrajectoryNode>& nodes = scene.trajectory_nodes();
  nodes[1].time_s = 1.0;

  std::vector<std::pair<double*, int>> blocks = {{opencv.params.data(), 8}, {pinhole.params.data(), 4},
                                                 {free_camera.params.data(), 4}, {flagged.params.data(), 4},
                                                 {nodes[0].correction, 6}, {nodes[1].correction, 6}};
  for (Rigid3d* p : {&frame, &cam_from_rig_fixed, &cam_from_rig_free, &scan, &scan_fixed, &mount}) {
    blocks.push_back({p->rotation.coeffs().data(), 4});
    blocks.push_back({p->translation.data(), 3});
  }
  ProblemBuilder builder(&scene);
  builder.AddGroup(std::make_unique<TouchGroup>(blocks));
  GaugeOptions gauge;
  gauge.kind = GaugeOptions::Kind::kNone;
  builder.set_gauge(gauge);
  ParameterOptions& options = builder.parameter_options();
  options.held_intrinsics[CameraId(1)] = {3, 2};
  options.held_intrinsics[CameraId(2)] = {0, 1, 2, 3};
  options.held_intrinsics[CameraId(3)] = {};
  options.constant_cams_from_rig.insert(CameraId(1));
  options.constant_scans.insert(ScanId(1));
  options.constant_mounts.insert(MountId(0));
  options.constant_trajectory_nodes.insert(TrajectoryNodeId(1));
  ceres::Problem& problem = builder.Build();

  // Intrinsics.
  const ceres::Manifold* subset = problem.GetManifold(opencv.params.data());
  ASSERT_NE(subset, nullptr);
  EXPECT_EQ(subset->AmbientSize(), 8);
  EXPECT_EQ(subset->TangentSize(), 6);
  EXPECT_FALSE(problem.IsParameterBlockConstant(opencv.params.data()));
  EXPECT_TRUE(problem.IsParameterBlockConstant(pinhole.params.data()));
  EXPECT_EQ(problem.GetManifold(free_camera.params.data()), nullptr);
  EXPECT_EQ(Tangent(problem, free_camera.params.data()), 4);
  EXPECT_FALSE(problem.IsParameterBlockConstant(free_camera.params.data()));
  EXPECT_TRUE(problem.IsParameterBlockConstant(flagged.params.data()));

  // Poses: the quaternion manifold on every rotation, the constant sets held.
  for (Rigid3d* p : {&frame, &cam_from_rig_fixed, &cam_from_rig_free, &scan, &scan_fixed, &mount}) {
    ExpectPoseManifolds(problem, *p);
  }
  ExpectPoseConstant(problem, frame, false);
  ExpectPoseConstant(problem, cam_from_rig_fixed, true);
  ExpectPoseConstant(problem, cam_from_rig_free, false);
  ExpectPoseConstant(problem, scan, false);
  ExpectPoseConstant(problem, scan_fixed, true);
  ExpectPoseConstant(problem, mount, true);
  // A stored pose no group uses stays out of the problem.
  EXPECT_FALSE(problem.HasParameterBlock(unused_frame.rotation.coeffs().data()));

  // Trajectory nodes: no manifold; the listed node constant.
  EXPECT_EQ(problem.GetManifold(nodes[0].correction), nullptr);
  EXPECT_EQ(Tangent(problem, nodes[0].correction), 6);
  EXPECT_FALSE(problem.IsParameterBlockConstant(nodes[0].correction));
  EXPECT_TRUE(problem.IsParameterBlockConstant(nodes[1].correction));
}

}  // namespace
}  // namespace mmba
