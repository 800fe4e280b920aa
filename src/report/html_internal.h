#pragma once

// Shared pieces of report.html (adjust_report.h): typed access to the report JSON with errors
// that name the field by its path, number formatting, and one Render* function per section.
// Each section's unit renders one concept; adjust_report.cc puts the page together.

#include <array>
#include <cmath>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mmba/report/svg_plot.h"

namespace mmba::report::internal {

using nlohmann::json;

inline constexpr const char* kDash = "\xE2\x80\x94";
inline constexpr const char* kSigma = "\xCF\x83";

// ---- Typed access (json_access.cc); every error names the field by its path. -------------

/// "type value" of a JSON value, cut to 60 characters, for error messages.
std::string Describe(const json& value);
/// Throws std::invalid_argument "report JSON: field 'path': found …, expected …".
[[noreturn]] void Fail(const std::string& path, const std::string& found, const std::string& expected);
std::string Join(const std::string& path, const std::string& key);
std::string Index(const std::string& path, size_t i);
/// A present, non-null member (nullptr when absent or null).
const json* Member(const json& object, const std::string& key);
std::optional<std::string> OptString(const json& object, const std::string& key, const std::string& path);
std::string ReqString(const json& object, const std::string& key, const std::string& path);
/// A number; NaN when absent or null (JSON has no NaN: writers emit null).
double Num(const json& object, const std::string& key, const std::string& path);
std::optional<bool> OptBool(const json& object, const std::string& key, const std::string& path);
const json* OptObject(const json& object, const std::string& key, const std::string& path);
const json* OptArray(const json& object, const std::string& key, const std::string& path);
const json& ElementObject(const json& array, size_t i, const std::string& path);
/// An array of 3 numbers (null = NaN); nullopt when absent.
std::optional<std::array<double, 3>> OptVec3(const json& object, const std::string& key, const std::string& path);
std::vector<double> NumberArray(const json& object, const std::string& key, const std::string& path);

// ---- Formatting (json_access.cc). ---------------------------------------------------------

std::string Esc(const std::string& s);
/// A count with narrow spaces between thousands ("35 966"); "—" when not finite.
std::string Count(double value);
/// Significant digits ("%.Ng"), "—" when not finite.
std::string Sig(double value, int digits = 6);
/// Metres shown in millimetres.
std::string Mm(double metres, int decimals = 1);
std::string Td(const std::string& content);
std::string TdText(const std::string& escaped);
double Norm3(const std::array<double, 3>& v);
/// P(norm of k whitened components > t); k = 1 is the two-sided normal tail.
double ChiTail(double t, int k);

/// What every section needs besides the JSON: the folder the project's paths are relative to.
struct PageContext {
  std::string project_dir;  ///< report.json `project_dir`; empty: paths shown as given
  /// An absolute `path` relative to project_dir ("images/a.jpg", "../data/x"); without
  /// project_dir, its file name. Relative paths unchanged.
  std::string Path(const std::string& path) const;
  /// `text` with "<project_dir>/" removed and project_dir itself shown as ".".
  std::string Text(const std::string& text) const;
};

// ---- Sections, one unit each. ---------------------------------------------------------------

extern const char* const kCss;  // page_style.cc

// page_header.cc: title block, summary with the σ0/χ² tests, warnings.
void RenderHeader(const json& report, const std::string& project, const std::string& status,
                  const PageContext& context, std::ostringstream& html);
void RenderSummary(const json& report, const std::string& status, const PageContext& context,
                   std::ostringstream& html);
void RenderWarnings(const json& report, const PageContext& context, std::ostringstream& html);

// groups_section.cc
void RenderGroups(const json& groups, std::ostringstream& html);

// control_points_section.cc: control and check points against their surveyed coordinates.
/// Check-point RMSE: report.json `check_summary`, else computed from `control_points`.
struct CheckSummary {
  bool given = false;  ///< from check_summary (else computed from the table)
  double count = NAN;
  std::array<double, 3> rmse{NAN, NAN, NAN};
  double rmse_3d = NAN, expected_3d = NAN;
};
CheckSummary ReadCheckSummary(const json& report);
/// One entry of report.json `control_points`; the ellipse scaled to 95 % confidence.
struct ControlPoint {
  std::string id;
  bool check = false;
  std::array<double, 3> surveyed{NAN, NAN, NAN}, adjusted{NAN, NAN, NAN}, d{NAN, NAN, NAN}, sigma{NAN, NAN, NAN};
  double ellipse_a = NAN, ellipse_b = NAN, ellipse_azimuth_deg = NAN;  ///< 95 % confidence
  std::string flagged_axes;  ///< "E, U" when |d| > 3σ in those axes
};
std::vector<ControlPoint> ReadControlPoints(const json& report);
/// Factor from an ellipse of the given confidence (NaN: the standard 1σ ellipse) to the 95 %
/// one: k95 / sqrt(−2 ln(1 − p)), the χ²_2 quantile in closed form. Fails on p outside (0, 1).
double EllipseFactorTo95(double confidence, const std::string& path);
void RenderControlPoints(const json& report, std::ostringstream& html);

/// k with P(χ²_2 ≤ k²) = 0.95: the factor from the standard (1σ) error ellipse to the 95 %
/// confidence ellipse, sqrt(χ²_{2;0.95}) = sqrt(5.9915) (Mikhail & Ackermann 1976;
/// Ghilani 2017, ch. 19, error ellipses).
inline constexpr double k95Ellipse2d = 2.447747;
/// The same for a 3-D ellipsoid: sqrt(χ²_{3;0.95}) = sqrt(7.8147).
inline constexpr double k95Ellipsoid3d = 2.795483;
/// Two-sided 95 % normal quantile, for one coordinate (height).
inline constexpr double k95Normal = 1.959964;

// accuracy_section.cc: check-point accuracy (NSSDA / ASPRS).
void RenderAccuracy(const json& report, std::ostringstream& html);

// points_section.cc: report.json `points` and `relative_precision`.
void RenderAdjustedPoints(const json& report, std::ostringstream& html);
void RenderRelativePrecision(const json& report, std::ostringstream& html);

// observations_section.cc: report.json `observations` {file, total, critical_value, order, rows}.
void RenderObservations(const json& report, const PageContext& context, std::ostringstream& html);

// photo_images_section.cc: report.json `photo_measurements.images`.
void RenderPhotoImages(const json& report, const PageContext& context, std::ostringstream& html);

// settings_section.cc: report.json `crs`, `mmba`, `settings`, `files`.
void RenderCrsRow(const json& report, std::ostringstream& html);
void RenderCrs(const json& report, std::ostringstream& html);
void RenderSettings(const json& report, const PageContext& context, std::ostringstream& html);

// blunders_section.cc
void RenderBlunders(const json& report, std::ostringstream& html);

// images_section.cc
void RenderPoseCorrections(const json& report, std::ostringstream& html);

// sensors_section.cc
void RenderCalibrations(const json& report, std::ostringstream& html);
void RenderDenseClouds(const json& report, std::ostringstream& html);
void RenderMiRegistrations(const json& report, std::ostringstream& html);
void RenderFiles(const json& report, const PageContext& context, std::ostringstream& html);

}  // namespace mmba::report::internal
