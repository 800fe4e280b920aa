#pragma once

// Similarity of a LiDAR image and a photo: mutual information (maximised, as Wang et al. 2012
// insist, Eq. (1)–(3)), normalised MI (Studholme et al. 1999) and the normalised information
// distance NID = 1 − MI/H(X,Y) (Li et al. 2004), from a joint histogram.

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "mmba/registration/mi/lidar_image.h"

namespace mmba::registration::mi {

enum class MetricKind { kMi, kNmi, kNid };
std::string MetricName(MetricKind kind);
/// The metric as reported (OUT.json, the console) from the value the search maximises: NID is
/// minimised, so the search maximises −NID and the report gives NID itself.
inline double ReportedMetric(MetricKind kind, double searched) {
  return kind == MetricKind::kNid ? -searched : searched;
}
bool ParseMetric(const std::string& name, MetricKind* kind);

/// How samples enter the joint histogram.
enum class Smoothing {
  kNone,     ///< one count per sample in its bin
  kParzen,   ///< histogram convolved with a Gaussian of `parzen_sigma_bins` (Parzen window)
  kBSpline,  ///< each sample spread over 4×4 bins with cubic B-spline weights of its
             ///< continuous values (Mattes et al. 2003), photo sampled bilinearly at the
             ///< point's sub-pixel position: smooth in the pose, used for gradients
};
std::string SmoothingName(Smoothing smoothing);
bool ParseSmoothing(const std::string& name, Smoothing* smoothing);

enum class Region {
  kWholeImage,  ///< every pixel of the views; pixels without LiDAR form their own LiDAR bin
                ///< (the paper's black background). Sample count fixed: no sample-size bias.
  kOverlap,     ///< only pixels covered by LiDAR (sample count varies with the pose)
};
std::string RegionName(Region region);
bool ParseRegion(const std::string& name, Region* region);

struct MetricOptions {
  MetricKind kind = MetricKind::kNmi;
  int bins = 64;  ///< per axis (paper: 256)
  Smoothing smoothing = Smoothing::kBSpline;
  double parzen_sigma_bins = 1.0;
  /// The overlap: measured better than the whole image (bench/RESULTS.md "64 histogram bins and
  /// the overlap region").
  Region region = Region::kOverlap;
  /// K > 1: the LiDAR values carry a surface class c in 0..K−1 as c + fraction (fraction
  /// in [0, 1): EncodeSurfaceClasses) and the metric is conditioned on it: Σ_c p(c)·metric_c,
  /// each metric_c from a joint histogram of class c's samples alone with the full `bins`,
  /// so that I(intensity; photo | class) is measured, not the MI of the classes' mixture
  /// (bench/RESULTS.md "Surface classes (opt-in)", "Orientation classes"). 1 = the plain metric
  /// (values in [0, 1]). At most kMaxLidarClasses.
  int lidar_classes = 1;
  bool Check(std::string* error) const;
};

/// Entropies in bits of one evaluation; `value` is the chosen metric oriented so that
/// LARGER IS BETTER (NID is reported as −NID in `value`, and as itself in `nid`).
struct MetricValue {
  double mi = 0;             ///< H(X) + H(Y) − H(X,Y), bits
  double nmi = 0;            ///< (H(X) + H(Y)) / H(X,Y), 1..2
  double nid = 1;            ///< 1 − MI / H(X,Y), 0..1, smaller is better
  double joint_entropy = 0;  ///< H(X,Y), bits
  double samples = 0;        ///< number of samples in the histogram
  double lidar_samples = 0;  ///< of which covered by LiDAR
  double value = 0;          ///< the metric chosen in the options, larger = better
};

/// Accumulates a joint histogram over one or more views (a frame's views share it).
class JointHistogram {
 public:
  explicit JointHistogram(const MetricOptions& options);
  void Clear();
  /// Adds every sample of one rendered view against its photo.
  void Add(const LidarImage& lidar, const GrayImage& photo);
  /// Add() of the B-spline histogram (the default smoothing; CHECKed) for a view rendered by
  /// RenderLidarZBuffer only: each covered pixel's winner read from the z-buffer, with the
  /// same arithmetic as RenderLidarImage + Add (the same sums, bit for bit) but without the
  /// per-pixel arrays. `render` must be the options the z-buffer was rendered with.
  void AddZBuffer(const LidarImage& lidar, const LidarPoints& points,
                  const RenderOptions& render, const GrayImage& photo);
  /// Adds samples given as pairs: LiDAR value in [0, 1] (negative = no LiDAR, counted only in
  /// whole-image mode) and photo grey level 0..255. Used for the shuffled-pairing baseline.
  void AddPairs(const std::vector<float>& lidar01, const std::vector<float>& photo255);
  void AddPairs(const float* lidar01, const float* photo255, size_t count);
  /// Adds the counts of another histogram with the same options (partial histograms filled
  /// on several threads).
  void Merge(const JointHistogram& other);
  MetricValue Evaluate() const;

