// report.html: the change of each image pose by the adjustment.
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "report/html_internal.h"

namespace mmba::report::internal {
namespace {

std::vector<PoseCorrectionPoint> ReadPoseCorrections(const json& array) {
  std::vector<PoseCorrectionPoint> poses;
  for (size_t i = 0; i < array.size(); ++i) {
    const std::string path = Index("pose_corrections", i);
    const json& o = ElementObject(array, i, "pose_corrections");
    PoseCorrectionPoint p;
    p.image = ReqString(o, "image", path);
    p.sensor = OptString(o, "sensor", path).value_or("");
    p.dx = p.dy = p.dz = NAN;
    if (auto d = OptVec3(o, "d", path)) {
      p.dx = (*d)[0];
      p.dy = (*d)[1];
      p.dz = (*d)[2];
    }
    p.position_m = Num(o, "d_position_m", path);
    if (!std::isfinite(p.position_m)) p.position_m = Norm3({p.dx, p.dy, p.dz});
    p.rotation_deg = Num(o, "d_rotation_deg", path);
    poses.push_back(p);
  }
  return poses;
}

/// Per sensor: count, RMS and max of the position and rotation corrections.
void RenderPoseCorrectionStats(const std::vector<PoseCorrectionPoint>& poses,
                               std::ostringstream& html) {
  struct Stat {
    size_t n = 0, n_pos = 0, n_rot = 0;
    double sum_pos2 = 0, max_pos = 0, sum_rot2 = 0, max_rot = 0;
    std::string max_pos_image, max_rot_image;
  };
  std::vector<std::string> order;
  std::map<std::string, Stat> stats;
  for (const auto& p : poses) {
    if (!stats.count(p.sensor)) order.push_back(p.sensor);
    Stat& s = stats[p.sensor];
    ++s.n;
    if (std::isfinite(p.position_m)) {
      ++s.n_pos;
      s.sum_pos2 += p.position_m * p.position_m;
      if (std::abs(p.position_m) >= s.max_pos) {
        s.max_pos = std::abs(p.position_m);
        s.max_pos_image = p.image;
      }
    }
    if (std::isfinite(p.rotation_deg)) {
      ++s.n_rot;
      s.sum_rot2 += p.rotation_deg * p.rotation_deg;
      if (std::abs(p.rotation_deg) >= s.max_rot) {
        s.max_rot = std::abs(p.rotation_deg);
        s.max_rot_image = p.image;
      }
    }
  }
  html << "<table>\n<tr><th>sensor</th><th>images</th><th>RMS |&Delta;position| [mm]</th>"
          "<th>max [mm]</th><th>at image</th><th>RMS |&Delta;rotation| [&deg;]</th><th>max [&deg;]</th>"
          "<th>at image</th></tr>\n";
  for (const std::string& sensor : order) {
    const Stat& s = stats[sensor];
    const double rms_pos = s.n_pos > 0 ? std::sqrt(s.sum_pos2 / s.n_pos) : NAN;
    const double rms_rot = s.n_rot > 0 ? std::sqrt(s.sum_rot2 / s.n_rot) : NAN;
    html << "<tr>" << TdText(Esc(sensor)) << Td(Count(static_cast<double>(s.n))) << Td(Mm(rms_pos))
         << Td(s.n_pos ? Mm(s.max_pos) : kDash) << TdText(Esc(s.max_pos_image)) << Td(FormatFixed(rms_rot, 4))
         << Td(s.n_rot ? FormatFixed(s.max_rot, 4) : kDash) << TdText(Esc(s.max_rot_image)) << "</tr>\n";
  }
  html << "</table>\n";
}


}  // namespace

void RenderPoseCorrections(const json& report, std::ostringstream& html) {
  const json* array = OptArray(report, "pose_corrections", "");
  if (array == nullptr || array->empty()) return;
  const std::vector<PoseCorrectionPoint> poses = ReadPoseCorrections(*array);
  html << "<section id=\"poses\">\n<h2>Camera pose corrections</h2>\n";
  if (report.contains("photo_block") && report["photo_block"].is_object() &&
      report["photo_block"].contains("georeference") && report["photo_block"]["georeference"].is_string()) {
    html << "<p>Initial georeference of the photo block: " << Esc(report["photo_block"]["georeference"].get<std::string>())
         << ". The corrections below are from that initial pose.</p>\n";
  }
  RenderPoseCorrectionStats(poses, html);
  html << "<figure>\n" << SvgPoseCorrections(poses, 700)
       << "<figcaption>Change of each image's pose by the adjustment (cf. Fig. 13 of Wang, Ferrie "
          "&amp; Macfarlane 2012): bars |&Delta;position| and |&Delta;rotation|, markers the position "
          "components dx, dy, dz.</figcaption>\n</figure>\n";
  if (poses.size() <= 5000) {
    html << "<details><summary>All " << poses.size() << " images</summary>\n<table>\n<tr><th>image</th>"
            "<th>sensor</th><th>dx [mm]</th><th>dy [mm]</th><th>dz [mm]</th><th>|&Delta;position| [mm]</th>"
            "<th>|&Delta;rotation| [&deg;]</th></tr>\n";
    for (const auto& p : poses) {
      html << "<tr>" << TdText(Esc(p.image)) << TdText(Esc(p.sensor)) << Td(Mm(p.dx)) << Td(Mm(p.dy))
           << Td(Mm(p.dz)) << Td(Mm(p.position_m)) << Td(FormatFixed(p.rotation_deg, 4)) << "</tr>\n";
    }
    html << "</table>\n</details>\n";
  }
  html << "</section>\n";
}

}  // namespace mmba::report::internal
