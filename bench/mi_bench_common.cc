#include "mi_bench_common.h"

#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace mmba::bench {

using registration::mi::RegistrationOptions;

double PeakRssMiB() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;
}

double CpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + 1e-6 * usage.ru_utime.tv_usec + usage.ru_stime.tv_sec +
         1e-6 * usage.ru_stime.tv_usec;
}

std::vector<std::string> SplitList(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream list(text);
  for (std::string item; std::getline(list, item, ',');) items.push_back(item);
  return items;
}

void ApplyEvaluatorEnv(RegistrationOptions* options) {
  if (const char* v = std::getenv("MI_POINT_SAMPLES")) options->point_samples = std::atoi(v) != 0;
  if (const char* v = std::getenv("MI_PER_POINT_FROM_LEVEL")) {
    options->per_point_samples_from_level = std::atoi(v);
  }
  if (const char* v = std::getenv("MI_SAMPLE_BLOCK")) options->sample_block_px = std::atoi(v);
  if (const char* v = std::getenv("MI_SAMPLES_IN_CHECKS")) {
    options->point_samples_in_checks = std::atoi(v) != 0;
  }
  if (const char* v = std::getenv("MI_COV_PER_POINT")) {
    options->covariance_per_point_samples = std::atoi(v) != 0;
  }
  if (const char* v = std::getenv("MI_PYRAMID_PATHS")) options->pyramid_paths = std::atoi(v);
  if (const char* v = std::getenv("MI_PATHS_ADAPTIVE")) {
    options->pyramid_paths_adaptive = std::atoi(v) != 0;
  }
  if (const char* v = std::getenv("MI_THREADS")) options->threads = std::atoi(v);
  if (const char* v = std::getenv("MI_ALL_CHECKS")) options->measure_all_checks = std::atoi(v) != 0;
}

void ApplySearchEnv(RegistrationOptions* options) {
  if (const char* v = std::getenv("MI_LEVELS")) options->pyramid_levels = std::atoi(v);
  if (const char* v = std::getenv("MI_RESTART_LEVEL")) options->restart_level = std::atoi(v);
  if (const char* v = std::getenv("MI_SPLIT_LEVEL")) options->split_level = std::atoi(v);
  if (const char* v = std::getenv("MI_COARSE_STARTS")) options->coarse_starts = std::atoi(v);
  if (const char* v = std::getenv("MI_POLISH")) options->polish_rounds = std::atoi(v);
}

void PrintProbeArgmax(const std::vector<registration::mi::ProbeSample>& probe) {
  for (int axis = 0; axis < 6; ++axis) {
    const registration::mi::ProbeSample* best = nullptr;
    for (const registration::mi::ProbeSample& s : probe) {
      if (s.axis == axis && (best == nullptr || s.metric.value > best->metric.value)) best = &s;
    }
    std::printf(" %s %+.2f", registration::mi::ParameterName(axis), best->offset);
  }
}

void PrintDigest(const char* indent, const registration::mi::RegistrationResult& result) {
  std::printf("%sdigest %016llx  metric %a  iterations %d  evaluations %d\n", indent,
              static_cast<unsigned long long>(result.Digest()), result.metric_after.value,
              result.iterations, result.evaluations);
}

}  // namespace mmba::bench