  /// Whole-image mode from point samples: the pixels without LiDAR are not added one by one
  /// but as a complement. `padded` (bins + 3 values, the padded photo axis) is the photo
  /// histogram that the view's background and its samples' photo values make together at the
  /// samples' reference pose, and `pixels` the view's pixel count. Evaluate() then takes the
  /// background row as `padded` minus the photo histogram of the covered samples added: at
  /// the reference exactly the rendered background; at another pose what the samples' photo
  /// values no longer take, the background takes (the sample count stays the view's pixels,
  /// as when each pose is rendered). Background bins that the difference would make negative
  /// (photo values sampled off the pixel centres) count 0. CHECKs whole-image mode.
  void AddBackgroundComplement(const double* padded, double pixels);
  /// The padded photo histogram (bins + 3 values) of the samples without LiDAR added so far
  /// (whole-image mode), and of the LiDAR-covered samples (summed over the LiDAR axis).
  std::vector<double> PaddedEmptyPhoto() const { return empty_counts_; }
  std::vector<double> PaddedCoveredPhoto() const;

  /// Fast path of the point-sample evaluation (point_samples.cc), B-spline histogram of the
  /// overlap region only: one LiDAR-covered sample whose LiDAR bin weights were computed
  /// once for its point (bx = LiDAR bin, wx its four weights: LidarWeights) and whose photo
  /// value is `photo255` (0..255). Same sums as Add/AddPairs of the same values.
  [[gnu::always_inline]] void LidarWeights(float lidar01, int* bx, float wx[4]) const {
    int row = 0;
    const float pos = LidarPosition(lidar01, &row);
    const int local = pos <= 0.f ? 0 : (pos >= bins_ - 1 ? bins_ - 1 : static_cast<int>(pos));
    CubicBSplineWeights(pos - local, wx);
    *bx = row + local;
  }
  /// A LiDAR value's continuous bin position within its class (0 .. bins − 1) and the first
  /// padded row of its class's block in the histogram (`row`; 0 with one class). With
  /// lidar_classes = K > 1 the value is class + fraction (the class clamped to 0 .. K − 1).
  [[gnu::always_inline]] float LidarPosition(float value, int* row) const {
    const float scale = static_cast<float>(bins_ - 1);
    if (classes_ == 1) {
      *row = 0;
      return value * scale;
    }
    const int c = std::clamp(static_cast<int>(std::floor(value)), 0, classes_ - 1);
    *row = c * (bins_ + 3);
    return (value - static_cast<float>(c)) * scale;
  }
  int lidar_classes() const { return classes_; }
  int bins() const { return bins_; }
  /// `weight`: the number of samples this one stands for (1, or a point's footprint pixels).
  [[gnu::always_inline]] void AddCovered(int bx, const float wx[4], float photo255,
                                         float weight = 1.f) {
    AddCoveredBins(bx, wx, photo255, weight);
    AddCoveredCount(weight);
  }
  /// AddCovered in two parts for the inner loop: the 4×4 bins of one sample, and the sample
  /// count (any number of samples' weights at once: integer weights sum exactly, so the
  /// counts are the same as per sample, without a dependency through memory per sample).
  [[gnu::always_inline]] void AddCoveredBins(int bx, const float wx[4], float photo255,
                                             float weight) {
    const float pos = photo255 * photo_scale_;
    const int by = pos <= 0.f ? 0 : (pos >= bins_ - 1 ? bins_ - 1 : static_cast<int>(pos));
    float wy[4];
    CubicBSplineWeights(pos - by, wy);
    for (float& w : wy) w *= weight;
    double* base = &counts_[static_cast<size_t>(bx) * (bins_ + 3) + by];
    for (int i = 0; i < 4; ++i) {
      double* row = base + static_cast<size_t>(i) * (bins_ + 3);
      row[0] += wx[i] * wy[0];
      row[1] += wx[i] * wy[1];
      row[2] += wx[i] * wy[2];
      row[3] += wx[i] * wy[3];
    }
  }
  /// AddCoveredBins for `count` samples at once (count ≤ kBatch): sample k has the LiDAR bin
  /// bx[k], its weights wx[0..3][k], the photo value photo255[k] and the weight weight[k]. The
  /// photo bins and weights of all are computed first (a vectorisable loop), then the adds in
  /// the order k = 0, 1, …: the same sums as AddCoveredBins called for each in turn.
  static constexpr int kBatch = 256;
  void AddCoveredBatch(int count, const int* bx, const float (*wx)[kBatch],
                       const float* photo255, const float* weight);
  void AddCoveredCount(double weight) {
    total_ += weight;
    lidar_total_ += weight;
  }
  /// Cubic B-spline weights of the four bins base−1 .. base+2 for a fractional position t
  /// (Mattes et al. 2003, Eq. (4); Thévenaz & Unser 2000).
  [[gnu::always_inline]] static void CubicBSplineWeights(float t, float w[4]) {
    const float t2 = t * t, t3 = t2 * t;
    const float u = 1.f - t;
    w[0] = u * u * u * (1.f / 6.f);
    w[1] = (3.f * t3 - 6.f * t2 + 4.f) * (1.f / 6.f);
    w[2] = (-3.f * t3 + 3.f * t2 + 3.f * t + 1.f) * (1.f / 6.f);
    w[3] = t3 * (1.f / 6.f);
  }

