#include "mmba/sim/mesh.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

#include "mmba/core/atomic_file.h"
#include "mmba/core/error.h"
#include "mmba/io/text_reader.h"

namespace mmba::sim {

std::string MaterialClassName(MaterialClass material_class) {
  switch (material_class) {
    case MaterialClass::kDiffuse: return "diffuse";
    case MaterialClass::kGlass: return "glass";
    case MaterialClass::kReflective: return "reflective";
  }
  return "diffuse";
}

int TriangleMesh::AddMaterial(const Material& material) {
  materials.push_back(material);
  return static_cast<int>(materials.size()) - 1;
}

void TriangleMesh::AddTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                               const Eigen::Vector3d& c, int material) {
  const int base = static_cast<int>(vertices.size());
  vertices.push_back(a);
  vertices.push_back(b);
  vertices.push_back(c);
  triangles.emplace_back(base, base + 1, base + 2);
  triangle_material.push_back(material);
}

void TriangleMesh::AddQuad(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                           const Eigen::Vector3d& c, const Eigen::Vector3d& d, int material) {
  const int base = static_cast<int>(vertices.size());
  vertices.push_back(a);
  vertices.push_back(b);
  vertices.push_back(c);
  vertices.push_back(d);
  triangles.emplace_back(base, base + 1, base + 2);
  triangles.emplace_back(base, base + 2, base + 3);
  triangle_material.push_back(material);
  triangle_material.push_back(material);
}

void TriangleMesh::AddBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int material,
                          bool skip_bottom) {
  const auto p = [&](int ix, int iy, int iz) {
    return Eigen::Vector3d(ix ? hi.x() : lo.x(), iy ? hi.y() : lo.y(), iz ? hi.z() : lo.z());
  };
  // Counter-clockwise seen from outside.
  AddQuad(p(0, 0, 0), p(1, 0, 0), p(1, 0, 1), p(0, 0, 1), material);  // -y
  AddQuad(p(1, 1, 0), p(0, 1, 0), p(0, 1, 1), p(1, 1, 1), material);  // +y
  AddQuad(p(0, 1, 0), p(0, 0, 0), p(0, 0, 1), p(0, 1, 1), material);  // -x
  AddQuad(p(1, 0, 0), p(1, 1, 0), p(1, 1, 1), p(1, 0, 1), material);  // +x
  AddQuad(p(0, 0, 1), p(1, 0, 1), p(1, 1, 1), p(0, 1, 1), material);  // +z
  if (!skip_bottom) AddQuad(p(0, 1, 0), p(1, 1, 0), p(1, 0, 0), p(0, 0, 0), material);  // -z
}

void TriangleMesh::Append(const TriangleMesh& other) {
  const int vertex_offset = static_cast<int>(vertices.size());
  const int material_offset = static_cast<int>(materials.size());
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  for (const auto& t : other.triangles) {
    triangles.push_back(t + Eigen::Vector3i::Constant(vertex_offset));
  }
  for (int m : other.triangle_material) triangle_material.push_back(m + material_offset);
  materials.insert(materials.end(), other.materials.begin(), other.materials.end());
}

Eigen::Vector3d TriangleMesh::TriangleNormal(size_t triangle) const {
  const Eigen::Vector3i& t = triangles[triangle];
  return (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]).normalized();
}

double TriangleMesh::TriangleArea(size_t triangle) const {
  const Eigen::Vector3i& t = triangles[triangle];
  return 0.5 * (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]).norm();
}

void TriangleMesh::Bounds(Eigen::Vector3d* min, Eigen::Vector3d* max) const {
  *min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  *max = -*min;
  for (const auto& v : vertices) {
    *min = min->cwiseMin(v);
    *max = max->cwiseMax(v);
  }
}

