// report.html: per-image statistics of a photo block — observations, RMS of the image
// residuals, σ of the projection centre and of the rotation.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "report/html_internal.h"

namespace mmba::report::internal {
namespace {

struct ImageRow {
  std::string image, file;
  double observations = NAN, rms_px = NAN;
  std::array<double, 3> centre{NAN, NAN, NAN}, sigma_centre{NAN, NAN, NAN}, sigma_rotation{NAN, NAN, NAN};
};

std::vector<ImageRow> ReadImages(const json& images, const std::string& base) {
  std::vector<ImageRow> rows;
  for (size_t i = 0; i < images.size(); ++i) {
    const json& o = ElementObject(images, i, base);
    const std::string path = Index(base, i);
    ImageRow r;
    r.image = ReqString(o, "image", path);
    r.file = OptString(o, "file", path).value_or("");
    r.observations = Num(o, "observations", path);
    r.rms_px = Num(o, "rms_px", path);
    if (auto v = OptVec3(o, "centre_m", path)) r.centre = *v;
    if (auto v = OptVec3(o, "sigma_centre_m", path)) r.sigma_centre = *v;
    if (auto v = OptVec3(o, "sigma_rotation_deg", path)) r.sigma_rotation = *v;
    rows.push_back(r);
  }
  return rows;
}

double Median(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

/// The table of one block's images (`key`.images).
void RenderImageBlock(const json& block, const std::string& key, const PageContext& context,
                      std::ostringstream& html) {
  const json& images = block["images"];
  if (images.empty()) return;
  const std::vector<ImageRow> rows = ReadImages(images, key + ".images");
  std::vector<double> rms, counts;
  for (const ImageRow& r : rows) {
    rms.push_back(r.rms_px);
    counts.push_back(r.observations);
  }
  const double median_rms = Median(rms), median_count = Median(counts);
  const std::string id = OptString(block, "id", key).value_or("photos");
  html << "<section id=\"images" << (key == "photo_measurements" ? "" : "-" + key) << "\">\n<h2>Images of the photo block " << Esc(id) << "</h2>\n<p>" << rows.size()
       << " images; median " << Count(median_count) << " image points and RMS " << FormatFixed(median_rms, 3)
       << " px per image. Rows in red: RMS above twice the median, or fewer than 6 image points.</p>\n";
  if (rows.size() > 40) html << "<details><summary>All " << rows.size() << " images</summary>\n";
  html << "<table>\n<tr><th rowspan=\"2\">image</th><th rowspan=\"2\">file</th><th rowspan=\"2\">image points</th>"
          "<th rowspan=\"2\">RMS [px]</th><th colspan=\"3\">" << kSigma << " centre [mm]</th><th colspan=\"3\">"
       << kSigma << " rotation [&deg;]</th></tr>\n<tr><th>E</th><th>N</th><th>U</th><th>x</th><th>y</th><th>z</th></tr>\n";
  for (const ImageRow& r : rows) {
    const bool flag = (std::isfinite(median_rms) && r.rms_px > 2.0 * median_rms) || r.observations < 6;
    html << "<tr" << (flag ? " class=\"flag\"" : "") << ">" << TdText(Esc(r.image))
         << TdText("<code>" + Esc(context.Path(r.file)) + "</code>") << Td(Count(r.observations))
         << Td(FormatFixed(r.rms_px, 3));
    for (int k = 0; k < 3; ++k) html << Td(Mm(r.sigma_centre[k]));
    for (int k = 0; k < 3; ++k) html << Td(FormatFixed(r.sigma_rotation[k], 4));
    html << "</tr>\n";
  }
  html << "</table>\n";
  if (rows.size() > 40) html << "</details>\n";
  html << "<p class=\"note\">RMS per image coordinate of the image residuals; " << kSigma
       << " from the covariance of the adjustment; rotation about the camera axes. The same rows in <code>"
       << Esc(id) << "_images.csv</code>.</p>\n</section>\n";
}

}  // namespace

void RenderPhotoImages(const json& report, const PageContext& context, std::ostringstream& html) {
  // photo_measurements.images; photo_block.images when it is the per-image array (it may be
  // the image count).
  for (const char* key : {"photo_measurements", "photo_block"}) {
    const json* block = OptObject(report, key, "");
    if (block == nullptr) continue;
    const json* images = Member(*block, "images");
    if (images != nullptr && images->is_array()) RenderImageBlock(*block, key, context, html);
  }
}

}  // namespace mmba::report::internal
