// Label placement without overprinting (label_layout.h).
#include "mmba/report/label_layout.h"

#include <array>

namespace mmba::report {
namespace {

struct Box {
  double x0, y0, x1, y1;
  bool Overlaps(const Box& o) const { return x0 < o.x1 && o.x0 < x1 && y0 < o.y1 && o.y0 < y1; }
};

/// The candidate `k` (0..7) at offset `d` from the point: its text position and box.
LabelPlacement Candidate(const LabelRequest& r, int k, double d) {
  // Offsets in units of d: right-above, right-below, left-above, left-below, above, below,
  // right, left.
  static const std::array<std::array<int, 2>, 8> kDir = {
      {{1, -1}, {1, 1}, {-1, -1}, {-1, 1}, {0, -1}, {0, 1}, {1, 0}, {-1, 0}}};
  const int dx = kDir[k][0], dy = kDir[k][1];
  LabelPlacement p;
  p.shown = true;
  p.anchor = dx > 0 ? "start" : (dx < 0 ? "end" : "middle");
  p.box_x = dx > 0 ? r.x + d : (dx < 0 ? r.x - d - r.width : r.x - 0.5 * r.width);
  p.box_y = dy < 0 ? r.y - d - r.height : (dy > 0 ? r.y + d : r.y - 0.5 * r.height);
  p.x = dx > 0 ? p.box_x : (dx < 0 ? p.box_x + r.width : r.x);
  p.y = p.box_y + 0.8 * r.height;  // baseline: the descent is ~0.2 of the box
  return p;
}

}  // namespace

double EstimateTextWidth(const std::string& text, double font_px) {
  size_t code_points = 0;
  for (unsigned char c : text) {
    if ((c & 0xC0) != 0x80) ++code_points;
  }
  return 0.62 * font_px * code_points;
}

std::vector<LabelPlacement> PlaceLabels(const std::vector<LabelRequest>& labels, double min_x, double min_y,
                                        double max_x, double max_y) {
  std::vector<Box> markers;
  for (const LabelRequest& r : labels) {
    markers.push_back({r.x - r.marker_radius, r.y - r.marker_radius, r.x + r.marker_radius, r.y + r.marker_radius});
  }
  std::vector<Box> placed;
  std::vector<LabelPlacement> out(labels.size());
  for (size_t i = 0; i < labels.size(); ++i) {
    const LabelRequest& r = labels[i];
    for (int ring = 0; ring < 2 && !out[i].shown; ++ring) {
      const double d = (r.marker_radius + 1.5) * (ring == 0 ? 1.0 : 2.5);
      for (int k = 0; k < 8; ++k) {
        const LabelPlacement c = Candidate(r, k, d);
        const Box box{c.box_x, c.box_y, c.box_x + r.width, c.box_y + r.height};
        if (box.x0 < min_x || box.y0 < min_y || box.x1 > max_x || box.y1 > max_y) continue;
        bool free = true;
        for (const Box& b : placed) free = free && !box.Overlaps(b);
        for (size_t j = 0; j < markers.size() && free; ++j) free = !box.Overlaps(markers[j]);
        if (!free) continue;
        out[i] = c;
        placed.push_back(box);
        break;
      }
    }
  }
  return out;
}

}  // namespace mmba::report
