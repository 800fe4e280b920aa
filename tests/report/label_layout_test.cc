// Labels of the plan view do not overprint: PlaceLabels on crowded and spread points, and the
// plan view's <text> labels checked box against box.
#include <regex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "mmba/report/label_layout.h"
#include "mmba/report/svg_plot.h"

namespace mmba::report {
namespace {

bool Overlap(const LabelPlacement& a, const LabelRequest& ra, const LabelPlacement& b, const LabelRequest& rb) {
  return a.box_x < b.box_x + rb.width && b.box_x < a.box_x + ra.width && a.box_y < b.box_y + rb.height &&
         b.box_y < a.box_y + ra.height;
}

TEST(LabelLayout, SpreadPointsKeepEveryLabelInItsFirstPlace) {
  std::vector<LabelRequest> r;
  for (int i = 0; i < 5; ++i) r.push_back({50.0 + 100.0 * i, 100.0, 30.0, 12.0, 5.0});
  const auto p = PlaceLabels(r, 0, 0, 600, 200);
  for (size_t i = 0; i < r.size(); ++i) {
    ASSERT_TRUE(p[i].shown);
    EXPECT_EQ(p[i].anchor, "start");  // right-above, the first choice
    EXPECT_GT(p[i].box_x, r[i].x);
    EXPECT_LT(p[i].box_y + 12.0, r[i].y);
  }
}

TEST(LabelLayout, CrowdedPointsNeverOverprint) {
  // A 3 × 3 cluster 8 px apart (labels 24 px wide): not all fit; the shown ones must not
  // overlap each other nor any marker.
  std::vector<LabelRequest> r;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r.push_back({200.0 + 8.0 * i, 200.0 + 8.0 * j, 24.0, 12.0, 4.0});
  }
  const auto p = PlaceLabels(r, 0, 0, 400, 400);
  size_t shown = 0;
  for (size_t i = 0; i < r.size(); ++i) {
    if (!p[i].shown) continue;
    ++shown;
    for (size_t j = 0; j < r.size(); ++j) {
      if (j != i && p[j].shown) {
        EXPECT_FALSE(Overlap(p[i], r[i], p[j], r[j])) << i << " and " << j;
      }
      const bool on_marker = p[i].box_x < r[j].x + 4 && r[j].x - 4 < p[i].box_x + 24 && p[i].box_y < r[j].y + 4 &&
                             r[j].y - 4 < p[i].box_y + 12;
      EXPECT_FALSE(on_marker) << "label " << i << " on marker " << j;
    }
  }
  EXPECT_GE(shown, 4u);  // the outer ring of the cluster finds room
  // Inside the bounds.
  for (size_t i = 0; i < r.size(); ++i) {
    if (p[i].shown) {
      EXPECT_GE(p[i].box_x, 0.0);
    }
  }
}

TEST(LabelLayout, PlanViewLabelsDoNotOverprint) {
  // Two control points 0.3 m apart on a 100 m site: the naive "right-above" labels would
  // print on each other.
  std::vector<PlanPoint> points;
  const double xy[5][2] = {{0, 0}, {0.3, 0.1}, {100, 0}, {100, 60}, {0, 60}};
  for (int i = 0; i < 5; ++i) {
    PlanPoint p;
    p.id = "GCP" + std::to_string(i + 1);
    p.east = xy[i][0];
    p.north = xy[i][1];
    p.ellipse_a = 0.01;
    p.ellipse_b = 0.005;
    points.push_back(p);
  }
  const std::string svg = SvgPlanView(points, PlanViewOptions{});
  const std::regex label(R"re(<text x="([0-9.]+)" y="([0-9.]+)" font-size="10" fill="#222" text-anchor="(\w+)">(GCP\d)</text>)re");
  struct Box { double x0, y0, x1, y1; };
  std::vector<Box> boxes;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), label); it != std::sregex_iterator(); ++it) {
    const double x = std::stod((*it)[1]), y = std::stod((*it)[2]);
    const double w = EstimateTextWidth((*it)[4], 10.0);
    const std::string anchor = (*it)[3];
    const double x0 = anchor == "start" ? x : (anchor == "end" ? x - w : x - w / 2);
    boxes.push_back({x0, y - 9.6, x0 + w, y + 2.4});
  }
  ASSERT_EQ(boxes.size(), 5u) << "two labels fit beside two points 0.3 m apart";
  for (size_t i = 0; i < boxes.size(); ++i) {
    for (size_t j = i + 1; j < boxes.size(); ++j) {
      const bool overlap = boxes[i].x0 < boxes[j].x1 && boxes[j].x0 < boxes[i].x1 && boxes[i].y0 < boxes[j].y1 &&
                           boxes[j].y0 < boxes[i].y1;
      EXPECT_FALSE(overlap) << i << " and " << j;
    }
  }
}

TEST(LabelLayout, PoseLegendEntriesDoNotOverprint) {
  // A sensor name of 41 characters followed by another sensor: the second swatch starts after
  // the first name's text.
  const std::string long_name = "ladybug5_plus_rear_left_camera_number_003";
  std::vector<PoseCorrectionPoint> poses = {{"a.jpg", long_name, 0.01, 0.0, 0.0, 0.01, 0.1},
                                            {"b.jpg", "photos", 0.0, 0.02, 0.0, 0.02, 0.2}};
  const std::string svg = SvgPoseCorrections(poses, 900);
  const std::regex swatch(R"re(<rect x="([0-9.]+)" y="22" width="10" height="10")re");
  std::vector<double> x;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), swatch); it != std::sregex_iterator(); ++it) {
    x.push_back(std::stod((*it)[1]));
  }
  ASSERT_EQ(x.size(), 2u);
  EXPECT_GE(x[1], x[0] + 14 + EstimateTextWidth(long_name, 11.0));
}

}  // namespace
}  // namespace mmba::report
