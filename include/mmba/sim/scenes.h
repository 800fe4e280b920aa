#pragma once

// Built-in scenes of the simulator, parameterised and deterministic for a seed. World frame:
// east (x), north (y), up (z), metres; the ground is z = 0 and the object's front faces
// south (−y), so sensors stand at y < 0.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/sim/mesh.h"

namespace mmba::sim {

/// A named 3-D point of the scene: a survey mark on the ground or a target on a surface.
struct ScenePoint {
  std::string id;
  Eigen::Vector3d point_in_world = Eigen::Vector3d::Zero();
  std::string kind;  ///< "mark" (ground mark for setups / GNSS), "target" (on a surface)
};

struct SimScene {
  std::string name;
  TriangleMesh mesh;
  Eigen::Vector3d object_min = Eigen::Vector3d::Zero();  ///< bounds of the object of interest
  Eigen::Vector3d object_max = Eigen::Vector3d::Zero();  ///< (without the ground)
  std::vector<ScenePoint> marks;    ///< ground marks in front of the object
  std::vector<ScenePoint> targets;  ///< targets on the object's surfaces (control, scan targets)
};

/// An indoor film-set gate: two posts, a beam, a relief panel, a floor, studio walls.
struct GateOptions {
  double width_m = 9.0;        ///< outer width of the gate
  double height_m = 6.0;       ///< top of the beam
  double post_width_m = 0.8;
  double relief_depth_m = 0.12;  ///< how far relief blocks stand out
  int relief_blocks = 60;       ///< number of relief blocks on posts, beam and panel
  double studio_half_size_m = 14.0;  ///< walls of the studio at ±this from the gate centre
  bool Check(std::string* error) const;
};

/// An outdoor facade with windows and doors (glass), steps, buttresses, relief, side walls,
/// ground — left/right symmetric with repeated storeys (pseudo-symmetry).
struct CathedralOptions {
  double width_m = 30.0;
  double height_m = 20.0;        ///< eaves height; the gable rises above
  double depth_m = 24.0;         ///< length of the side walls
  int bays = 5;                  ///< window columns (odd keeps a central door)
  int storeys = 2;               ///< window rows
  int relief_blocks = 120;
  double ground_half_size_m = 60.0;
  bool Check(std::string* error) const;
};

SimScene MakeGateScene(const GateOptions& options, uint64_t seed);
SimScene MakeCathedralScene(const CathedralOptions& options, uint64_t seed);

/// A scene from a mesh file (LoadMesh) with marks on a circle in front of its bounds and
/// targets sampled on its front surfaces.
SimScene SceneFromMesh(TriangleMesh mesh, const std::string& name, uint64_t seed);

}  // namespace mmba::sim
