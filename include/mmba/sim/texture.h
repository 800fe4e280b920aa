#pragma once

// Procedural albedo: a deterministic function of the world point, the surface normal, the
// material and the scene seed — so every sensor (camera, panorama, LiDAR intensity) sees the
// same texture, with blob- and corner-like structure at several scales for SIFT.

#include <cstdint>

#include <Eigen/Core>

#include "mmba/sim/mesh.h"

namespace mmba::sim {

/// Value noise in [0, 1] on the integer lattice (trilinear, smoothstep), hashed with `seed`.
double ValueNoise3(const Eigen::Vector3d& point, uint64_t seed);
/// Sum of `octaves` value noises with halving amplitude and doubling frequency, in [0, 1].
double FractalNoise3(const Eigen::Vector3d& point, int octaves, uint64_t seed);

/// Albedo in [0.02, 0.98] of `material` at `point_in_world` on a surface with unit
/// `normal`. Patterns are laid out in the plane of the surface (the two world axes most
/// orthogonal to the normal).
double Albedo(const Material& material, const Eigen::Vector3d& point_in_world,
              const Eigen::Vector3d& normal, uint64_t seed);

}  // namespace mmba::sim
