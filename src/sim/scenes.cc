#include "mmba/sim/scenes.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <sstream>

#include "mmba/sim/ray_caster.h"

namespace mmba::sim {
namespace {

using Eigen::Vector3d;

// A rectangular opening in a wall of constant y: x in [x0, x1], z in [z0, z1].
struct Hole {
  double x0, x1, z0, z1;
};

// A wall in the plane y = `y` over [x0, x1] × [z0, z1] with rectangular holes, as the cells
// of the grid of hole edges that lie outside every hole. `normal_sign` −1 faces −y.
void AddWallWithHoles(TriangleMesh* mesh, double x0, double x1, double z0, double z1, double y,
                      const std::vector<Hole>& holes, int normal_sign, int material) {
  std::set<double> xs{x0, x1}, zs{z0, z1};
  for (const Hole& h : holes) {
    xs.insert(h.x0);
    xs.insert(h.x1);
    zs.insert(h.z0);
    zs.insert(h.z1);
  }
  const std::vector<double> xv(xs.begin(), xs.end()), zv(zs.begin(), zs.end());
  for (size_t i = 0; i + 1 < xv.size(); ++i) {
    for (size_t j = 0; j + 1 < zv.size(); ++j) {
      const double cx = 0.5 * (xv[i] + xv[i + 1]), cz = 0.5 * (zv[j] + zv[j + 1]);
      bool inside = false;
      for (const Hole& h : holes) {
        if (cx > h.x0 && cx < h.x1 && cz > h.z0 && cz < h.z1) inside = true;
      }
      if (inside) continue;
      const Vector3d a(xv[i], y, zv[j]), b(xv[i + 1], y, zv[j]), c(xv[i + 1], y, zv[j + 1]),
          d(xv[i], y, zv[j + 1]);
      if (normal_sign < 0) {
        mesh->AddQuad(a, b, c, d, material);
      } else {
        mesh->AddQuad(b, a, d, c, material);
      }
    }
  }
}

// The four reveal faces of a hole through a wall from y0 to y1 (facing into the opening).
void AddReveals(TriangleMesh* mesh, const Hole& h, double y0, double y1, int material) {
  mesh->AddQuad({h.x0, y0, h.z0}, {h.x1, y0, h.z0}, {h.x1, y1, h.z0}, {h.x0, y1, h.z0},
                material);  // sill, faces up
  mesh->AddQuad({h.x0, y0, h.z1}, {h.x0, y1, h.z1}, {h.x1, y1, h.z1}, {h.x1, y0, h.z1},
                material);  // lintel, faces down
  mesh->AddQuad({h.x0, y0, h.z0}, {h.x0, y1, h.z0}, {h.x0, y1, h.z1}, {h.x0, y0, h.z1},
                material);  // left jamb, faces +x
  mesh->AddQuad({h.x1, y0, h.z0}, {h.x1, y0, h.z1}, {h.x1, y1, h.z1}, {h.x1, y1, h.z0},
                material);  // right jamb, faces −x
}

bool Overlaps(double a0, double a1, double b0, double b1) { return a0 < b1 && b0 < a1; }

// Targets on surfaces: cast horizontally along +y from far in front through (x, z).
void PlaceTargets(SimScene* scene, const std::vector<std::pair<double, double>>& xz,
                  const std::string& prefix) {
  RayCaster caster(scene->mesh);
  int k = 0;
  for (const auto& [x, z] : xz) {
    // From 1 m in front of the object (not from outside a surrounding studio wall).
    const RayHit hit = caster.Intersect(Vector3d(x, scene->object_min.y() - 1.0, z), Vector3d::UnitY());
    if (!hit.hit) continue;
    std::ostringstream id;
    id << prefix << ++k;
    scene->targets.push_back({id.str(), hit.point, "target"});
  }
}

Material Make(const std::string& name, MaterialClass cls, TexturePattern pattern, double albedo,
              double contrast, double scale_m) {
  Material m;
  m.name = name;
  m.material_class = cls;
  m.pattern = pattern;
  m.base_albedo = albedo;
  m.contrast = contrast;
  m.scale_m = scale_m;
  return m;
}

}  // namespace

bool GateOptions::Check(std::string* error) const {
  std::ostringstream e;
  if (!(width_m > 2.0 * post_width_m + 0.5)) e << "gate width_m " << width_m << " must exceed 2·post_width_m + 0.5";
  else if (!(height_m > 1.5)) e << "gate height_m " << height_m << " must be > 1.5";
  else if (!(post_width_m > 0.05)) e << "gate post_width_m " << post_width_m << " must be > 0.05";
  else if (!(relief_depth_m >= 0.0)) e << "gate relief_depth_m " << relief_depth_m << " must be >= 0";
  else if (relief_blocks < 0) e << "gate relief_blocks " << relief_blocks << " must be >= 0";
  else if (!(studio_half_size_m > 0.5 * width_m + 1.0)) e << "gate studio_half_size_m " << studio_half_size_m << " must exceed width_m/2 + 1";
  if (e.str().empty()) return true;
  if (error) *error = e.str();
  return false;
}

bool CathedralOptions::Check(std::string* error) const {
  std::ostringstream e;
  if (!(width_m >= 8.0)) e << "cathedral width_m " << width_m << " must be >= 8";
  else if (!(height_m >= 6.0)) e << "cathedral height_m " << height_m << " must be >= 6";
  else if (!(depth_m >= 2.0)) e << "cathedral depth_m " << depth_m << " must be >= 2";
  else if (bays < 1 || bays > 15) e << "cathedral bays " << bays << " must be in [1, 15]";
  else if (storeys < 1 || storeys > 6) e << "cathedral storeys " << storeys << " must be in [1, 6]";
  else if (relief_blocks < 0) e << "cathedral relief_blocks " << relief_blocks << " must be >= 0";
  else if (!(ground_half_size_m > width_m)) e << "cathedral ground_half_size_m " << ground_half_size_m << " must exceed width_m";
  if (e.str().empty()) return true;
  if (error) *error = e.str();
  return false;
}

SimScene MakeGateScene(const GateOptions& o, uint64_t seed) {
  SimScene scene;
  scene.name = "gate";
  TriangleMesh& mesh = scene.mesh;
  std::mt19937_64 rng(seed * 2654435761ull + 1);
  const int floor = mesh.AddMaterial(Make("floor_concrete", MaterialClass::kDiffuse, TexturePattern::kNoise, 0.45, 0.3, 1.0));
  const int wall = mesh.AddMaterial(Make("studio_wall", MaterialClass::kDiffuse, TexturePattern::kBrick, 0.55, 0.3, 0.6));
  const int stone = mesh.AddMaterial(Make("post_stone", MaterialClass::kDiffuse, TexturePattern::kStone, 0.6, 0.35, 0.4));
  const int wood = mesh.AddMaterial(Make("beam_wood", MaterialClass::kDiffuse, TexturePattern::kWood, 0.5, 0.3, 0.5));
  const int panel = mesh.AddMaterial(Make("door_wood", MaterialClass::kDiffuse, TexturePattern::kWood, 0.4, 0.35, 0.3));
  const int relief = mesh.AddMaterial(Make("relief_plaster", MaterialClass::kDiffuse, TexturePattern::kNoise, 0.7, 0.3, 0.2));
  const int metal = mesh.AddMaterial(Make("metal_plate", MaterialClass::kReflective, TexturePattern::kNoise, 0.35, 0.15, 0.3));
  const int glass = mesh.AddMaterial(Make("glass_pane", MaterialClass::kGlass, TexturePattern::kNoise, 0.15, 0.05, 0.5));

  const double s = o.studio_half_size_m, w = 0.5 * o.width_m, pw = o.post_width_m;
  const double beam_h = std::min(0.8, 0.2 * o.height_m);
  const double ceiling = o.height_m + 3.0;
  mesh.AddQuad({-s, -s, 0}, {s, -s, 0}, {s, s, 0}, {-s, s, 0}, floor);
  mesh.AddQuad({-s, s, 0}, {s, s, 0}, {s, s, ceiling}, {-s, s, ceiling}, wall);     // back
  mesh.AddQuad({s, -s, 0}, {-s, -s, 0}, {-s, -s, ceiling}, {s, -s, ceiling}, wall);  // front
  mesh.AddQuad({-s, -s, 0}, {-s, s, 0}, {-s, s, ceiling}, {-s, -s, ceiling}, wall);  // west
  mesh.AddQuad({s, s, 0}, {s, -s, 0}, {s, -s, ceiling}, {s, s, ceiling}, wall);      // east
  mesh.AddQuad({-s, s, ceiling}, {s, s, ceiling}, {s, -s, ceiling}, {-s, -s, ceiling}, floor);
  // Posts, beam, door leaves (recessed by half a post), a metal plate and a glass pane.
  mesh.AddBox({-w, 0, 0}, {-w + pw, pw, o.height_m - beam_h}, stone, true);
  mesh.AddBox({w - pw, 0, 0}, {w, pw, o.height_m - beam_h}, stone, true);
  mesh.AddBox({-w - 0.3, -0.05, o.height_m - beam_h}, {w + 0.3, pw + 0.05, o.height_m}, wood);
  const double door_y = 0.5 * pw, door_top = o.height_m - beam_h;
  mesh.AddBox({-w + pw, door_y, 0}, {-0.01, door_y + 0.08, door_top}, panel, true);
  mesh.AddBox({0.01, door_y, 0}, {w - pw, door_y + 0.08, door_top}, panel, true);
  const double plate = std::min(1.2, 0.4 * (w - pw));
  mesh.AddBox({-0.5 * (w - pw) - 0.5 * plate, door_y - 0.01, 0.3 * door_top},
              {-0.5 * (w - pw) + 0.5 * plate, door_y, 0.3 * door_top + plate}, metal);
  mesh.AddBox({0.5 * (w - pw) - 0.5 * plate, door_y - 0.01, 0.6 * door_top},
              {0.5 * (w - pw) + 0.5 * plate, door_y, 0.6 * door_top + 0.6 * plate}, glass);
  // Relief blocks on the front faces of the posts, beam and doors.
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int i = 0; i < o.relief_blocks; ++i) {
    const double size = 0.1 + 0.3 * unit(rng);
    const double depth = o.relief_depth_m * (0.3 + 0.7 * unit(rng));
    const int where = static_cast<int>(unit(rng) * 4.0);
    double x0, z0, y_front;
    if (where <= 1) {  // a post
      const double px = where == 0 ? -w : w - pw;
      x0 = px + unit(rng) * std::max(0.0, pw - size);
      z0 = 0.3 + unit(rng) * std::max(0.0, door_top - 0.3 - size);
      y_front = 0.0;
    } else if (where == 2) {  // the beam
      x0 = -w + unit(rng) * (2 * w - size);
      z0 = o.height_m - beam_h + unit(rng) * std::max(0.0, beam_h - size);
      y_front = -0.05;
    } else {  // a door leaf
      x0 = -w + pw + unit(rng) * std::max(0.0, 2 * (w - pw) - size);
      z0 = 0.2 + unit(rng) * std::max(0.0, door_top - 0.2 - size);
      y_front = door_y;
    }
    const double sx = std::min(size, 0.95 * pw), sz = size * (0.5 + unit(rng));
    mesh.AddBox({x0, y_front - depth, z0}, {x0 + sx, y_front, z0 + sz}, relief);
  }
  scene.object_min = Vector3d(-w - 0.3, -0.3, 0.0);
  scene.object_max = Vector3d(w + 0.3, pw + 0.1, o.height_m);
  // Marks on the floor in front; targets on posts, beam, doors and the side walls.
  const double r = std::min(s - 1.0, 1.1 * o.width_m);
  for (int i = 0; i < 5; ++i) {
    const double a = M_PI * (0.2 + 0.15 * i);
    scene.marks.push_back({"M" + std::to_string(i + 1),
                           Vector3d(-r * std::cos(a) * 0.8, -0.7 * r * std::sin(a), 0.0), "mark"});
  }
  PlaceTargets(&scene,
               {{-w + 0.5 * pw, 1.0}, {w - 0.5 * pw, 1.0}, {-w + 0.5 * pw, 0.7 * door_top},
                {w - 0.5 * pw, 0.7 * door_top}, {-0.5 * w, o.height_m - 0.5 * beam_h},
                {0.5 * w, o.height_m - 0.5 * beam_h}, {-0.3 * w, 0.15 * door_top},
                {0.3 * w, 0.15 * door_top}},
               "T");
  return scene;
}

