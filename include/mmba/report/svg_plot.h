#pragma once

// Inline SVG plots and HTML helpers of the adjustment report (report.html). Every function
// returns a self-contained <svg> element (no script, no external asset, no font file) that a
// browser prints as it shows it. Every string put into a plot is HTML-escaped here.

#include <cstddef>
#include <string>
#include <vector>

namespace mmba::report {

/// Escapes & < > " ' for HTML text and attribute values (also inside SVG).
std::string HtmlEscape(const std::string& text);

/// `value` with `decimals` digits after the point, or "—" when it is NaN/±Inf.
std::string FormatFixed(double value, int decimals);

/// The "nice" step (1, 2 or 5 × 10^k) closest above `raw` > 0; 0 for raw <= 0 or not finite.
double NiceStep(double raw);

/// Counts of a histogram over [lower, upper) in equal bins. Values below `lower` are counted
/// in the first bin and values at or above `upper` in the last (and also in `below`/`above`),
/// so that Σ counts = the number of finite values; NaN/Inf are only counted in `non_finite`.
struct Histogram {
  double lower = 0.0;
  double upper = 1.0;
  std::vector<size_t> counts;
  size_t below = 0;       ///< finite values < lower (included in counts.front())
  size_t above = 0;       ///< finite values >= upper (included in counts.back())
  size_t non_finite = 0;  ///< NaN / ±Inf values (not in counts)
  size_t total() const;   ///< Σ counts
  double bin_width() const { return counts.empty() ? 0.0 : (upper - lower) / counts.size(); }
};

/// Bins `values` over [lower, upper) into `bins` >= 1 equal bins (see Histogram).
/// Throws std::invalid_argument when bins < 1 or !(lower < upper).
Histogram ComputeHistogram(const std::vector<double>& values, double lower, double upper,
                           int bins);

/// Reference density drawn over a histogram of whitened residuals.
enum class ReferenceDensity {
  kNone,
  kStandardNormal,  ///< whitened residual components: N(0, 1)
  kChi,             ///< norms |r|/σ of whitened k-vectors: χ distribution with k dof
};

/// Standard normal density φ(x).
double StandardNormalDensity(double x);
/// Density of the χ distribution with k >= 1 degrees of freedom (the norm of k independent
/// N(0,1) components): x^(k−1)·e^(−x²/2) / (2^(k/2−1)·Γ(k/2)) for x >= 0, 0 below
/// (k = 1: the half-normal 2φ(x); k = 2: Rayleigh).
double ChiDensity(double x, int k);

struct HistogramOptions {
  std::string title;                   ///< drawn above the plot (escaped)
  std::string x_label = "whitened residual r/σ";
  std::string y_label = "count";
  ReferenceDensity density = ReferenceDensity::kStandardNormal;
  int chi_dof = 1;                     ///< k of kChi, >= 1
  /// Range of the bins; when !(lower < upper) it is chosen from the data: ±max(4, ⌈q⌉)
  /// (at most ±10) for kStandardNormal/kNone, [0, max(4, ⌈q⌉)] for kChi, where q is the
  /// 99.9 % quantile of |value|.
  double lower = 0.0;
  double upper = 0.0;
  int bins = 0;                        ///< 0: Rice rule ⌈2·n^(1/3)⌉ clamped to [6, 48]
  int width_px = 520;
  int height_px = 250;
};

/// Histogram of `values` as an inline <svg>: bars, the reference density scaled to counts
/// (n · bin width · f(x)), labelled axes, and a note of values beyond the range (drawn in
/// the end bins) and of non-finite values. Empty input gives a plot saying "no values".
std::string SvgHistogram(const std::vector<double>& values, const HistogramOptions& options);

/// The histogram SvgHistogram draws for `values` and `options` (resolved range and bins).
Histogram ResolveHistogram(const std::vector<double>& values, const HistogramOptions& options);

/// One control or check point of the plan view; metres in the local ENU frame.
struct PlanPoint {
  std::string id;
  bool check = false;           ///< check point (withheld) or control point
  double east = 0.0, north = 0.0;
  double d_east = 0.0, d_north = 0.0;  ///< adjusted − surveyed; NaN: no vector drawn
  /// Error ellipse: semi-axes a >= b [m] and the azimuth of a from north towards east
  /// [degrees]; a NaN or <= 0: no ellipse drawn.
  double ellipse_a = 0.0, ellipse_b = 0.0, ellipse_azimuth_deg = 0.0;
  bool flagged = false;         ///< |d| > 3σ in some axis: drawn in red
};

struct PlanViewOptions {
  int width_px = 640;
  int height_px = 520;
  std::string ellipse_label = "standard error ellipse (1σ)";
};

/// Scales of a plan view: map metres → px, and the common magnification of error ellipses
/// and displacement vectors (px per metre of error).
struct PlanScales {
  double map_px_per_m = 0.0;
  double error_px_per_m = 0.0;
  double map_bar_m = 0.0;    ///< length of the map scale bar [m]
  double error_bar_m = 0.0;  ///< length of the error scale bar [m]
};

/// Plan (east right, north up) of control (triangles) and check points (circles) with
/// their error ellipses and displacement vectors drawn at a magnified error scale, with one
/// scale bar for the map and one for the errors. Points with non-finite E/N are left out.
std::string SvgPlanView(const std::vector<PlanPoint>& points, const PlanViewOptions& options,
                        PlanScales* scales = nullptr);

/// SVG rotation (degrees, clockwise on screen, from +x = east) of an ellipse whose major
/// axis has the azimuth `azimuth_deg` (from north towards east): azimuth − 90.
double SvgRotationFromAzimuth(double azimuth_deg);

/// Correction of one image pose by the adjustment.
struct PoseCorrectionPoint {
  std::string image;
  std::string sensor;
  double dx = 0.0, dy = 0.0, dz = 0.0;  ///< position correction components [m]; NaN: absent
  double position_m = 0.0;              ///< |position correction| [m]
  double rotation_deg = 0.0;            ///< rotation angle of the correction [degrees]
};

/// Position and rotation corrections per image (cf. Fig. 13 of Wang, Ferrie & Macfarlane
/// 2012): two panels over the image index, |Δposition| bars with the dx/dy/dz components as
/// markers, and |Δrotation| bars; bars coloured per sensor.
std::string SvgPoseCorrections(const std::vector<PoseCorrectionPoint>& poses, int width_px = 900);

}  // namespace mmba::report
