#pragma once

// The text outputs of `mmba survey` (docs/commands/survey.md): observations.csv, the summary
// it prints and report.md. Angles are in the input's unit, residuals and σ in cc / arc seconds
// or mm; a residual is adjusted − observed (Gama's v).

#include <cstddef>
#include <string>

#include "mmba/survey/adjust.h"
#include "mmba/survey/network.h"

namespace mmba::survey {

/// observations.csv: the observations of `net` in input order with their statistics from
/// `adj` (index, line, kind, from, to, observed, adjusted, residual, unit, σ, redundancy,
/// studentized residual, flag "max", "max-critical" or "critical").
std::string ObservationsCsv(const SurveyNetwork& net, const SurveyAdjustment& adj);

/// The summary `mmba survey` prints and report.md opens with: dimensions, datum, σ0, χ² test,
/// the largest studentized residual and the number of removed observations. `input` is the
/// file name as given.
std::string ResultSummary(const std::string& input, const SurveyNetwork& net,
                          const SurveyAdjustment& adj);

/// report.md: ResultSummary, the variance components per group, the adjusted points with σ,
/// 95 % confidence ellipses and 95 % height intervals, the relative precision of each point
/// and its two nearest neighbours (σ of the difference from the joint covariance), the
/// `largest_rows` largest studentized residuals and the removed observations.
std::string ReportMarkdown(const std::string& input, const SurveyNetwork& net,
                           const SurveyAdjustment& adj, size_t largest_rows);

}  // namespace mmba::survey