namespace {

struct CathedralMaterials {
  int ground, stone, side, roof, trim, relief, glass, interior, metal;
};

CathedralMaterials AddCathedralMaterials(TriangleMesh& mesh) {
  CathedralMaterials m;
  m.ground = mesh.AddMaterial(Make("ground_paving", MaterialClass::kDiffuse, TexturePattern::kStone, 0.45, 0.3, 0.8));
  m.stone = mesh.AddMaterial(Make("facade_stone", MaterialClass::kDiffuse, TexturePattern::kStone, 0.62, 0.3, 0.5));
  m.side = mesh.AddMaterial(Make("side_brick", MaterialClass::kDiffuse, TexturePattern::kBrick, 0.5, 0.3, 0.5));
  m.roof = mesh.AddMaterial(Make("roof_slate", MaterialClass::kDiffuse, TexturePattern::kBrick, 0.3, 0.2, 0.4));
  m.trim = mesh.AddMaterial(Make("trim_stone", MaterialClass::kDiffuse, TexturePattern::kNoise, 0.7, 0.3, 0.3));
  m.relief = mesh.AddMaterial(Make("relief_sculpture", MaterialClass::kDiffuse, TexturePattern::kNoise, 0.66, 0.35, 0.15));
  m.glass = mesh.AddMaterial(Make("glass_window", MaterialClass::kGlass, TexturePattern::kNoise, 0.12, 0.06, 0.4));
  m.interior = mesh.AddMaterial(Make("interior_plaster", MaterialClass::kDiffuse, TexturePattern::kNoise, 0.35, 0.25, 1.0));
  m.metal = mesh.AddMaterial(Make("metal_door_fittings", MaterialClass::kReflective, TexturePattern::kNoise, 0.4, 0.1, 0.2));
  return m;
}

/// The front wall's openings: `bays` columns × `storeys` rows of windows (column-major); the
/// central bottom one is a door.
struct Openings {
  std::vector<Hole> holes;
  std::vector<bool> is_door;
};

Openings CathedralOpenings(const CathedralOptions& o) {
  const double w = 0.5 * o.width_m, h = o.height_m;
  const double bay_w = o.width_m / o.bays, storey_h = h / o.storeys;
  Openings openings;
  for (int b = 0; b < o.bays; ++b) {
    for (int s = 0; s < o.storeys; ++s) {
      const double cx = -w + (b + 0.5) * bay_w;
      const bool door = (s == 0 && b == o.bays / 2);
      const double hw = door ? 0.3 * bay_w : 0.22 * bay_w;
      const double z0 = door ? 0.45 : s * storey_h + 0.35 * storey_h;
      const double z1 = door ? std::min(0.75 * storey_h, 5.0) : s * storey_h + 0.85 * storey_h;
      openings.holes.push_back({cx - hw, cx + hw, z0, z1});
      openings.is_door.push_back(door);
    }
  }
  return openings;
}

/// The front wall (`wall_t` thick) with its openings: reveals, glass, a bar across the door.
void AddFrontWall(TriangleMesh& mesh, const CathedralOptions& o, const Openings& openings,
                  double wall_t, const CathedralMaterials& m) {
  const double w = 0.5 * o.width_m, h = o.height_m;
  const std::vector<Hole>& holes = openings.holes;
  AddWallWithHoles(&mesh, -w, w, 0.0, h, 0.0, holes, -1, m.stone);
  AddWallWithHoles(&mesh, -w, w, 0.0, h, wall_t, holes, +1, m.interior);
  for (size_t i = 0; i < holes.size(); ++i) {
    AddReveals(&mesh, holes[i], 0.0, wall_t, m.trim);
    const double y_glass = 0.5 * wall_t;
    const Hole& k = holes[i];
    mesh.AddQuad({k.x0, y_glass, k.z0}, {k.x1, y_glass, k.z0}, {k.x1, y_glass, k.z1},
                 {k.x0, y_glass, k.z1}, m.glass);
    if (openings.is_door[i]) {  // a metal bar across the glass door
      mesh.AddBox({k.x0, y_glass - 0.06, 1.0}, {k.x1, y_glass - 0.01, 1.1}, m.metal);
    }
  }
}

/// Side walls, back wall, roof (flat at h inside a gable `gable` high); the interior floor is
/// the ground.
void AddCathedralShell(TriangleMesh& mesh, const CathedralOptions& o, double gable,
                       const CathedralMaterials& m) {
  const double w = 0.5 * o.width_m, h = o.height_m, d = o.depth_m;
  mesh.AddQuad({-w, d, 0}, {-w, 0, 0}, {-w, 0, h}, {-w, d, h}, m.side);
  mesh.AddQuad({w, 0, 0}, {w, d, 0}, {w, d, h}, {w, 0, h}, m.side);
  mesh.AddQuad({w, d, 0}, {-w, d, 0}, {-w, d, h}, {w, d, h}, m.side);
  mesh.AddTriangle({-w, 0, h}, {w, 0, h}, {0, 0, h + gable}, m.stone);
  mesh.AddTriangle({w, d, h}, {-w, d, h}, {0, d, h + gable}, m.side);
  mesh.AddQuad({-w, 0, h}, {0, 0, h + gable}, {0, d, h + gable}, {-w, d, h}, m.roof);
  mesh.AddQuad({w, 0, h}, {w, d, h}, {0, d, h + gable}, {0, 0, h + gable}, m.roof);
}

/// Buttresses between bays and at the corners (stepped twice) and three steps before the door.
void AddButtressesAndSteps(TriangleMesh& mesh, const CathedralOptions& o, const Hole& door,
                           const CathedralMaterials& m) {
  const double w = 0.5 * o.width_m, h = o.height_m;
  const double bay_w = o.width_m / o.bays;
  for (int b = 0; b <= o.bays; ++b) {
    const double x = -w + b * bay_w;
    const double bw = 0.45;
    const double x0 = std::max(-w, x - bw), x1 = std::min(w, x + bw);
    mesh.AddBox({x0, -1.2, 0}, {x1, 0, 0.45 * h}, m.stone, true);
    mesh.AddBox({x0 + 0.05, -0.7, 0.45 * h}, {x1 - 0.05, 0, 0.8 * h}, m.stone, true);
  }
  for (int k = 0; k < 3; ++k) {
    mesh.AddBox({door.x0 - 1.0 + 0.3 * k, -2.4 + 0.8 * k, 0}, {door.x1 + 1.0 - 0.3 * k, 0, 0.15 * (k + 1)},
                m.trim, true);
  }
}

/// Relief blocks on the front wall, avoiding the openings and the buttresses: up to
/// `relief_blocks`, in at most 50 attempts each.
void AddFrontRelief(TriangleMesh& mesh, const CathedralOptions& o, const std::vector<Hole>& holes,
                    std::mt19937_64& rng, std::uniform_real_distribution<double>& unit,
                    int relief) {
  const double w = 0.5 * o.width_m, h = o.height_m;
  const double bay_w = o.width_m / o.bays;
  int placed = 0;
  for (int attempt = 0; attempt < 50 * o.relief_blocks && placed < o.relief_blocks; ++attempt) {
    const double sx = 0.15 + 0.6 * unit(rng), sz = 0.15 + 0.6 * unit(rng);
    const double x0 = -w + unit(rng) * (o.width_m - sx), z0 = 0.5 + unit(rng) * (h - 0.6 - sz);
    bool free = true;
    for (const Hole& k : holes) {
      if (Overlaps(x0, x0 + sx, k.x0 - 0.1, k.x1 + 0.1) && Overlaps(z0, z0 + sz, k.z0 - 0.1, k.z1 + 0.1)) free = false;
    }
    for (int b = 0; b <= o.bays && free; ++b) {
      const double x = -w + b * bay_w;
      if (Overlaps(x0, x0 + sx, x - 0.5, x + 0.5)) free = false;
    }
    if (!free) continue;
    const double depth = 0.05 + 0.25 * unit(rng);
    mesh.AddBox({x0, -depth, z0}, {x0 + sx, 0, z0 + sz}, relief);
    ++placed;
  }
}

/// Six marks on an arc in front; targets beside the openings and one in the gable.
void PlaceCathedralSurvey(SimScene* scene, const CathedralOptions& o, double gable) {
  const double w = 0.5 * o.width_m, h = o.height_m;
  const double bay_w = o.width_m / o.bays, storey_h = h / o.storeys;
  const double r = 1.4 * o.width_m;
  for (int i = 0; i < 6; ++i) {
    const double a = M_PI * (0.25 + 0.1 * i);
    scene->marks.push_back({"M" + std::to_string(i + 1),
                            Vector3d(-r * std::cos(a), -0.8 * r * std::sin(a) - 2.0, 0.0), "mark"});
  }
  std::vector<std::pair<double, double>> xz;
  for (int b = 0; b < o.bays; ++b) {
    const double x = -w + b * bay_w + 0.12 * bay_w;  // beside the openings
    xz.emplace_back(x, 0.2 * storey_h);
    xz.emplace_back(x, h - 0.3 * storey_h);
  }
  xz.emplace_back(0.0, h + 0.1 * gable);
  PlaceTargets(scene, xz, "T");
}

}  // namespace

