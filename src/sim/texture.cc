#include "mmba/sim/texture.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace mmba::sim {
namespace {

// SplitMix64 finaliser: a well-mixed 64-bit hash of the lattice coordinates.
uint64_t Mix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

double LatticeValue(int64_t x, int64_t y, int64_t z, uint64_t seed) {
  uint64_t h = Mix(seed);
  h = Mix(h ^ static_cast<uint64_t>(x));
  h = Mix(h ^ static_cast<uint64_t>(y));
  h = Mix(h ^ static_cast<uint64_t>(z));
  return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0);
}

uint64_t Fnv1a(const std::string& text) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  return h;
}

double Smooth(double t) { return t * t * (3.0 - 2.0 * t); }

}  // namespace

double ValueNoise3(const Eigen::Vector3d& point, uint64_t seed) {
  const double fx = std::floor(point.x()), fy = std::floor(point.y()), fz = std::floor(point.z());
  const int64_t x0 = static_cast<int64_t>(fx), y0 = static_cast<int64_t>(fy),
                z0 = static_cast<int64_t>(fz);
  const double tx = Smooth(point.x() - fx), ty = Smooth(point.y() - fy),
               tz = Smooth(point.z() - fz);
  double c[2][2][2];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k) c[i][j][k] = LatticeValue(x0 + i, y0 + j, z0 + k, seed);
  const auto lerp = [](double a, double b, double t) { return a + (b - a) * t; };
  const double x00 = lerp(c[0][0][0], c[1][0][0], tx), x10 = lerp(c[0][1][0], c[1][1][0], tx);
  const double x01 = lerp(c[0][0][1], c[1][0][1], tx), x11 = lerp(c[0][1][1], c[1][1][1], tx);
  return lerp(lerp(x00, x10, ty), lerp(x01, x11, ty), tz);
}

double FractalNoise3(const Eigen::Vector3d& point, int octaves, uint64_t seed) {
  double sum = 0.0, amplitude = 1.0, norm = 0.0;
  Eigen::Vector3d p = point;
  for (int o = 0; o < octaves; ++o) {
    sum += amplitude * ValueNoise3(p, seed + 7919ull * o);
    norm += amplitude;
    amplitude *= 0.5;
    p *= 2.0;
  }
  return sum / norm;
}

double Albedo(const Material& material, const Eigen::Vector3d& point_in_world,
              const Eigen::Vector3d& normal, uint64_t seed) {
  // In-plane coordinates: u horizontal along the surface, v the remaining axis (up on walls).
  const Eigen::Vector3d a = normal.cwiseAbs();
  double u, v;
  if (a.z() >= a.x() && a.z() >= a.y()) {  // floor / roof
    u = point_in_world.x();
    v = point_in_world.y();
  } else if (a.x() >= a.y()) {  // wall facing east/west
    u = point_in_world.y();
    v = point_in_world.z();
  } else {  // wall facing north/south
    u = point_in_world.x();
    v = point_in_world.z();
  }
  const double s = std::max(material.scale_m, 1e-3);
  const uint64_t material_seed = seed * 1315423911ull + Fnv1a(material.name);
  // Fine grain at 1/8 of the block size, plus large stains.
  const double grain = FractalNoise3(point_in_world * (8.0 / s), 4, material_seed);
  const double stain = ValueNoise3(point_in_world * (0.7 / s), material_seed + 17);
  double pattern = 0.5;
  switch (material.pattern) {
    case TexturePattern::kNoise:
      pattern = 0.5 * grain + 0.5 * stain;
      break;
    case TexturePattern::kStone:
    case TexturePattern::kBrick: {
      const double course_h = material.pattern == TexturePattern::kBrick ? 0.5 * s : s;
      const double block_w = material.pattern == TexturePattern::kBrick ? s : 1.7 * s;
      const double joint = 0.06 * course_h + 0.01;
      const double row = std::floor(v / course_h);
      const double offset = (static_cast<int64_t>(row) % 2 == 0) ? 0.0 : 0.5 * block_w;
      const double col = std::floor((u + offset) / block_w);
      const double fu = (u + offset) - col * block_w;
      const double fv = v - row * course_h;
      const bool in_joint = fu < joint || fv < joint;
      // Each block its own shade (a lattice value per block), plus grain.
      const double block_shade = LatticeValue(static_cast<int64_t>(col),
                                              static_cast<int64_t>(row), 0, material_seed + 3);
      pattern = in_joint ? 0.08 : 0.25 + 0.45 * block_shade + 0.3 * grain;
      break;
    }
    case TexturePattern::kWood: {
      const double streak = 0.5 + 0.5 * std::sin(v * 4.0 * M_PI / s + 6.0 * grain);  // period s/2
      pattern = 0.6 * streak + 0.4 * grain;
      break;
    }
  }
  const double value = material.base_albedo + material.contrast * 2.0 * (pattern - 0.5);
  return std::clamp(value, 0.02, 0.98);
}

}  // namespace mmba::sim
