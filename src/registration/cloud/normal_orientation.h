#pragma once

// Orientation of estimated surface normals independent of the cloud's frame.

#include <vector>

#include <Eigen/Core>

namespace mmba::registration::internal {

/// Turns normals so that neighbouring ones agree: the sign is propagated along a minimum
/// spanning tree of the `k`-nearest-neighbour graph with edge cost 1 − |n_i·n_j|, so that it
/// crosses from one point to the next where the surface bends least (Hoppe, DeRose, Duchamp,
/// McDonald & Stuetzle, "Surface reconstruction from unorganized points", SIGGRAPH 1992,
/// Sec. 3.3). Each connected part of the graph keeps the sign that most of its normals had
/// on input. Normals oriented towards a cloud's frame origin are right for a scan in its own
/// frame; a cloud moved into another frame, its origin among or beside its surfaces, has
/// some of them turned against the rest. NaN normals are left as they are and take no part.
/// Returns the number of normals turned.
size_t OrientConsistently(const std::vector<Eigen::Vector3d>& points, int k,
                          std::vector<Eigen::Vector3d>* normals);

}  // namespace mmba::registration::internal
