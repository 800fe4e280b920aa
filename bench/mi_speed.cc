// MI registration speed and accuracy: a synthetic street cloud of N points with
// intensity, a ray-cast photo (940×452 pinhole view, the paper's view size) from a known pose,
// registration from a start perturbed by 0.1 m and 1°. Prints wall time, evaluations, peak
// memory and pixel offsets at the start and at the result for each representation.
//   mi_speed [MILLION_POINTS=1] [REPRESENTATION=all|intensity|points|depth] [STARTS=1]
// STARTS = 1: the start below; 6: also five more (0.1 m / 1° and 0.3 m / 2°, mixed signs).
// MMBA_DEBUG=1 in the environment logs each stage (time, evaluations). MI_ORIENTATION=N: the
// intensity registrations' orientation classes (register-mi's default; 0 = the plain metric).
// MI_INCIDENCE=1: their cloud also corrected for the angle of incidence (timed with the classes).
// MI_WEAK_SCAN=0: without the acceptance scan along the weakly observed direction.
#include <sys/resource.h>

#include <cmath>
#include <cstdio>
#include <algorithm>
#include <cstdlib>
#include <string>
#include <vector>

#include "mmba/core/huge_pages.h"
#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "mmba/registration/mi/mi_registration.h"
#include "registration/mi/synthetic_scene.h"

using namespace mmba;
using namespace mmba::registration::mi;

static double PeakRssMiB() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;
}

