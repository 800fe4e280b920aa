// report.html: calibrations, dense clouds, MI registrations.
#include <cmath>
#include <string>

#include "report/html_internal.h"

namespace mmba::report::internal {

void RenderCalibrations(const json& report, std::ostringstream& html) {
  const json* array = OptArray(report, "calibrations", "");
  if (array == nullptr || array->empty()) return;
  html << "<section id=\"calibrations\">\n<h2>Calibrations</h2>\n";
  for (size_t i = 0; i < array->size(); ++i) {
    const std::string path = Index("calibrations", i);
    const json& c = ElementObject(*array, i, "calibrations");
    html << "<h3>" << Esc(ReqString(c, "name", path)) << "</h3>\n";
    const json* parameters = OptArray(c, "parameters", path);
    if (parameters == nullptr || parameters->empty()) {
      html << "<p class=\"note\">No parameters listed.</p>\n";
      continue;
    }
    html << "<table>\n<tr><th>parameter</th><th>initial</th><th>adjusted</th><th>change</th><th>"
         << kSigma << "</th><th>|change|/" << kSigma << "</th></tr>\n";
    const std::string ppath = Join(path, "parameters");
    for (size_t j = 0; j < parameters->size(); ++j) {
      const json& p = ElementObject(*parameters, j, ppath);
      const std::string epath = Index(ppath, j);
      const double initial = Num(p, "initial", epath);
      const double adjusted = Num(p, "adjusted", epath);
      const double sigma = Num(p, "sigma", epath);
      const double change = adjusted - initial;
      html << "<tr>" << TdText(Esc(ReqString(p, "name", epath))) << Td(Sig(initial, 8))
           << Td(Sig(adjusted, 8)) << Td(Sig(change, 4)) << Td(Sig(sigma, 3))
           << Td(sigma > 0.0 ? FormatFixed(std::abs(change) / sigma, 1) : kDash) << "</tr>\n";
    }
    html << "</table>\n";
  }
  html << "</section>\n";
}

void RenderDenseClouds(const json& report, std::ostringstream& html) {
  const json* array = OptArray(report, "spherical_dense", "");
  if (array == nullptr || array->empty()) return;
  html << "<section id=\"dense\">\n<h2>Dense clouds of the spherical stations</h2>\n"
       << "<p class=\"note\">Vertical-baseline stereo of each adjusted pair; " << kSigma
       << " of a point's range from 0.5 px of disparity. The distance to the LiDAR surface is taken "
          "where the two overlap.</p>\n<table>\n<tr><th>station</th><th>points</th><th>median range (m)</th><th>median "
       << kSigma << " range (m)</th><th>on the LiDAR surface</th><th>median |distance| (m)</th><th>median |distance|/"
       << kSigma << "</th></tr>\n";
  for (size_t i = 0; i < array->size(); ++i) {
    const std::string path = Index("spherical_dense", i);
    const json& d = ElementObject(*array, i, "spherical_dense");
    const std::string station = Esc(ReqString(d, "station", path));
    const std::string status = ReqString(d, "status", path);
    if (status != "ok") {
      html << "<tr>" << TdText(station) << "<td colspan=\"6\">" << Esc(status) << "</td></tr>\n";
      continue;
    }
    const double compared = Num(d, "lidar_compared", path);
    html << "<tr>" << TdText(station) << Td(FormatFixed(Num(d, "points", path), 0))
         << Td(FormatFixed(Num(d, "median_range_m", path), 2)) << Td(FormatFixed(Num(d, "median_range_sigma_m", path), 3))
         << Td(std::isnan(compared) ? kDash : FormatFixed(compared, 0))
         << Td(FormatFixed(Num(d, "median_abs_distance_to_lidar_m", path), 3))
         << Td(FormatFixed(Num(d, "median_abs_distance_over_sigma", path), 2)) << "</tr>\n";
  }
  html << "</table>\n</section>\n";
}

void RenderMiRegistrations(const json& report, std::ostringstream& html) {
  const json* array = OptArray(report, "mi_registration", "");
  if (array == nullptr || array->empty()) return;
  html << "<section id=\"mi\">\n<h2>MI registration of the images to the LiDAR</h2>\n"
       << "<p class=\"note\">Each image registered to the LiDAR by mutual information (Wang, Ferrie "
          "&amp; Macfarlane 2012) from its initial pose: the correction found, the pixel "
       << kSigma << " of its calibrated covariance, and for an &ldquo;ok&rdquo; (used as a weighted pose "
          "prior) how far the adjustment ended from it. Against the mobile LiDAR the rig's panoramas are registered "
          "jointly (the rig calibration: one rig_from_lidar for all frames, each frame &ldquo;used&rdquo; or "
          "&ldquo;rejected&rdquo; by its own screening registration).</p>\n<table>\n<tr><th>image</th><th>kind</th><th>LiDAR</th><th>status</th>"
          "<th>|t| [mm]</th><th>roll [&deg;]</th><th>pitch [&deg;]</th><th>yaw [&deg;]</th><th>"
       << kSigma << " [px]</th><th>adjusted &minus; MI [mm]</th><th>[&deg;]</th><th>time [s]</th><th>reason</th></tr>\n";
  for (size_t i = 0; i < array->size(); ++i) {
    const std::string path = Index("mi_registration", i);
    const json& m = ElementObject(*array, i, "mi_registration");
    const std::string status = ReqString(m, "status", path);
    double t = NAN, roll = NAN, pitch = NAN, yaw = NAN;
    if (m.contains("correction") && m["correction"].is_object()) {
      const json& c = m["correction"];
      const std::string cp = Join(path, "correction");
      t = Norm3({Num(c, "tx", cp), Num(c, "ty", cp), Num(c, "tz", cp)});
      roll = Num(c, "roll", cp);
      pitch = Num(c, "pitch", cp);
      yaw = Num(c, "yaw", cp);
    }
    const double dm = Num(m, "adjusted_minus_registered_m", path), dd = Num(m, "adjusted_minus_registered_deg", path);
    html << "<tr" << (status == "ok" || status == "used" ? "" : " class=\"flag\"") << ">" << TdText(Esc(ReqString(m, "image", path)))
         << TdText(Esc(OptString(m, "kind", path).value_or(""))) << TdText(Esc(OptString(m, "lidar", path).value_or("static")))
         << TdText(Esc(status)) << Td(Mm(t))
         << Td(FormatFixed(roll, 3)) << Td(FormatFixed(pitch, 3)) << Td(FormatFixed(yaw, 3))
         << Td(FormatFixed(Num(m, "sigma_px", path), 2)) << Td(std::isnan(dm) ? kDash : Mm(dm))
         << Td(std::isnan(dd) ? kDash : FormatFixed(dd, 3)) << Td(FormatFixed(Num(m, "runtime_seconds", path), 1))
         << TdText(Esc(OptString(m, "reason", path).value_or(""))) << "</tr>\n";
  }
  html << "</table>\n</section>\n";
}

}  // namespace mmba::report::internal