SimScene MakeCathedralScene(const CathedralOptions& o, uint64_t seed) {
  SimScene scene;
  scene.name = "cathedral";
  TriangleMesh& mesh = scene.mesh;
  std::mt19937_64 rng(seed * 2654435761ull + 2);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const CathedralMaterials m = AddCathedralMaterials(mesh);

  const double g = o.ground_half_size_m, w = 0.5 * o.width_m, h = o.height_m, d = o.depth_m;
  const double wall_t = 0.6;  // thickness of the front wall
  mesh.AddQuad({-g, -g, 0}, {g, -g, 0}, {g, g, 0}, {-g, g, 0}, m.ground);
  const Openings openings = CathedralOpenings(o);
  AddFrontWall(mesh, o, openings, wall_t, m);
  const double gable = 0.3 * o.width_m;
  AddCathedralShell(mesh, o, gable, m);
  const Hole& door = openings.holes[static_cast<size_t>((o.bays / 2) * o.storeys)];
  AddButtressesAndSteps(mesh, o, door, m);
  // A round sculpted medallion in the gable (a fan standing out 0.25 m).
  const Vector3d centre(0, -0.25, h + 0.38 * gable);
  const double radius = std::min(0.25 * gable, 0.2 * o.width_m);
  for (int k = 0; k < 24; ++k) {
    const double a0 = 2 * M_PI * k / 24, a1 = 2 * M_PI * (k + 1) / 24;
    mesh.AddTriangle(centre, centre + radius * Vector3d(std::cos(a1), 0, std::sin(a1)),
                     centre + radius * Vector3d(std::cos(a0), 0, std::sin(a0)), m.relief);
  }
  AddFrontRelief(mesh, o, openings.holes, rng, unit, m.relief);
  scene.object_min = Vector3d(-w, -2.4, 0.0);
  scene.object_max = Vector3d(w, d, h + gable);
  PlaceCathedralSurvey(&scene, o, gable);
  return scene;
}

SimScene SceneFromMesh(TriangleMesh mesh, const std::string& name, uint64_t seed) {
  SimScene scene;
  scene.name = name;
  mesh.Bounds(&scene.object_min, &scene.object_max);
  scene.mesh = std::move(mesh);
  const Vector3d size = scene.object_max - scene.object_min;
  const Vector3d centre = 0.5 * (scene.object_min + scene.object_max);
  const double r = std::max(3.0, 1.2 * std::max(size.x(), size.z()));
  for (int i = 0; i < 5; ++i) {
    const double a = M_PI * (0.25 + 0.125 * i);
    scene.marks.push_back({"M" + std::to_string(i + 1),
                           Vector3d(centre.x() - r * std::cos(a),
                                    scene.object_min.y() - r * std::sin(a), scene.object_min.z()),
                           "mark"});
  }
  std::vector<std::pair<double, double>> xz;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 2; ++j) {
      xz.emplace_back(scene.object_min.x() + (0.2 + 0.3 * i) * size.x(),
                      scene.object_min.z() + (0.3 + 0.4 * j) * size.z());
    }
  }
  PlaceTargets(&scene, xz, "T");
  (void)seed;
  return scene;
}

}  // namespace mmba::sim