int main(int argc, char** argv) {
  mmba::ReexecWithHugePageMalloc(argv);  // as the mmba binary does (core/huge_pages.h)
  const double million = argc > 1 ? std::stod(argv[1]) : 1.0;
  const std::string which = argc > 2 ? argv[2] : "all";
  if (std::getenv("MMBA_DEBUG") != nullptr) SetVerbosity(Verbosity::kVerbose);
  const double area_m2 = 1114.0;  // surfaces of testing::StreetScene()
  const double spacing = std::sqrt(area_m2 / (million * 1e6));
  Timer timer;
  io::PointCloud cloud = testing::StreetCloud(spacing);
  const sensors::Camera camera = testing::StreetCamera(940, 452, 470.0);
  const Rigid3d truth = testing::StreetCamFromLidar(Eigen::Vector3d(0.5, 0.3, 0.2), 4.0);
  const GrayImage photo = testing::StreetPhoto(camera, truth);
  LidarPoints points = PrepareLidarPoints(cloud);
  // MI_INCIDENCE=1: the intensity registrations' cloud prepared with the incidence correction
  // (timed with the classes; the street's intensity has no incidence term, so k ~ 0).
  const bool incidence = std::getenv("MI_INCIDENCE") != nullptr && std::atoi(std::getenv("MI_INCIDENCE")) != 0;
  if (!incidence) cloud = io::PointCloud();  // keep only the prepared floats
  std::printf("cloud %.2f M points (spacing %.4f m), photo 940x452, setup %.1f s, peak %.0f MiB\n",
              points.size() / 1e6, spacing, timer.ElapsedSeconds(), PeakRssMiB());
  Frame frame;
  frame.name = "street";
  frame.views = MakeViews(photo, camera, ViewOptions(), "street");
  frame.points = &points;
  const int starts = argc > 3 ? std::atoi(argv[3]) : 1;
  std::vector<Vector6d> perturbations(6);
  perturbations[0] << 0.1, -0.08, 0.06, 1.0, -0.8, 0.9;
  perturbations[1] << -0.1, 0.1, -0.1, -1.0, 1.0, -1.0;
  perturbations[2] << 0.1, 0.1, 0.1, 1.0, 1.0, 1.0;
  perturbations[3] << 0.3, -0.3, 0.3, 2.0, -2.0, 2.0;
  perturbations[4] << -0.3, 0.3, -0.3, -2.0, 2.0, -2.0;
  perturbations[5] << 0.0, 0.3, 0.0, 0.0, 0.0, 2.0;
  perturbations.resize(std::clamp(starts, 1, 6));
  // The intensity registrations as register-mi runs them: conditioned on the surfaces'
  // orientation (MI_ORIENTATION=N sectors; default register-mi's, 0 = the plain metric), the
  // classes seen from the first start's camera centre, timed apart.
  int sectors = kDefaultOrientationSectors;
  if (const char* v = std::getenv("MI_ORIENTATION")) sectors = std::atoi(v);
  LidarPoints classed;
  if (sectors > 0 && (which == "all" || which == "intensity")) {
    Timer classify;
    const Rigid3d first = ApplyCorrection(truth, perturbations[0]);
    if (incidence) {
      // register-mi's path with a known scanner: the intensity corrected for the angle of
      // incidence (the scanner at the cloud's origin) and the classes on the same planes.
      IncidenceCorrection correction;
      correction.scanner = [](size_t) -> Eigen::Vector3d { return Eigen::Vector3d::Zero(); };
      IncidenceFit fit;
      std::vector<Eigen::Vector3f> normals;
      classed = PrepareLidarPoints(cloud, correction, &fit, &normals);
      EncodeOrientationClasses(first.Inverse().translation.cast<float>(), sectors, normals, &classed);
      std::printf("incidence correction (exponent %.3f) and orientation classes (%d sectors): %.2f s, peak %.0f MiB\n",
                  fit.exponent, sectors, classify.ElapsedSeconds(), PeakRssMiB());
    } else {
      classed = points;
      EncodeOrientationClasses(first.Inverse().translation.cast<float>(), sectors, 0.5f,
                               &classed);
      std::printf("orientation classes (%d sectors): %.2f s, peak %.0f MiB\n", sectors,
                  classify.ElapsedSeconds(), PeakRssMiB());
    }
  }
  cloud = io::PointCloud();
  for (Representation r :
       {Representation::kIntensity, Representation::kPoints, Representation::kDepth}) {
    if (which != "all" && which != RepresentationName(r)) continue;
    for (const Vector6d& perturbation : perturbations) {
    const Rigid3d start = ApplyCorrection(truth, perturbation);
    RegistrationOptions options;
    options.render.representation = r;
    // Experiments: MI_FINEST_NM_LEVEL, MI_POINTS_PER_PIXEL override the defaults.
    if (const char* level = std::getenv("MI_FINEST_NM_LEVEL")) {
      options.finest_nelder_mead_level = std::atoi(level);
    }
    // Point-sample evaluator (0 = render every evaluation) and the level from which each
    // point is one weighted sample (finer levels: one sample per covered pixel).
    if (const char* v = std::getenv("MI_POINT_SAMPLES")) options.point_samples = std::atoi(v) != 0;
    if (const char* v = std::getenv("MI_SAMPLE_BLOCK")) options.sample_block_px = std::atoi(v);
    if (const char* v = std::getenv("MI_PER_POINT_FROM_LEVEL")) {
      options.per_point_samples_from_level = std::atoi(v);
    }
    if (const char* v = std::getenv("MI_SAMPLES_IN_CHECKS")) {
      options.point_samples_in_checks = std::atoi(v) != 0;
    }
    // MI_COV_PER_POINT=0: the covariance fit on per-pixel samples.
    if (const char* v = std::getenv("MI_COV_PER_POINT")) {
      options.covariance_per_point_samples = std::atoi(v) != 0;
    }
    if (const char* cap = std::getenv("MI_POINTS_PER_PIXEL")) {
      options.max_points_per_pixel = std::atof(cap);
    }
    if (const char* v = std::getenv("MI_THREADS")) options.threads = std::atoi(v);
    if (const char* v = std::getenv("MI_WEAK_SCAN")) options.scan_weak_direction = std::atoi(v) != 0;
    if (const char* v = std::getenv("MI_PYRAMID_PATHS")) options.pyramid_paths = std::atoi(v);
    if (const char* v = std::getenv("MI_PATHS_ADAPTIVE")) {
      options.pyramid_paths_adaptive = std::atoi(v) != 0;
    }
    // MI_ALL_CHECKS=1: every acceptance check measured also after one failed.
    if (const char* v = std::getenv("MI_ALL_CHECKS")) options.measure_all_checks = std::atoi(v) != 0;
    // Points-only images carry information only against the empty background.
    if (r == Representation::kPoints) options.metric.region = Region::kWholeImage;
    frame.points = &points;
    if (r == Representation::kIntensity && sectors > 0) {
      options.metric.lidar_classes = sectors + 3;
      frame.points = &classed;
    }
    Timer one;
    const RegistrationResult result = RegisterFrames({frame}, start, options);
    const double seconds = one.ElapsedSeconds();
    const PixelOffsetStats before = PixelOffsets(points, frame.views[0], truth, start, options.render);
    const PixelOffsetStats after =
        PixelOffsets(points, frame.views[0], truth, result.cam_from_lidar, options.render);
    const AcceptanceChecks& c = result.checks;
    // Covariance honesty: actual error of each parameter over its predicted σ.
    const Vector6d error = result.correction - CorrectionBetween(start, truth);
    Vector6d ratio = Vector6d::Constant(NAN);
    if (result.covariance_valid) {
      ratio = error.cwiseAbs().cwiseQuotient(result.covariance.diagonal().cwiseSqrt());
    }
    std::printf("(%.2f %.2f %.2f m, %.1f %.1f %.1f deg) ", perturbation[0], perturbation[1],
                perturbation[2], perturbation[3], perturbation[4], perturbation[5]);
    std::printf("%-9s %-6s %6.2f s  %4d evals  %5.1f ms/eval  median offset %.2f -> %.2f px "
                "(p90 %.2f -> %.2f)  sigma %.3f px (calibrated %.3f)  restarts %.2f px (rms %.2f)  halves "
                "%.2f px  MI gain %.4f bits "
                "(z %.0f)  N_eff %.0f (/%.1f)  err/sd %.2f %.2f %.2f %.2f %.2f %.2f  peak %.0f MiB  %s\n",
                RepresentationName(r).c_str(), result.status.c_str(), seconds,
                result.evaluations, 1000 * seconds / std::max(1, result.evaluations),
                before.median_px, after.median_px, before.p90_px, after.p90_px, c.sigma_px,
                c.sigma_px_calibrated, c.restart_spread_px, c.restart_rms_px, c.split_spread_px, c.mi_bits - c.mi_shuffled_bits, c.mi_significance,
                c.effective_samples, c.sample_inflation, ratio[0], ratio[1], ratio[2], ratio[3],
                ratio[4], ratio[5], PeakRssMiB(), result.reason.c_str());
    double cpu = 0;
    for (const StageStat& stage : result.stages) {
      std::printf("    %-28s %4d evals %7.3f s (cpu %7.3f s)\n", stage.name.c_str(),
                  stage.evaluations, stage.seconds, stage.cpu_seconds);
      cpu += stage.cpu_seconds;
    }
    std::printf("    registration cpu %.2f s\n", cpu);
    // The result bit for bit: equal digests = a reproduced registration.
    std::printf("    digest %016llx  metric %a  iterations %d  evaluations %d\n",
                static_cast<unsigned long long>(result.Digest()), result.metric_after.value,
                result.iterations, result.evaluations);
    }
  }
  return 0;
}