void TriangleMesh::Validate(const std::string& where) const {
  if (triangles.empty()) {
    throw InputError::Message(where, "the mesh has no triangles (expected at least one)");
  }
  if (triangle_material.size() != triangles.size()) {
    throw InputError::Message(where, "one material index per triangle expected");
  }
  for (size_t i = 0; i < vertices.size(); ++i) {
    if (!vertices[i].allFinite()) {
      throw InputError(where, 0, "vertex " + std::to_string(i), "a non-finite coordinate",
                       "finite x, y, z");
    }
  }
  const int num_vertices = static_cast<int>(vertices.size());
  for (size_t i = 0; i < triangles.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      if (triangles[i][k] < 0 || triangles[i][k] >= num_vertices) {
        throw InputError(where, 0, "face " + std::to_string(i),
                         "vertex index " + std::to_string(triangles[i][k]),
                         "an index in [0, " + std::to_string(num_vertices) + ")");
      }
    }
    if (triangle_material[i] < 0 || triangle_material[i] >= static_cast<int>(materials.size())) {
      throw InputError(where, 0, "face " + std::to_string(i), "material index out of range",
                       "a defined material");
    }
  }
}

namespace {

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

Material MaterialFromName(const std::string& name, const Material& fallback) {
  Material material = fallback;
  material.name = name;
  const std::string lower = Lower(name);
  if (lower.rfind("glass", 0) == 0 || lower.find("window") != std::string::npos) {
    material.material_class = MaterialClass::kGlass;
    material.base_albedo = 0.15;
  } else if (lower.rfind("mirror", 0) == 0 || lower.rfind("metal", 0) == 0 ||
             lower.rfind("reflective", 0) == 0) {
    material.material_class = MaterialClass::kReflective;
  }
  return material;
}

int ParseObjIndex(const std::string& token, int num_vertices, const std::string& path,
                  int64_t line) {
  const std::string head = token.substr(0, token.find('/'));
  char* end = nullptr;
  const long value = std::strtol(head.c_str(), &end, 10);
  if (head.empty() || *end != '\0' || value == 0) {
    throw InputError(path, line, "face vertex", token,
                     "a non-zero integer vertex index (v, v/vt, v//vn or v/vt/vn)");
  }
  const long index = value > 0 ? value - 1 : num_vertices + value;
  if (index < 0 || index >= num_vertices) {
    throw InputError(path, line, "face vertex", std::to_string(value),
                     "an index of a vertex defined above (1.." + std::to_string(num_vertices) +
                         ")");
  }
  return static_cast<int>(index);
}

TriangleMesh LoadObj(const std::string& path, const Material& default_material) {
  const std::string text = io::ReadWholeFile(path);
  TriangleMesh mesh;
  std::map<std::string, int> material_index;
  int current = -1;
  std::istringstream stream(text);
  std::string raw;
  int64_t line = 0;
  while (std::getline(stream, raw)) {
    ++line;
    if (!raw.empty() && raw.back() == '\r') raw.pop_back();
    std::istringstream tokens(raw);
    std::string keyword;
    if (!(tokens >> keyword) || keyword[0] == '#') continue;
    if (keyword == "v") {
      Eigen::Vector3d v;
      std::string s[3];
      if (!(tokens >> s[0] >> s[1] >> s[2])) {
        throw InputError(path, line, "v", raw, "three coordinates 'v x y z'");
      }
      for (int k = 0; k < 3; ++k) {
        char* end = nullptr;
        v[k] = std::strtod(s[k].c_str(), &end);
        if (*end != '\0' || !std::isfinite(v[k])) {
          throw InputError(path, line, "v", s[k], "a finite number");
        }
      }
      mesh.vertices.push_back(v);
    } else if (keyword == "usemtl") {
      std::string name;
      tokens >> name;
      auto it = material_index.find(name);
      if (it == material_index.end()) {
        it = material_index.emplace(name, mesh.AddMaterial(MaterialFromName(name, default_material)))
                 .first;
      }
      current = it->second;
    } else if (keyword == "f") {
      std::vector<int> face;
      std::string token;
      while (tokens >> token) {
        face.push_back(ParseObjIndex(token, static_cast<int>(mesh.vertices.size()), path, line));
      }
      if (face.size() < 3) {
        throw InputError(path, line, "f", std::to_string(face.size()) + " vertices",
                         "at least 3");
      }
      if (current < 0) {
        current = mesh.AddMaterial(default_material);
        material_index.emplace(default_material.name, current);
      }
      for (size_t k = 1; k + 1 < face.size(); ++k) {
        mesh.triangles.emplace_back(face[0], face[k], face[k + 1]);
        mesh.triangle_material.push_back(current);
      }
    }
    // vt, vn, o, g, s, mtllib: not needed by the simulator.
  }
  return mesh;
}

// PLY: header, then vertex and face elements (other elements before/after are skipped only
// in ASCII files; binary files must hold vertex and face only, with known property types).
struct PlyProperty {
  std::string name;
  std::string type;          // scalar type, or the item type of a list
  std::string count_type;    // list count type ("" for scalars)
};
struct PlyElement {
  std::string name;
  int64_t count = 0;
  std::vector<PlyProperty> properties;
};

int PlyTypeSize(const std::string& type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "float" || type == "int32" ||
      type == "uint32" || type == "float32") return 4;
  if (type == "double" || type == "float64") return 8;
  return 0;
}

