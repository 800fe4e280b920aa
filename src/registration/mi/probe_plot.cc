// Probe output (Wang et al. 2012, Figs. 3 and 11): CSV and one PNG per parameter. OpenCV is
// used here only for drawing and PNG encoding.
#include <algorithm>
#include <filesystem>
#include <sstream>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "codecs/image_codecs.h"
#include "mmba/core/atomic_file.h"
#include "mmba/registration/mi/mi_registration.h"

namespace mmba::registration::mi {
namespace {

std::vector<uint8_t> PlotAxis(const std::vector<ProbeSample>& samples, int axis) {
  constexpr int kWidth = 640, kHeight = 400, kMargin = 50;
  cv::Mat canvas(kHeight, kWidth, CV_8UC3, cv::Scalar(255, 255, 255));
  std::vector<const ProbeSample*> s;
  for (const ProbeSample& p : samples) {
    if (p.axis == axis) s.push_back(&p);
  }
  if (s.size() < 2) return {};
  const double x0 = s.front()->offset, x1 = s.back()->offset;
  struct Curve {
    std::function<double(const MetricValue&)> get;
    cv::Scalar color;
    const char* name;
  };
  const Curve curves[3] = {
      {[](const MetricValue& m) { return m.mi; }, cv::Scalar(200, 0, 0), "MI"},
      {[](const MetricValue& m) { return m.nmi; }, cv::Scalar(0, 150, 0), "NMI"},
      {[](const MetricValue& m) { return m.joint_entropy; }, cv::Scalar(0, 0, 200), "H(X,Y)"}};
  cv::rectangle(canvas, cv::Point(kMargin, kMargin / 2),
                cv::Point(kWidth - kMargin / 2, kHeight - kMargin), cv::Scalar(0, 0, 0));
  const int zero_x = kMargin + static_cast<int>((0 - x0) / (x1 - x0) * (kWidth - 1.5 * kMargin));
  cv::line(canvas, cv::Point(zero_x, kMargin / 2), cv::Point(zero_x, kHeight - kMargin),
           cv::Scalar(180, 180, 180));
  for (int c = 0; c < 3; ++c) {
    double lo = 1e300, hi = -1e300;
    for (const ProbeSample* p : s) {
      lo = std::min(lo, curves[c].get(p->metric));
      hi = std::max(hi, curves[c].get(p->metric));
    }
    if (!(hi > lo)) hi = lo + 1;
    std::vector<cv::Point> points;
    for (const ProbeSample* p : s) {
      const double u = (p->offset - x0) / (x1 - x0);
      const double v = (curves[c].get(p->metric) - lo) / (hi - lo);
      points.emplace_back(kMargin + static_cast<int>(u * (kWidth - 1.5 * kMargin)),
                          kHeight - kMargin - static_cast<int>(v * (kHeight - 1.5 * kMargin)));
    }
    cv::polylines(canvas, points, false, curves[c].color, 2, cv::LINE_AA);
    std::ostringstream label;
    label.precision(4);
    label << curves[c].name << " [" << lo << ", " << hi << "]";
    cv::putText(canvas, label.str(), cv::Point(kMargin + 5, kMargin / 2 + 18 * (c + 1)),
                cv::FONT_HERSHEY_SIMPLEX, 0.45, curves[c].color, 1, cv::LINE_AA);
  }
  std::ostringstream axis_label;
  axis_label << ParameterName(axis) << (axis < 3 ? " offset (m)" : " offset (deg)") << "  "
             << x0 << " .. " << x1 << "  (each curve scaled to its range)";
  cv::putText(canvas, axis_label.str(), cv::Point(kMargin, kHeight - 18),
              cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  std::vector<uint8_t> png;
  codecs::EncodeImage(".png", canvas, &png);
  return png;
}

}  // namespace

void WriteProbe(const std::vector<ProbeSample>& samples, const std::string& dir) {
  AtomicFileSet files;
  const std::filesystem::path base(dir);
  files.Add(base / "probe.csv", [&](std::ostream& out) {
    out.precision(9);
    // offset_unit: metres for tx ty tz, degrees for roll pitch yaw (the correction's units).
    out << "parameter,offset,mi_bits,nmi,nid,joint_entropy_bits,samples,lidar_samples,offset_unit\n";
    for (const ProbeSample& s : samples) {
      out << ParameterName(s.axis) << "," << s.offset << "," << s.metric.mi << ","
          << s.metric.nmi << "," << s.metric.nid << "," << s.metric.joint_entropy << ","
          << s.metric.samples << "," << s.metric.lidar_samples << "," << (s.axis < 3 ? "m" : "deg") << "\n";
    }
  });
  for (int axis = 0; axis < 6; ++axis) {
    std::vector<uint8_t> png = PlotAxis(samples, axis);
    if (png.empty()) continue;
    files.Add(
        base / (std::string("probe_") + ParameterName(axis) + ".png"),
        [png](std::ostream& out) {
          out.write(reinterpret_cast<const char*>(png.data()),
                    static_cast<std::streamsize>(png.size()));
        },
        true);
  }
  files.Commit();
}

}  // namespace mmba::registration::mi
