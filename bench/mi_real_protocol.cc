// register-mi on a real camera–LiDAR pair from 8 starts around the provider's calibration:
// five 0.1 m / 1° starts in known directions and three of 3° in roll, pitch and yaw (the
// OpenCalib protocol: their initial_error.txt "3 3 3 0 0 0"), the last with 0.1 m per axis as
// well. Prints one Markdown row per start: the start, the result's error to the calibration
// (rotation angle, deg; translation of cam_from_lidar, cm), the stated σ (the covariance's
// root sum of the three angles' and of the three shifts' variances), the status, the time.
// The frame is prepared as `mmba register-mi` prepares it (PrepareJob) and registered by
// RegisterJob with register-mi's defaults and the --set settings given.
//   mi_real_protocol (--camera YAML | --kitti-calib FILE) --lidar CLOUD --image IMAGE
//                    [--starts 0,1,...] [--set NAME=VALUE ...] [--probe PREFIX]
// --probe: instead, the edge score along each axis around the calibration at every edge level
// (±0.3 m, ±3°), and PREFIX_level<N>.png: the edge image D with the LiDAR edge points at the
// calibration drawn white.
#include <algorithm>
#include <cmath>
#include <optional>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "mi_bench_common.h"
#include "mmba/core/error.h"
#include "mmba/core/logging.h"
#include "mmba/registration/mi/edges.h"
#include "mmba/registration/mi/image.h"
#include "mmba/registration/mi/job.h"
#include "mmba/registration/mi/mi_registration.h"
#include "mmba/registration/mi/registration_settings.h"

using namespace mmba;
using namespace mmba::registration::mi;

namespace {

// The protocol's starts: tx ty tz (m), roll pitch yaw (deg), as register-mi --perturb.
std::vector<Vector6d> Starts() {
  std::vector<Vector6d> starts(8);
  starts[0] << 0.1, 0, 0, 1, 0, 0;
  starts[1] << 0, 0.1, 0, 0, 1, 0;
  starts[2] << 0, 0, 0.1, 0, 0, 1;
  starts[3] << 0.1, -0.1, 0.1, 1, -1, 1;
  starts[4] << -0.1, 0.1, -0.1, -1, 1, -1;
  starts[5] << 0, 0, 0, 3, 3, 3;
  starts[6] << 0, 0, 0, -3, -3, -3;
  starts[7] << 0.1, 0.1, -0.1, 3, -3, 3;
  return starts;
}

double RotationErrorDeg(const Rigid3d& a, const Rigid3d& b) {
  return Eigen::AngleAxisd(a.rotation * b.rotation.inverse()).angle() * 180.0 / M_PI;
}

std::string Start(const Vector6d& p) {
  char text[128];
  std::snprintf(text, sizeof(text), "%+.1f %+.1f %+.1f; %+.0f %+.0f %+.0f", p[0], p[1], p[2], p[3], p[4], p[5]);
  return text;
}

// The edge score along each axis around the reference at every level, and the edge images.
void Probe(const Job& job, const std::string& prefix) {
  const EdgeMetric edges(job.frames, job.reference, job.options.edge, job.options.edge_bound_deg + 1);
  std::printf("edge points: %zu depth, %zu intensity\n", edges.points(0), edges.points(1));
  static const char* kNames[6] = {"tx", "ty", "tz", "roll", "pitch", "yaw"};
  for (int level = 0; level < edges.levels(); ++level) {
    std::printf("level %d: score at the calibration %.4f\n", level, edges.Evaluate(job.reference, level));
    for (int axis = 0; axis < 6; ++axis) {
      const double step = axis < 3 ? 0.05 : 0.5;
      double best = -1, best_at = 0;
      std::printf("  %-5s", kNames[axis]);
      for (int k = -6; k <= 6; ++k) {
        Vector6d x = Vector6d::Zero();
        x[axis] = k * step;
        const double v = edges.Evaluate(ApplyCorrection(job.reference, x), level);
        if (v > best) best = v, best_at = x[axis];
        std::printf(" %.3f", v);
      }
      std::printf("  max at %+.2f\n", best_at);
    }
    GrayImage image = EdgeLevelImage(job.frames[0].views[0].image, job.options.edge, level);
    for (float& v : image.pixels) v = std::min(255.f, 60.f * v);
    const View& view = job.frames[0].views[0];
    for (const EdgePoint& p : edges.frame_points(0)) {
      const Eigen::Vector3d q = job.reference * p.point_in_lidar.cast<double>();
      if (q.z() <= 0.1) continue;
      const std::optional<Eigen::Vector2d> xy = view.camera.ImgFromCam(q);
      if (!xy) continue;
      const int c = static_cast<int>((*xy)[0]), r = static_cast<int>((*xy)[1]);
      for (int dr = -1; dr <= 1; ++dr)
        for (int dc = -1; dc <= 1; ++dc)
          if (c + dc >= 0 && r + dr >= 0 && c + dc < image.width && r + dr < image.height)
            image.at(c + dc, r + dr) = p.kind == 0 ? 255.f : 0.f;
    }
    WriteGrayPng(image, prefix + "_level" + std::to_string(level) + ".png");
  }
}

}  // namespace