double ReadPlyBinary(const std::string& type, const char* p) {
  if (type == "char" || type == "int8") return static_cast<int8_t>(*p);
  if (type == "uchar" || type == "uint8") return static_cast<uint8_t>(*p);
  if (type == "short" || type == "int16") { int16_t v; std::memcpy(&v, p, 2); return v; }
  if (type == "ushort" || type == "uint16") { uint16_t v; std::memcpy(&v, p, 2); return v; }
  if (type == "int" || type == "int32") { int32_t v; std::memcpy(&v, p, 4); return v; }
  if (type == "uint" || type == "uint32") { uint32_t v; std::memcpy(&v, p, 4); return v; }
  if (type == "float" || type == "float32") { float v; std::memcpy(&v, p, 4); return v; }
  double v;
  std::memcpy(&v, p, 8);
  return v;
}

struct PlyHeader {
  std::string format;  // "ascii" or "binary_little_endian"
  std::vector<PlyElement> elements;
  size_t body = 0;     // offset of the first byte after the end_header line
};

PlyHeader ReadPlyHeader(const std::string& path, const std::string& data) {
  if (data.rfind("ply", 0) != 0) {
    throw InputError(path, 1, "magic", data.substr(0, 3), "'ply'");
  }
  const size_t header_end = data.find("end_header");
  if (header_end == std::string::npos) {
    throw InputError::Message(path, "no 'end_header' line in the PLY header");
  }
  std::istringstream header(data.substr(0, header_end));
  std::string raw;
  PlyHeader h;
  int64_t line = 0;
  while (std::getline(header, raw)) {
    ++line;
    std::istringstream tokens(raw);
    std::string keyword;
    if (!(tokens >> keyword)) continue;
    if (keyword == "format") {
      tokens >> h.format;
      if (h.format != "ascii" && h.format != "binary_little_endian") {
        throw InputError(path, line, "format", h.format,
                         "ascii or binary_little_endian");
      }
    } else if (keyword == "element") {
      PlyElement element;
      tokens >> element.name >> element.count;
      if (element.count < 0) {
        throw InputError(path, line, "element count", std::to_string(element.count), ">= 0");
      }
      h.elements.push_back(element);
    } else if (keyword == "property") {
      if (h.elements.empty()) {
        throw InputError(path, line, "property", raw, "a property after an element");
      }
      PlyProperty property;
      std::string type;
      tokens >> type;
      if (type == "list") {
        tokens >> property.count_type >> property.type >> property.name;
      } else {
        property.type = type;
        tokens >> property.name;
      }
      if (PlyTypeSize(property.type) == 0 ||
          (!property.count_type.empty() && PlyTypeSize(property.count_type) == 0)) {
        throw InputError(path, line, "property type", raw, "a PLY scalar type");
      }
      h.elements.back().properties.push_back(property);
    }
  }
  const size_t pos = data.find('\n', header_end);
  h.body = pos == std::string::npos ? data.size() : pos + 1;
  return h;
}

/// Reads the values of a PLY body in order, ASCII tokens or little-endian binary.
class PlyValueReader {
 public:
  PlyValueReader(const std::string& path, const std::string& data, const PlyHeader& header)
      : path_(path), data_(data), ascii_format_(header.format == "ascii"), pos_(header.body),
        ascii_(ascii_format_ ? data.substr(header.body) : std::string()) {}

