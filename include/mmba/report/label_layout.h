#pragma once

// Placement of point labels in the SVG plots so that no two labels overprint each other or
// another point's marker: each label tries eight positions around its point (right-above
// first), then the same eight one step further out; a label with no free position is left
// out (its point keeps the id in its tooltip). Greedy, in the order given — O(n²) boxes, for
// the tens to hundreds of points of a plan view. Pixels, y down.

#include <string>
#include <vector>

namespace mmba::report {

struct LabelRequest {
  double x = 0.0, y = 0.0;        ///< the point (marker centre)
  double width = 0.0, height = 0.0;  ///< the text's box
  double marker_radius = 5.0;     ///< the marker's half size: labels keep off it
};

struct LabelPlacement {
  bool shown = false;
  double x = 0.0, y = 0.0;          ///< text position: x of the anchor, y of the baseline
  std::string anchor = "start";     ///< SVG text-anchor: "start", "middle" or "end"
  double box_x = 0.0, box_y = 0.0;  ///< top-left of the text's box
};

/// Width of `text` at `font_px` in a sans-serif font, estimated as 0.62 em per character
/// (UTF-8 code points), a bound for DejaVu Sans / Arial digits and capitals.
double EstimateTextWidth(const std::string& text, double font_px);

/// Places the labels inside [min_x, max_x] × [min_y, max_y] (see the file comment).
std::vector<LabelPlacement> PlaceLabels(const std::vector<LabelRequest>& labels, double min_x, double min_y,
                                        double max_x, double max_y);

}  // namespace mmba::report
