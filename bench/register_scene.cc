// bench/register_scene: `mmba register-eval` without the mmba binary (links only the cloud
// registration and io), for single cells while the rest of the tree builds. Usage:
//   register_scene SCENE_DIR OUT_DIR [methods=mmba,mmba-g] [cells=src:tgt,src:tgt]
//                  [viewpoints=0|1] [cross=0|1] [probe_weak_motions=0|1]
//                  [check_fit_uncertainty=0|1]
// Writes OUT_DIR/results.csv and tables.md as register-eval does, and prints one line per cell
// (status, RMS to the truth, resolution, the new uncertainty figures) plus CPU time and RSS.
#include <sys/resource.h>

#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "mmba/core/error.h"
#include "mmba/registration/cloud/scene_evaluation.h"

namespace {
std::vector<std::string> Split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}
}  // namespace

int main(int argc, char** argv) {
  using namespace mmba::registration;
  if (argc < 3) {
    std::cerr << "usage: register_scene SCENE_DIR OUT_DIR [methods=a,b] [cells=s:t,...] "
                 "[viewpoints=0|1] [cross=0|1]\n";
    return 2;
  }
  SceneEvalOptions options;
  options.methods = {"mmba", "mmba-g"};
  for (int i = 3; i < argc; ++i) {
    const std::string kv = argv[i];
    const size_t eq = kv.find('=');
    const std::string key = kv.substr(0, eq), value = eq == std::string::npos ? "" : kv.substr(eq + 1);
    if (key == "methods") options.methods = Split(value);
    else if (key == "cells") options.cells = Split(value);
    else if (key == "viewpoints") options.use_viewpoints = value != "0";
    else if (key == "cross") options.cross_modal = value != "0";
    else if (key == "probe_weak_motions") options.base.probe_weak_motions = value != "0";
    else if (key == "check_fit_uncertainty") options.base.check_fit_uncertainty = value != "0";
    else {
      std::cerr << "unknown key " << key << "\n";
      return 2;
    }
  }
  try {
    const SceneEvaluation eval = EvaluateScene(argv[1], options);
    WriteSceneEvaluation(eval, argv[2]);
    for (const EvalRow& r : eval.rows) {
      std::printf("%-24s -> %-18s %-7s %-6s rms %8.4g m  res %8.4g m  fit %.3f  viol %.4f  "
                  "sigma_rms %8.4g m  %6.1f s  %s\n",
                  r.source.c_str(), r.target.c_str(), r.method.c_str(), r.status.c_str(), r.rms_m,
                  r.resolution_m, r.fitness, r.violation, r.sigma_rms_m, r.runtime_s,
                  r.reason.substr(0, 160).c_str());
    }
  } catch (const mmba::InputError& e) {
    std::cerr << e.what() << "\n";
    return 2;
  }
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::printf("CPU %.1f s, peak RSS %.0f MiB\n",
              usage.ru_utime.tv_sec + usage.ru_stime.tv_sec + 1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec),
              usage.ru_maxrss / 1024.0);
  return 0;
}
