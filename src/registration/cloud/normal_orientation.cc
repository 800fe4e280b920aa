#include "registration/cloud/normal_orientation.h"

#include <algorithm>
#include <cmath>
#include <queue>
#include <tuple>

#include "registration/cloud/pcl_backend.h"

namespace mmba::registration::internal {

size_t OrientConsistently(const std::vector<Eigen::Vector3d>& points, int k,
                          std::vector<Eigen::Vector3d>* normals) {
  std::vector<Eigen::Vector3d>& n = *normals;
  std::vector<size_t> valid;  // points with a normal; the graph is built on them alone
  for (size_t i = 0; i < points.size(); ++i) {
    if (n[i].allFinite()) valid.push_back(i);
  }
  if (valid.size() < 2 || k < 1) return 0;
  std::vector<Eigen::Vector3d> graph_points;
  graph_points.reserve(valid.size());
  for (size_t i : valid) graph_points.push_back(points[i]);
  const PointIndex index(graph_points);

  // The k-nearest-neighbour graph, made symmetric (an edge in either list joins both).
  std::vector<std::vector<int>> adjacent(valid.size());
  std::vector<int> nearest;
  std::vector<float> squared_distances;
  for (size_t a = 0; a < valid.size(); ++a) {
    index.KNearest(graph_points[a], k + 1, &nearest, &squared_distances);
    for (int b : nearest) {
      if (b == static_cast<int>(a)) continue;
      adjacent[a].push_back(b);
      adjacent[b].push_back(static_cast<int>(a));
    }
  }
  const auto cost = [&](int a, int b) {
    return 1.0 - std::abs(n[valid[a]].dot(n[valid[b]]));
  };

  // Prim's algorithm from the first point of each connected part; a point reached from its
  // tree parent is turned when it disagrees with it.
  std::vector<char> reached(valid.size(), 0), turned(valid.size(), 0);
  using Edge = std::tuple<double, int, int>;  // cost, parent, point
  std::priority_queue<Edge, std::vector<Edge>, std::greater<Edge>> queue;
  size_t total_turned = 0;
  std::vector<int> part;
  for (size_t seed = 0; seed < valid.size(); ++seed) {
    if (reached[seed]) continue;
    part.clear();
    reached[seed] = 1;
    part.push_back(static_cast<int>(seed));
    for (int b : adjacent[seed]) queue.emplace(cost(static_cast<int>(seed), b), static_cast<int>(seed), b);
    while (!queue.empty()) {
      const auto [c, parent, point] = queue.top();
      queue.pop();
      if (reached[point]) continue;
      reached[point] = 1;
      part.push_back(point);
      Eigen::Vector3d& normal = n[valid[point]];
      if (normal.dot(n[valid[parent]]) < 0.0) {
        normal = -normal;
        turned[point] = 1;
      }
      for (int b : adjacent[point]) {
        if (!reached[b]) queue.emplace(cost(point, b), point, b);
      }
    }
    // The part keeps the majority's input sign: when most of it was turned, turn it all back.
    const size_t part_turned =
        std::count_if(part.begin(), part.end(), [&](int p) { return turned[p] != 0; });
    const bool back = 2 * part_turned > part.size();
    for (int p : part) {
      if (back) n[valid[p]] = -n[valid[p]];
      if ((turned[p] != 0) != back) ++total_turned;
    }
  }
  return total_turned;
}

}  // namespace mmba::registration::internal
