#include "mmba/sim/scenes.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "mmba/core/error.h"
#include "mmba/sim/ray_caster.h"
#include "mmba/sim/texture.h"

namespace mmba::sim {
namespace {

std::string TempDir() {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("mmba_sim_scenes_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir.string();
}

TEST(Scenes, SameSeedSameMeshOtherSeedOtherRelief) {
  const SimScene a = MakeCathedralScene(CathedralOptions(), 7);
  const SimScene b = MakeCathedralScene(CathedralOptions(), 7);
  const SimScene c = MakeCathedralScene(CathedralOptions(), 8);
  ASSERT_EQ(a.mesh.vertices.size(), b.mesh.vertices.size());
  for (size_t i = 0; i < a.mesh.vertices.size(); ++i) {
    ASSERT_EQ(a.mesh.vertices[i], b.mesh.vertices[i]);
  }
  bool differs = a.mesh.vertices.size() != c.mesh.vertices.size();
  for (size_t i = 0; !differs && i < a.mesh.vertices.size(); ++i) {
    differs = a.mesh.vertices[i] != c.mesh.vertices[i];
  }
  EXPECT_TRUE(differs);
}

TEST(Scenes, GateHasTheRequestedSizeAndTargetsOnSurfaces) {
  GateOptions options;
  const SimScene gate = MakeGateScene(options, 1);
  EXPECT_NEAR(gate.object_max.z(), options.height_m, 1e-12);
  EXPECT_NEAR(gate.object_max.x() - gate.object_min.x(), options.width_m + 0.6, 1e-12);
  EXPECT_GE(gate.targets.size(), 6u);
  EXPECT_EQ(gate.marks.size(), 5u);
  RayCaster caster(gate.mesh);
  for (const ScenePoint& target : gate.targets) {
    // Each target lies on a surface: a ray from 1 m in front hits it at 1 m.
    const RayHit hit =
        caster.Intersect(target.point_in_world - Eigen::Vector3d(0, 1, 0), Eigen::Vector3d::UnitY());
    ASSERT_TRUE(hit.hit) << target.id;
    // ... on the gate itself, not on the studio walls.
    EXPECT_TRUE((target.point_in_world.array() >= gate.object_min.array() - 0.2).all() &&
                (target.point_in_world.array() <= gate.object_max.array() + 0.2).all())
        << target.id << " at " << target.point_in_world.transpose();
    EXPECT_NEAR(hit.distance_m, 1.0, 1e-9) << target.id;
  }
}

TEST(Scenes, CheckRejectsImpossibleParameters) {
  GateOptions gate;
  gate.width_m = 1.0;
  std::string error;
  EXPECT_FALSE(gate.Check(&error));
  EXPECT_NE(error.find("width_m"), std::string::npos);
  CathedralOptions cathedral;
  cathedral.bays = 0;
  EXPECT_FALSE(cathedral.Check(&error));
  EXPECT_NE(error.find("bays"), std::string::npos);
  EXPECT_TRUE(CathedralOptions().Check(&error));
}

TEST(RayCaster, HitsAnalyticPlaneAndBox) {
  TriangleMesh mesh;
  const int m = mesh.AddMaterial(Material());
  mesh.AddQuad({-10, -10, 0}, {10, -10, 0}, {10, 10, 0}, {-10, 10, 0}, m);
  mesh.AddBox({1, 1, 0}, {2, 2, 1}, m, true);
  RayCaster caster(mesh);
  // Down onto the plane z = 0 at 45°: distance √2·3.
  const RayHit ground = caster.Intersect({-3, 0, 3}, Eigen::Vector3d(1, 0, -1));
  ASSERT_TRUE(ground.hit);
  EXPECT_NEAR(ground.distance_m, 3.0 * std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(ground.point.z(), 0.0, 1e-9);
  EXPECT_NEAR(ground.point.x(), 0.0, 1e-9);
  EXPECT_NEAR(ground.normal.z(), 1.0, 1e-12);
  // Horizontally into the box face x = 1.
  const RayHit face = caster.Intersect({-2.0, 1.5, 0.5}, Eigen::Vector3d::UnitX());
  ASSERT_TRUE(face.hit);
  EXPECT_NEAR(face.distance_m, 3.0, 1e-9);
  EXPECT_NEAR(face.normal.x(), -1.0, 1e-12);
  // Up into the sky: no hit; max range respected.
  EXPECT_FALSE(caster.Intersect({0, 0, 1}, Eigen::Vector3d::UnitZ()).hit);
  EXPECT_FALSE(caster.Intersect({-2.0, 1.5, 0.5}, Eigen::Vector3d::UnitX(), 0.0, 2.9).hit);
  EXPECT_TRUE(caster.Visible({-5, 0, 1}, {5, 0, 1}));
  EXPECT_FALSE(caster.Visible({0, 1.5, 0.5}, {3, 1.5, 0.5}));
}

TEST(Mesh, ObjRoundTripAndPlyAscii) {
  const SimScene gate = MakeGateScene(GateOptions(), 3);
  const std::string dir = TempDir();
  WriteObj(gate.mesh, dir + "/gate.obj");
  const TriangleMesh back = LoadMesh(dir + "/gate.obj", Material());
  EXPECT_EQ(back.NumTriangles(), gate.mesh.NumTriangles());
  double area_a = 0, area_b = 0;
  for (size_t t = 0; t < back.NumTriangles(); ++t) area_b += back.TriangleArea(t);
  for (size_t t = 0; t < gate.mesh.NumTriangles(); ++t) area_a += gate.mesh.TriangleArea(t);
  EXPECT_NEAR(area_a, area_b, 1e-6 * area_a);
  bool has_glass = false;
  for (const Material& m : back.materials) has_glass |= m.material_class == MaterialClass::kGlass;
  EXPECT_TRUE(has_glass);

  std::ofstream(dir + "/quad.ply") << "ply\nformat ascii 1.0\nelement vertex 4\n"
                                      "property float x\nproperty float y\nproperty float z\n"
                                      "element face 1\nproperty list uchar int vertex_indices\n"
                                      "end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
  const TriangleMesh quad = LoadMesh(dir + "/quad.ply", Material());
  EXPECT_EQ(quad.NumTriangles(), 2u);
  EXPECT_NEAR(quad.TriangleArea(0) + quad.TriangleArea(1), 1.0, 1e-12);
}

TEST(Mesh, BrokenFilesThrowWithLocation) {
  const std::string dir = TempDir();
  std::ofstream(dir + "/bad.obj") << "v 0 0 0\nv 1 0 0\nf 1 2 7\n";
  try {
    LoadMesh(dir + "/bad.obj", Material());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.obj:3"), std::string::npos) << e.what();
  }
  std::ofstream(dir + "/empty.obj") << "# nothing\n";
  EXPECT_THROW(LoadMesh(dir + "/empty.obj", Material()), InputError);
  EXPECT_THROW(LoadMesh(dir + "/mesh.stl", Material()), InputError);
}

TEST(Texture, DeterministicAndStructured) {
  Material stone;
  stone.pattern = TexturePattern::kStone;
  const Eigen::Vector3d n(0, -1, 0);
  double lo = 1, hi = 0;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(0.013 * i, 0, 0.007 * i);
    const double a = Albedo(stone, p, n, 5);
    EXPECT_EQ(a, Albedo(stone, p, n, 5));
    lo = std::min(lo, a);
    hi = std::max(hi, a);
  }
  EXPECT_GT(hi - lo, 0.3);  // enough contrast for features
}

}  // namespace
}  // namespace mmba::sim