int main(int argc, char** argv) {
  JobRequest request;
  std::vector<std::string> settings;
  std::vector<int> chosen;
  std::string probe;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() { return i + 1 < argc ? std::string(argv[++i]) : std::string(); };
    if (a == "--camera") request.camera = next();
    else if (a == "--kitti-calib") request.kitti_calib = next();
    else if (a == "--lidar") request.lidar.push_back(next());
    else if (a == "--image") request.image.push_back(next());
    else if (a == "--probe") probe = next();
    else if (a == "--starts") for (const std::string& s : bench::SplitList(next())) chosen.push_back(std::stoi(s));
    else if (a == "--set") {
      while (i + 1 < argc && std::string(argv[i + 1]).rfind("--", 0) != 0) settings.push_back(argv[++i]);
    } else {
      std::fprintf(stderr, "unknown argument %s\n", a.c_str());
      return 2;
    }
  }
  SetVerbosity(std::getenv("MMBA_DEBUG") != nullptr ? Verbosity::kVerbose : Verbosity::kNormal);
  if (chosen.empty()) chosen = {0, 1, 2, 3, 4, 5, 6, 7};
  std::string problem;
  std::vector<std::string> names;
  if (!RegistrationSettingsTable().Apply(settings, &request.options, &problem, &names)) {
    std::fprintf(stderr, "--set: %s\n", problem.c_str());
    return 2;
  }
  try {
    const std::vector<FramePaths> paths = ListFrames(request);
    Job job = PrepareJob(request, paths);
    const Rigid3d reference = job.reference;
    if (!probe.empty()) {
      Probe(job, probe);
      return 0;
    }
    std::printf("| start (tx ty tz m; r p y deg) | status | rotation error deg | translation error cm | "
                "stated sigma deg / cm | sigma ratio rot / trans | MI weight | time s |\n|---|---|---|---|---|---|---|---|\n");
    const std::vector<Vector6d> starts = Starts();
    std::vector<double> ratios;
    int ok = 0, good_ok = 0, bad_ok = 0;
    for (int s : chosen) {
      job.start = ApplyCorrection(reference, starts[s]);
      Rigid3d cam_from_local;
      const double cpu0 = bench::CpuSeconds();
      const RegistrationResult r = RegisterJob(job, &cam_from_local);
      const double cpu = bench::CpuSeconds() - cpu0;
      const double rot = RotationErrorDeg(cam_from_local, reference);
      const double trans = (cam_from_local.translation - reference.translation).norm();
      const Eigen::Matrix<double, 6, 6>& c = r.covariance;
      const double sigma_rot = std::sqrt(c(3, 3) + c(4, 4) + c(5, 5));
      const double sigma_t = std::sqrt(c(0, 0) + c(1, 1) + c(2, 2));
      ratios.push_back(sigma_rot / std::max(rot, 1e-3));
      ratios.push_back(sigma_t / std::max(trans, 1e-4));
      ok += r.ok();
      good_ok += r.ok() && rot <= 0.3 && trans <= 0.05;
      bad_ok += r.ok() && (rot > 0.6 || trans > 0.10);
      std::printf("| %s | %s | %.3f | %.1f | %.3f / %.1f | %.2f / %.2f | %.3g | %.1f (CPU %.1f) |\n",
                  Start(starts[s]).c_str(), r.ok() ? "**ok**" : ("failed: " + r.reason).c_str(), rot, 100 * trans,
                  sigma_rot, 100 * sigma_t, sigma_rot / std::max(rot, 1e-3), sigma_t / std::max(trans, 1e-4),
                  r.edge_mi_weight, r.runtime_seconds, cpu);
      std::fflush(stdout);
    }
    std::sort(ratios.begin(), ratios.end());
    std::printf("\nok %d of %zu; ok within 0.3 deg and 5 cm: %d; ok beyond 0.6 deg or 10 cm: %d; "
                "median sigma ratio (stated / actual, rotation and translation): %.2f; peak RSS %.0f MiB\n",
                ok, chosen.size(), good_ok, bad_ok, ratios[ratios.size() / 2], bench::PeakRssMiB());
  } catch (const InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  return 0;
}
