#pragma once

// Shared by the MI benches (mi_kitti, mi_panoramas, mi_speed): the process's figures, comma
// lists, the MI_* environment variables that set the same registration options in each, the
// per-axis peak of a probe, the result's digest line and the histograms of pixel offsets.

#include <string>
#include <vector>

#include "mmba/registration/mi/mi_registration.h"

namespace mmba::bench {

/// Peak resident memory of this process, MiB.
double PeakRssMiB();
/// User + system CPU time of this process, s.
double CpuSeconds();
/// The items of a comma-separated list.
std::vector<std::string> SplitList(const std::string& text);

/// The evaluator's and the checks' knobs every MI bench takes from the environment:
/// MI_POINT_SAMPLES (0 = render every evaluation), MI_PER_POINT_FROM_LEVEL, MI_SAMPLE_BLOCK,
/// MI_SAMPLES_IN_CHECKS, MI_COV_PER_POINT (0: the covariance fit on per-pixel samples),
/// MI_PYRAMID_PATHS, MI_PATHS_ADAPTIVE, MI_THREADS, MI_ALL_CHECKS (1: every acceptance check
/// measured also after one failed). A variable not set leaves its option as it is.
void ApplyEvaluatorEnv(registration::mi::RegistrationOptions* options);
/// The search structure's knobs of mi_kitti and mi_panoramas: MI_LEVELS (pyramid levels),
/// MI_RESTART_LEVEL, MI_SPLIT_LEVEL (the levels of the restarts and of the halves),
/// MI_COARSE_STARTS, MI_POLISH (polish rounds).
void ApplySearchEnv(registration::mi::RegistrationOptions* options);

/// Prints, for each of the six axes, the offset of `probe`'s largest metric value along it
/// (" tx +0.02 ty -0.10 …").
void PrintProbeArgmax(const std::vector<registration::mi::ProbeSample>& probe);

/// "<indent>digest %016llx  metric %a  iterations %d  evaluations %d": the result bit for bit
/// (equal digests = a reproduced registration).
void PrintDigest(const char* indent, const registration::mi::RegistrationResult& result);

/// Wang et al.'s histogram of pixel offsets: counts per bin of `width` px, `bins` bins, the
/// last holding everything beyond; divided by the number of values when `normalise`.
std::vector<double> Histogram(const std::vector<double>& values, double width, int bins,
                              bool normalise);
/// Writes Histogram() of the offsets `before` and `after` registration as a CSV (bin_from_px,
/// bin_to_px, <unit>_before, <unit>_after) and as an SVG bar chart titled `title`.
void WriteHistogram(const std::string& csv, const std::string& svg, const std::string& title,
                    const std::string& unit, const std::vector<double>& before,
                    const std::vector<double>& after, double width, int bins, bool normalise);

}  // namespace mmba::bench