  /// The next value, of PLY type `type`, of property `property` of record `i` of `element`.
  double Read(const std::string& type, const PlyElement& element, int64_t i,
              const PlyProperty& property) {
    if (ascii_format_) {
      std::string token;
      if (!(ascii_ >> token)) {
        throw InputError(path_, 0, element.name + " " + std::to_string(i),
                         "end of file", "a value of property '" + property.name + "'");
      }
      char* end = nullptr;
      const double value = std::strtod(token.c_str(), &end);
      if (*end != '\0') {
        throw InputError(path_, 0, element.name + " " + std::to_string(i),
                         token, "a number for '" + property.name + "'");
      }
      return value;
    }
    const int size = PlyTypeSize(type);
    if (pos_ + size > data_.size()) {
      throw InputError::AtByte(path_, pos_, element.name + " " + std::to_string(i),
                               "end of file", "more binary data");
    }
    const double value = ReadPlyBinary(type, data_.data() + pos_);
    pos_ += size;
    return value;
  }

 private:
  const std::string& path_;
  const std::string& data_;
  bool ascii_format_;
  size_t pos_;
  std::istringstream ascii_;
};

/// Record `i` of `element`: a vertex (x, y, z) or a face (fanned into triangles).
void ReadPlyRecord(const PlyElement& element, int64_t i, int material, PlyValueReader& reader,
                   const std::string& path, TriangleMesh* mesh) {
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  std::vector<int> face;
  for (const PlyProperty& property : element.properties) {
    if (!property.count_type.empty()) {
      const double count = reader.Read(property.count_type, element, i, property);
      for (int k = 0; k < static_cast<int>(count); ++k) {
        const double index = reader.Read(property.type, element, i, property);
        if (element.name == "face") face.push_back(static_cast<int>(index));
      }
    } else {
      const double value = reader.Read(property.type, element, i, property);
      if (element.name == "vertex") {
        if (property.name == "x") v.x() = value;
        if (property.name == "y") v.y() = value;
        if (property.name == "z") v.z() = value;
      }
    }
  }
  if (element.name == "vertex") {
    mesh->vertices.push_back(v);
  } else if (element.name == "face") {
    if (face.size() < 3) {
      throw InputError(path, 0, "face " + std::to_string(i),
                       std::to_string(face.size()) + " vertices", "at least 3");
    }
    for (size_t k = 1; k + 1 < face.size(); ++k) {
      mesh->triangles.emplace_back(face[0], face[k], face[k + 1]);
      mesh->triangle_material.push_back(material);
    }
  }
}

TriangleMesh LoadPly(const std::string& path, const Material& default_material) {
  const std::string data = io::ReadWholeFile(path);
  const PlyHeader header = ReadPlyHeader(path, data);
  TriangleMesh mesh;
  const int material = mesh.AddMaterial(default_material);
  PlyValueReader reader(path, data, header);
  for (const PlyElement& element : header.elements) {
    for (int64_t i = 0; i < element.count; ++i) {
      ReadPlyRecord(element, i, material, reader, path, &mesh);
    }
  }
  return mesh;
}

}  // namespace

TriangleMesh LoadMesh(const std::string& path, const Material& default_material) {
  const std::string lower = Lower(path);
  TriangleMesh mesh;
  if (lower.size() >= 4 && lower.substr(lower.size() - 4) == ".obj") {
    mesh = LoadObj(path, default_material);
  } else if (lower.size() >= 4 && lower.substr(lower.size() - 4) == ".ply") {
    mesh = LoadPly(path, default_material);
  } else {
    throw InputError(path, 0, "mesh file extension", path, ".obj or .ply");
  }
  mesh.Validate(path);
  return mesh;
}

void WriteObj(const TriangleMesh& mesh, const std::string& path) {
  WriteFileAtomically(path, [&](std::ostream& out) {
    out << "# mmba simulated scene mesh: world frame (east, north, up), metres\n";
    out << std::setprecision(9);
    for (const auto& v : mesh.vertices) out << "v " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
    for (size_t m = 0; m < mesh.materials.size(); ++m) {
      bool any = false;
      for (size_t t = 0; t < mesh.triangles.size(); ++t) {
        if (mesh.triangle_material[t] != static_cast<int>(m)) continue;
        if (!any) out << "usemtl " << mesh.materials[m].name << '\n';
        any = true;
        const auto& f = mesh.triangles[t];
        out << "f " << f[0] + 1 << ' ' << f[1] + 1 << ' ' << f[2] + 1 << '\n';
      }
    }
  });
}

}  // namespace mmba::sim
