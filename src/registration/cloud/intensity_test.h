#pragma once

// Intensity test: telling apart poses that the geometry cannot. A pseudo-symmetric structure
// (a gate turned by 180°, a facade shifted by one bay) fits a turned or shifted copy of a part
// almost as well as the right pose; what differs is the texture on it. Where both clouds carry
// a brightness — LiDAR reflectance, or the grey value of the colours of a photogrammetric
// cloud — the right pose puts bright source points onto bright target points, a wrong twin
// puts them onto unrelated ones.
//
// The two sensors' brightnesses need not be on one scale (reflectance in 0..1 or raw 16-bit
// counts, photo grey levels, an unknown exposure): each cloud's brightness is replaced by its
// rank in the cloud, and a pose is judged by the rank (Spearman) correlation of source and
// target brightness over its inliers — the monotone counterpart of the intensity/grey-level
// dependence that mutual-information registration of LiDAR to photographs relies on (Wang,
// Ferrie & Macfarlane, CVPRW 2012; Pandey et al., JFR 2015). Its magnitude is used: LiDAR
// reflectance in the near infrared can run against visible grey (vegetation).
//
// Two poses are compared by the difference of their |correlation|, with a delete-one-block
// jackknife standard error over the source blocks of the geometric ambiguity test (Efron &
// Stein 1981; neighbouring points share their brightness errors, so blocks, not points, are
// the independent samples).

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "mmba/io_cloud/point_cloud.h"

namespace mmba {
class PointIndex;
}  // namespace mmba

namespace mmba::registration::internal {

/// A cloud's brightness (intensity, else the BT.601 luma of its colours) as mid-ranks in
/// (0, 1); empty when the cloud has neither, a non-finite value, or one constant value.
std::vector<float> BrightnessRanks(const io::PointCloud& cloud);
/// The same ranks (among all the cloud's points), only at the points `at`, in that order.
std::vector<float> BrightnessRanks(const io::PointCloud& cloud, const std::vector<size_t>& at);

/// Per-block sums of (source rank x, target rank y) over a pose's inliers.
struct IntensityBlocks {
  struct Moments {
    double n = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  };
  std::vector<int64_t> keys;     ///< block key per entry, ascending
  std::vector<Moments> moments;  ///< one per key
  /// |rank correlation| over all blocks (0 with fewer than 30 inliers or no variance).
  double AbsCorrelation() const;
};

class IntensityAgreement {
 public:
  /// `fine_src`: the verification's source points (source frame); `block`: the block size in
  /// metres. Each cloud is searched through a stride sample of at most `max_points` points.
  IntensityAgreement(const io::PointCloud& source, const io::PointCloud& target,
                     const std::vector<Eigen::Vector3d>& fine_src, double block,
                     size_t max_points = 500000);
  ~IntensityAgreement();
  IntensityAgreement(const IntensityAgreement&) = delete;
  IntensityAgreement& operator=(const IntensityAgreement&) = delete;

  /// Both clouds carry a usable brightness.
  bool available() const { return available_; }

  /// The blocks of pose `target_from_source` over the fine source points marked `inlier`.
  IntensityBlocks Measure(const Eigen::Matrix4d& target_from_source,
                          const std::vector<bool>& inlier) const;

  /// Paired t statistic of |r_a| − |r_b| (positive: a agrees better), jackknifed over the
  /// union of the two poses' blocks and mapped to its normal equivalent (K − 1 degrees of
  /// freedom for K blocks); 0 with fewer than 3 blocks or a zero standard error.
  static double Significance(const IntensityBlocks& a, const IntensityBlocks& b);

 private:
  bool available_ = false;
  std::vector<float> fine_src_rank_;  ///< source brightness rank at each fine point
  std::vector<Eigen::Vector3d> fine_src_;
  std::vector<float> tgt_rank_;       ///< per point of the target sample
  std::unique_ptr<mmba::PointIndex> tgt_index_;
  double block_ = 1.0;
};

/// The geometric t joined by the intensity t: Stouffer's (t_g + t_i)/√2 of two independent z
/// statistics (Stouffer et al. 1949), used only where it exceeds t_g (the brightness can settle
/// a geometric tie in favour of the geometric best, never unsettle a pose the geometry
/// resolved).
double CombinedSignificance(double t_geometric, double t_intensity);

}  // namespace mmba::registration::internal
