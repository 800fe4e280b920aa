#pragma once

// Coordinates the observations cannot determine, found in the design matrix of a built
// survey problem and removed from the adjustment as GNU Gama does
// (LocalNetwork::singular_coords, lib/gnu_gama/local/network.cpp): an xy pair whose x and y
// columns are parallel (1 − |cos| < 1e-12, e.g. a point seen by one direction only), or an
// xy or z whose columns are zero (no active observation). Private to mmba_survey.

#include <cmath>
#include <string>
#include <vector>

#include <ceres/problem.h>
#include <ceres/crs_matrix.h>

#include "mmba/survey/adjust.h"
#include "mmba/survey/network.h"

namespace mmba::survey::internal {

/// Sets the xy (or z) of `p` removed and returns the record.
inline RemovedCoordinate RemoveCoordinate(SurveyPoint* p, bool xy, const std::string& reason) {
  (xy ? p->xy : p->z) = CoordStatus::kRemoved;
  return RemovedCoordinate{p->id, p->line, xy ? "xy" : "z", reason};
}

/// The free coordinates of `problem` (built from `net`'s groups) that the observations do not
/// determine, each set CoordStatus::kRemoved. Empty: every free coordinate has an observation
/// and no xy pair is singular on its own.
inline std::vector<RemovedCoordinate> RemoveSingularCoordinates(SurveyNetwork* net,
                                                                ceres::Problem& problem) {
  std::vector<double*> blocks;
  std::vector<SurveyPoint*> owners;
  std::vector<bool> is_xy;
  for (SurveyPoint& p : net->points) {
    if (p.xy_free() && problem.HasParameterBlock(p.xy_block())) {
      blocks.push_back(p.xy_block()), owners.push_back(&p), is_xy.push_back(true);
    }
    if (p.z_free() && problem.HasParameterBlock(p.z_block())) {
      blocks.push_back(p.z_block()), owners.push_back(&p), is_xy.push_back(false);
    }
  }
  std::vector<RemovedCoordinate> removed;
  // A free coordinate without any residual block: no observation at all.
  for (SurveyPoint& p : net->points) {
    if (p.xy_free() && !problem.HasParameterBlock(p.xy_block())) {
      removed.push_back(RemoveCoordinate(&p, true, "no observation of its x, y"));
    }
    if (p.z_free() && !problem.HasParameterBlock(p.z_block())) {
      removed.push_back(RemoveCoordinate(&p, false, "no observation of its z"));
    }
  }
  if (blocks.empty()) return removed;
  ceres::Problem::EvaluateOptions eval;
  eval.parameter_blocks = blocks;
  ceres::CRSMatrix jacobian;
  problem.Evaluate(eval, nullptr, nullptr, nullptr, &jacobian);
  // Column sums of products over the whitened Jacobian: aa, bb, ab per xy pair (Gama's test
  // on its weighted design matrix), a·a per z.
  std::vector<double> col_start(blocks.size());
  int column = 0;
  for (size_t k = 0; k < blocks.size(); ++k) {
    col_start[k] = column;
    column += is_xy[k] ? 2 : 1;
  }
  std::vector<double> aa(blocks.size(), 0.0), bb(blocks.size(), 0.0), ab(blocks.size(), 0.0);
  std::vector<int> block_of(column, 0);
  for (size_t k = 0; k < blocks.size(); ++k) {
    for (int c = 0; c < (is_xy[k] ? 2 : 1); ++c) block_of[static_cast<int>(col_start[k]) + c] = static_cast<int>(k);
  }
  for (int r = 0; r < jacobian.num_rows; ++r) {
    // Each row touches a pair at most once: collect its x and y entries.
    std::vector<std::pair<int, double>> entries;
    for (int i = jacobian.rows[r]; i < jacobian.rows[r + 1]; ++i) {
      entries.emplace_back(jacobian.cols[i], jacobian.values[i]);
    }
    for (const auto& [c, v] : entries) {
      const int k = block_of[c];
      const bool second = c != static_cast<int>(col_start[k]);
      (second ? bb[k] : aa[k]) += v * v;
      if (!second && is_xy[k]) {
        for (const auto& [c2, v2] : entries) {
          if (c2 == c + 1) ab[k] += v * v2;
        }
      }
    }
  }
  for (size_t k = 0; k < blocks.size(); ++k) {
    SurveyPoint* p = owners[k];
    if (!is_xy[k]) {
      if (aa[k] == 0.0) removed.push_back(RemoveCoordinate(p, false, "no observation determines its z"));
      continue;
    }
    const double big = std::max(aa[k], bb[k]), small = std::min(aa[k], bb[k]);
    const double d = big == 0.0 ? 0.0 : 1.0 - std::abs(ab[k]) / std::sqrt(big * small);
    if (small == 0.0 || d < 1e-12) {
      removed.push_back(RemoveCoordinate(
          p, true, "singular x, y: the observations fix it along one line only (e.g. one direction)"));
    }
  }
  return removed;
}

}  // namespace mmba::survey::internal
