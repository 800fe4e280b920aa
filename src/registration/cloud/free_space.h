#pragma once

// Free space seen by a cloud's sensors: a spherical z-buffer (the first surface along each
// ray) per sensor position, for the visibility test of registration hypotheses. A point of
// the other cloud that a hypothesis puts in front of the first surface a sensor saw along its
// ray lies in space that sensor observed as empty: the hypothesis contradicts the data
// (the visibility consistency test of Huber & Hebert, "Fully automatic registration of
// multiple 3D data sets", Image and Vision Computing 21(7), 2003).

#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

namespace mmba::registration::internal {

class FreeSpace {
 public:
  /// `points` seen from `sensors` (same frame). Each sensor's angular cell is
  /// `cell_spacings` × `spacing` / the median range of the points from it, so a cell holds a
  /// few points at the typical range; queries take the nearest surface over the 3 × 3 cells
  /// around the ray (a gap between samples is not taken for free space).
  FreeSpace(const std::vector<Eigen::Vector3d>& points,
            const std::vector<Eigen::Vector3d>& sensors, double spacing,
            double cell_spacings = 3.0);

  bool empty() const { return views_.empty(); }

  /// True when `q` lies nearer to some sensor than the first surface along its ray by more
  /// than `margin` (the sensor saw through q). `*surface` (if given) is the index of the
  /// point that is the first surface in q's own cell, `*hit` where q's ray meets that
  /// surface (at that point's range).
  bool Violates(const Eigen::Vector3d& q, double margin, int* surface = nullptr,
                Eigen::Vector3d* hit = nullptr) const;

 private:
  struct View {
    Eigen::Vector3d origin;
    double cell = 0.0;
    std::unordered_map<uint64_t, std::pair<float, int>> first;  // cell → (range, point)
  };
  static bool Cell(const View& v, const Eigen::Vector3d& d, int* ring, int* column, int* columns);
  static uint64_t Key(int ring, int column) {
    return (static_cast<uint64_t>(static_cast<uint32_t>(ring)) << 32) |
           static_cast<uint32_t>(column);
  }
  std::vector<View> views_;
};

}  // namespace mmba::registration::internal
