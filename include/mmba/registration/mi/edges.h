#pragma once

// The geometric term of a LiDAR-to-camera registration, after Levinson & Thrun, "Automatic
// Online Calibration of Cameras and Lasers" (RSS 2013): LiDAR points at depth discontinuities
// (and at intensity edges) along each scan ring, weighted by the size of the discontinuity,
// scored against the image's edge map spread by an inverse distance transform. Several frames
// share one pose: their scores are summed (Levinson & Thrun's J_C = Σ_f Σ_p X_p^f D_{i,j}^f).

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"
#include "mmba/registration/mi/image.h"
#include "mmba/registration/mi/lidar_image.h"

namespace mmba::registration::mi {

struct Frame;

/// The geometric term's knobs (register-mi --set edge_*). Defaults: Levinson & Thrun's α, γ;
/// the LiDAR grid and thresholds physically motivated (bench/RESULTS.md "LiDAR edges").
struct EdgeOptions {
  /// Angular cell of the LiDAR's scan grid (azimuth × elevation about the LiDAR's origin, z
  /// up), deg: finer than the ring spacing of a 32–128-beam LiDAR (0.33–1°), about its
  /// azimuth step (0.1–0.2°), so a row of cells holds one ring.
  double cell_deg = 0.2;
  /// A point's ring neighbours are the nearest occupied cells of its row within this many
  /// cells on either side (a missing return in between is skipped).
  int neighbour_cells = 4;
  /// A depth edge: a neighbour farther by at least max(edge_min_jump_m, edge_jump_fraction ·
  /// range) — the near side of a discontinuity only, so a far point seen past a near edge is
  /// not an edge (occlusion).
  double min_jump_m = 0.3;
  double jump_fraction = 0.05;
  /// Intensity edges: points whose intensity differs from a ring neighbour on the same surface
  /// (depth within the jump threshold) by more than this quantile of all such differences.
  /// 1 = no intensity edges.
  double intensity_quantile = 0.95;
  /// Levinson & Thrun's D = α E + (1 − α) max_{x,y} E_{x,y} γ^{max(|x−i|,|y−j|)} (their α
  /// = 1/3, γ = 0.98 per pixel).
  double alpha = 1.0 / 3.0;
  double gamma = 0.98;
  /// Gaussian blur of the photo before its edges, px. A coarser level spreads and blurs the
  /// edge image by `level_blur_factor` per level (coarse to fine by blurring: EdgeLevelImage).
  double blur_px = 1.0;
  double level_blur_factor = 2.0;
  int levels = 2;
  bool Check(std::string* error) const;
};

/// One LiDAR edge point: where, its weight X (Levinson & Thrun: √depth jump in m^½ for a
/// depth edge, the intensity difference in 0..1 for an intensity edge) and its kind.
struct EdgePoint {
  Eigen::Vector3f point_in_lidar;
  float weight = 0;
  uint8_t kind = 0;  ///< 0 depth, 1 intensity
};

/// The edge points of one LiDAR sweep given in the LiDAR's own frame, its origin at `centre`
/// (z up): each point's ring neighbours in an azimuth × elevation grid of cell `cell_deg`
/// (the nearest point per cell; the farther ones are hidden behind it).
/// X_i = max(r_{i−1} − r_i, r_{i+1} − r_i, 0)^½ (Levinson & Thrun 2013, Sec. IV-A).
std::vector<EdgePoint> DetectLidarEdges(const LidarPoints& points, const Eigen::Vector3f& centre,
                                        const EdgeOptions& options);

/// DetectLidarEdges' points as a cloud (intensity 1), for drawing them (register-mi --overlay).
LidarPoints EdgeCloud(const LidarPoints& points, const EdgeOptions& options);

/// The photo's edge image E (each pixel's largest absolute difference to its 8 neighbours,
/// after a Gaussian blur of `blur_px`), spread by Levinson & Thrun's inverse distance
/// transform D = α E + (1 − α) max E γ^{Chebyshev distance} (two raster passes, exact for
/// the Chebyshev distance), then blurred by `smooth_px` (a coarse level; 0: none), divided by
/// its mean: 1 = an edge point's chance value.
GrayImage EdgeDistanceImage(const GrayImage& photo, double blur_px, double alpha, double gamma,
                            double smooth_px = 0);

/// The edge image of `level` (0 = finest): the photo blurred by blur_px; at a coarser level
/// γ^(1/s) and D blurred by blur_px · s, s = level_blur_factor^level (coarse to fine).
GrayImage EdgeLevelImage(const GrayImage& photo, const EdgeOptions& options, int level);

/// Levinson & Thrun's objective for a set of frames sharing one cam_from_lidar, coarse to fine.
/// Edge points are detected once per frame (about the LiDAR's origin, the cloud's frame origin)
/// and culled to those that project into a view at the start (plus a margin of the bounds);
/// a point projecting outside its view at a pose adds 0 (the sum is over a fixed set).
class EdgeMetric {
 public:
  EdgeMetric(const std::vector<Frame>& frames, const Rigid3d& cam_from_lidar_start,
             const EdgeOptions& options, double margin_deg);
  int levels() const { return static_cast<int>(images_.empty() ? 0 : images_[0].size()); }
  /// Σ over the frames' views of each kind's weighted mean of D at the points' projections,
  /// averaged over the kinds present, over the frames. Only points whose `part` bits masked
  /// by `mask` equal `value` count (mask 0: all).
  double Evaluate(const Rigid3d& cam_from_lidar, int level, uint8_t mask = 0,
                  uint8_t value = 0) const;
  size_t points(int kind) const;
  size_t frames() const { return frame_points_.size(); }
  /// The frame's edge points (for drawing).
  const std::vector<EdgePoint>& frame_points(size_t f) const { return frame_points_[f]; }
  /// The part bits of a point: 1 = right half of its view at the start, 2 = lower half,
  /// 4 = an odd frame.
  static constexpr uint8_t kRight = 1, kLower = 2, kOddFrame = 4;

 private:
  const std::vector<Frame>& frames_;
  std::vector<std::vector<EdgePoint>> frame_points_;
  std::vector<std::vector<uint8_t>> parts_;
  std::vector<std::vector<int>> view_of_;  ///< per point its view at the start
  std::vector<std::vector<GrayImage>> images_;  ///< [view over all frames][level]
  std::vector<size_t> first_view_;              ///< per frame its first view in images_
};

}  // namespace mmba::registration::mi
