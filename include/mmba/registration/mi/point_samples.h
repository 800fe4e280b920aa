#pragma once

// Point-sample evaluation of the joint histogram with the visibility frozen at a reference
// pose. Sample-based mutual information (Viola & Wells 1997, Sec. 2.3; Pluim, Maintz &
// Viergever 2003, Sec. 3.2): the histogram is built from a fixed set of samples carried by
// the moving data, instead of re-rendering the whole LiDAR image at every pose.
//
// The z-buffer is rendered once at the reference pose; each covered pixel (c, r) becomes a
// sample of its winning point i with the integer offset (c, r) − floor(x_i(reference)). At a
// pose P the sample's photo value is taken bilinearly at x_i(P) + offset — at the reference
// pose exactly what JointHistogram::Add samples for the rendered image with the B-spline
// histogram (c + ½ + the winner's sub-pixel offset). Away from the reference the samples move
// with their points; what is not modelled is the change of the hidden-surface decision and
// of the footprint size, so callers rebuild the set when the pose has moved by more than
// about a pixel (ProbeDisplacementPx).

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"
#include "mmba/registration/mi/lidar_image.h"
#include "mmba/registration/mi/metric.h"

namespace mmba::registration::mi {

/// The samples of one view, grouped by their point (point-major, so one projection serves
/// the whole footprint).
struct ViewSamples {
  std::vector<Eigen::Vector3f> points_in_lidar;  ///< the points winning ≥ 1 pixel
  std::vector<float> value01;  ///< per point: intensity, or 1 (points); depth is per pose
  std::vector<uint32_t> sample_begin;  ///< per point, its samples [begin[j], begin[j + 1])
  std::vector<std::array<int8_t, 2>> sample_offset;  ///< pixel − floor(projection), (dc, dr)
  /// Per sample, the number of pixels it stands for: 1 when every pixel is a sample; when
  /// each point keeps one sample, its share of its block's pixels or its won pixel count
  /// (MakeViewSamples, PerPointPlacement).
  std::vector<float> sample_weight;
  /// A few points spread over the visible set and their pixels at the reference pose, to
  /// measure how far a pose has moved the image (ProbeDisplacementPx).
  std::vector<Eigen::Vector3f> probe_points;
  std::vector<Eigen::Vector2f> probe_pixels;
  size_t samples() const { return sample_offset.size(); }
  size_t points() const { return points_in_lidar.size(); }
};

/// Per-point samples (MakeViewSamples with `per_point`): where each visible point is
/// sampled and what it weighs.
///  - block_px > 0: the footprint decides visibility only. A point is sampled when it won
///    at least one pixel and is not behind the surface seen at the pixel of its own
///    projection (by more than depth_tolerance_m + depth_tolerance_fraction · that range:
///    a neighbour of the same surface covering it does not hide it). Its sample is at its own
///    projection, so that a point at an occlusion edge is not displaced by the footprints
///    around it. Its weight is the image area it stands for: the covered pixels of its
///    block_px × block_px block divided by the samples in that block. Over a block the
///    weights add up to the rendered histogram's pixels, as in the per-pixel metric of
///    Wang et al. (CVPRW 2012), but without the extra weight that a nearer point's
///    footprint wins where it spreads over a farther surface.
///  - block_px = 0: the pixel it won nearest its own projection, weighted by the number of
///    pixels it won (the rendered image's weights). Measured: the spread footprints at
///    occlusion edges bias the optimum (bench/RESULTS.md, "The footprint decides visibility
///    only").
struct PerPointPlacement {
  int block_px = 8;
  double depth_tolerance_m = 0.1;
  double depth_tolerance_fraction = 0.01;
};

/// Builds the samples from `rendered`, the LidarImage of `points` rendered for the view at
/// the reference pose (its z-buffer winners and their projections). `per_point`: each
/// visible point keeps one weighted sample, placed as `placement` says (the point-sample MI
/// of Viola & Wells; the footprint's neighbouring pixels are strongly correlated samples of
/// the same point); otherwise every covered pixel is a sample of weight 1 (at the reference
/// exactly the rendered histogram). At most `max_probes` probe points are kept.
ViewSamples MakeViewSamples(const LidarPoints& points, const LidarImage& rendered,
                            const RenderOptions& options, bool per_point,
                            const PerPointPlacement& placement = PerPointPlacement(),
                            int max_probes = 16);

/// For the points [point_begin, point_end) of `samples`: adds to `histogram` (B-spline,
/// overlap region) one sample per footprint pixel whose position under `cam_from_lidar` lies
/// inside the view: the point's LiDAR value (0..1) against the photo sampled bilinearly at
/// the point's projection + the sample's offset. Points that do not project (behind the
/// camera, out of range, outside the view) add nothing, as in the renderer.
void AccumulateViewSamples(const ViewSamples& samples, const View& view,
                           const Rigid3d& cam_from_lidar, const RenderOptions& options,
                           size_t point_begin, size_t point_end, JointHistogram* histogram);

/// Largest pixel displacement (pixels of the view) of the probe points between the
/// reference pose and `cam_from_lidar` (+infinity when a probe no longer projects; 0 when
/// there are no probes). Seam-aware for equirectangular views.
double ProbeDisplacementPx(const ViewSamples& samples, const View& view,
                           const Rigid3d& cam_from_lidar);

}  // namespace mmba::registration::mi