 private:
  /// One sample's bins (continuous bin positions); the caller adds it to total_ and
  /// lidar_total_ (once for many samples: Add, AddPairs).
  /// `lidar_row`: the first padded row of the sample's class block (LidarPosition).
  void AddSample(int lidar_row, float lidar_pos, float photo_pos, bool lidar_empty);
  /// Add() for the B-spline histogram (the default), the same sums in fewer instructions.
  void AddBSpline(const LidarImage& lidar, const GrayImage& photo);
  void AddBSplineZBuffer(const LidarImage& lidar, const LidarPoints& points,
                         const LidarValueMap& value_of, const GrayImage& photo);
  /// The body of both: `pixels` says which pixels are covered, their value and where their
  /// point falls in the photo.
  template <typename Pixels>
  void AddBSplineChunks(const Pixels& pixels, int width, int height, const GrayImage& photo);
  /// The histogram without its padding (folded onto the edge bins): rows = the empty-LiDAR
  /// row first in whole-image mode (with the background complement), then each class's
  /// `bins` LiDAR rows; columns = the `bins` photo bins. Evaluate()'s first step.
  std::vector<double> FoldedJoint() const;
  MetricOptions options_;
  int bins_;
  int classes_ = 1;  ///< options_.lidar_classes
  /// LiDAR-covered samples: (bins+3)² bins with one bin of padding below and two above on
  /// both axes, so that the 4×4 B-spline footprint needs no clamping; Evaluate() folds the
  /// padding onto the edge bins (the same as clamping each contribution). With K classes, K
  /// such blocks one after the other along the LiDAR axis (rows c·(bins+3) ..).
  std::vector<double> counts_;
  std::vector<double> empty_counts_;  ///< photo histogram of samples without LiDAR (bins+3)
  /// AddBackgroundComplement's sums: the reference photo histogram (bins+3) and pixels.
  std::vector<double> background_;
  double background_pixels_ = 0;
  double total_ = 0;
  double lidar_total_ = 0;
  float photo_scale_ = 0;  ///< photo grey level → continuous bin
};

}  // namespace mmba::registration::mi
