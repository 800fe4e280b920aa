#pragma once

// Triangle meshes of the simulator: vertices in the world frame (east, north, up; metres),
// one material per triangle. Materials carry the class the sensors react to (diffuse, glass,
// reflective) and the parameters of a procedural albedo texture (texture.h).

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace mmba::sim {

/// How a surface answers light and laser pulses.
enum class MaterialClass : int {
  kDiffuse = 0,     ///< Lambertian
  kGlass = 1,       ///< mostly transmits; LiDAR passes through or returns a mirror ghost
  kReflective = 2,  ///< specular (polished metal, wet stone): LiDAR mirror ghosts
};

/// "diffuse", "glass", "reflective".
std::string MaterialClassName(MaterialClass material_class);

/// Procedural pattern of a material's albedo.
enum class TexturePattern : int {
  kNoise = 0,   ///< multi-octave value noise (plaster, concrete)
  kStone = 1,   ///< ashlar blocks with mortar joints plus noise
  kBrick = 2,   ///< running-bond bricks plus noise
  kWood = 3,    ///< streaks along one axis plus noise
};

struct Material {
  std::string name;
  MaterialClass material_class = MaterialClass::kDiffuse;
  TexturePattern pattern = TexturePattern::kNoise;
  double base_albedo = 0.6;    ///< mean albedo, 0..1
  double contrast = 0.35;      ///< amplitude of the texture, 0..1
  double scale_m = 0.5;        ///< block size of the pattern (stone course height etc.), metres
};

/// A triangle mesh with one material index per triangle.
struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;          ///< metres, world frame
  std::vector<Eigen::Vector3i> triangles;         ///< vertex indices, counter-clockwise
  std::vector<int> triangle_material;             ///< index into `materials`, one per triangle
  std::vector<Material> materials;

  size_t NumTriangles() const { return triangles.size(); }
  /// Adds a material and returns its index.
  int AddMaterial(const Material& material);
  /// Adds a triangle (vertices appended).
  void AddTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                   int material);
  /// Adds a planar quad a-b-c-d (two triangles).
  void AddQuad(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
               const Eigen::Vector3d& d, int material);
  /// Adds an axis-aligned box [min, max] with outward faces; `skip_bottom` omits the face
  /// at min.z (boxes standing on the ground).
  void AddBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max, int material,
              bool skip_bottom = false);
  /// Appends another mesh (its materials appended too).
  void Append(const TriangleMesh& other);

  /// Unit normal of a triangle (right-hand rule a→b→c).
  Eigen::Vector3d TriangleNormal(size_t triangle) const;
  double TriangleArea(size_t triangle) const;
  /// Axis-aligned bounds of the vertices.
  void Bounds(Eigen::Vector3d* min, Eigen::Vector3d* max) const;
  /// Throws InputError(`where`, ...) if the mesh is empty, has an index out of range, a
  /// non-finite vertex or a material index out of range.
  void Validate(const std::string& where) const;
};

/// Loads a mesh from OBJ (v / f, polygons fanned, `usemtl` names mapped to materials whose
/// class is guessed from the name: "glass*", "mirror*|metal*|reflective*") or PLY (ASCII or
/// binary little endian; vertex x, y, z as float or double; face vertex_indices as a list).
/// Every triangle gets `default_material` unless the OBJ names one. Throws InputError.
TriangleMesh LoadMesh(const std::string& path, const Material& default_material);

/// Writes the mesh as OBJ with one `usemtl <material name>` group per material
/// (atomically). LoadMesh reads it back with the same triangles and material names.
void WriteObj(const TriangleMesh& mesh, const std::string& path);

}  // namespace mmba::sim
