// MI registration speed and accuracy: a synthetic street cloud of N points with
// intensity, a ray-cast photo (940×452 pinhole view, the paper's view size) from a known pose,
// registration from a start perturbed by 0.1 m and 1°. Prints wall time, evaluations, peak
// memory and pixel offsets at the start and at the result for each representation.
//   mi_speed [MILLION_POINTS=1] [REPRESENTATION=all|intensity|points|depth] [STARTS=1]
// STARTS = 1: the start below; 6: also five more (0.1 m / 1° and 0.3 m / 2°, mixed signs).
// The options are register-mi's for each representation (points over the whole image, the
// intensity conditioned on the orientation classes). MMBA_DEBUG=1 in the environment logs
// each stage (time, evaluations). MI_ORIENTATION=N: the intensity registrations' orientation
// classes (register-mi --orientation-classes; 0 = the plain metric). MI_INCIDENCE=1: their
// cloud also corrected for the angle of incidence (timed with the classes). MI_WEAK_SCAN=0:
// without the acceptance scan along the weakly observed direction. MI_FINEST_NM_LEVEL,
// MI_POINTS_PER_PIXEL and the knobs of mi_bench_common.h (MI_POINT_SAMPLES, MI_SAMPLE_BLOCK,
// MI_PYRAMID_PATHS, MI_THREADS, …) override the defaults.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "mi_bench_common.h"
#include "mmba/core/huge_pages.h"
#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "mmba/registration/mi/job.h"
#include "mmba/registration/mi/mi_registration.h"
#include "registration/mi/synthetic_scene.h"

using namespace mmba;
using namespace mmba::registration::mi;
using bench::PeakRssMiB;

namespace {

// The synthetic street: the cloud (kept only for the incidence correction), its prepared
// points, the camera, the true pose and the photo.
struct Street {
  io::PointCloud cloud;
  LidarPoints points;
  sensors::Camera camera;
  Rigid3d truth;
  GrayImage photo;
};

Street MakeStreet(double million, bool keep_cloud) {
  const double area_m2 = 1114.0;  // surfaces of testing::StreetScene()
  const double spacing = std::sqrt(area_m2 / (million * 1e6));
  Timer timer;
  Street street;
  street.cloud = testing::StreetCloud(spacing);
  street.camera = testing::StreetCamera(940, 452, 470.0);
  street.truth = testing::StreetCamFromLidar(Eigen::Vector3d(0.5, 0.3, 0.2), 4.0);
  street.photo = testing::StreetPhoto(street.camera, street.truth);
  street.points = PrepareLidarPoints(street.cloud);
  if (!keep_cloud) street.cloud = io::PointCloud();  // keep only the prepared floats
  std::printf("cloud %.2f M points (spacing %.4f m), photo 940x452, setup %.1f s, peak %.0f MiB\n",
              street.points.size() / 1e6, spacing, timer.ElapsedSeconds(), PeakRssMiB());
  return street;
}

std::vector<Vector6d> Perturbations(int starts) {
  std::vector<Vector6d> perturbations(6);
  perturbations[0] << 0.1, -0.08, 0.06, 1.0, -0.8, 0.9;
  perturbations[1] << -0.1, 0.1, -0.1, -1.0, 1.0, -1.0;
  perturbations[2] << 0.1, 0.1, 0.1, 1.0, 1.0, 1.0;
  perturbations[3] << 0.3, -0.3, 0.3, 2.0, -2.0, 2.0;
  perturbations[4] << -0.3, 0.3, -0.3, -2.0, 2.0, -2.0;
  perturbations[5] << 0.0, 0.3, 0.0, 0.0, 0.0, 2.0;
  perturbations.resize(std::clamp(starts, 1, 6));
  return perturbations;
}

// The intensity registrations' cloud as register-mi prepares it: conditioned on the surfaces'
// orientation (`sectors`), the classes seen from the first start's camera centre, timed apart;
// with `incidence` (MI_INCIDENCE=1, an experiment: the street's intensity has no incidence
// term, so k ~ 0) the intensity also corrected for the angle of incidence with the scanner at
// the cloud's origin, and the classes on the same planes.
LidarPoints ClassedPoints(const Street& street, int sectors, bool incidence, const Rigid3d& first) {
  Timer classify;
  LidarPoints classed;
  if (incidence) {
    IncidenceCorrection correction;
    correction.scanner = [](size_t) -> Eigen::Vector3d { return Eigen::Vector3d::Zero(); };
    IncidenceFit fit;
    std::vector<Eigen::Vector3f> normals;
    classed = PrepareLidarPoints(street.cloud, correction, &fit, &normals);
    EncodeOrientationClasses(first.Inverse().translation.cast<float>(), sectors, normals, &classed);
    std::printf("incidence correction (exponent %.3f) and orientation classes (%d sectors): %.2f s, peak %.0f MiB\n",
                fit.exponent, sectors, classify.ElapsedSeconds(), PeakRssMiB());
  } else {
    classed = street.points;
    EncodeOrientationClasses(first.Inverse().translation.cast<float>(), sectors,
                             static_cast<float>(kDefaultSurfaceVoxelM), &classed);
    std::printf("orientation classes (%d sectors): %.2f s, peak %.0f MiB\n", sectors,
                classify.ElapsedSeconds(), PeakRssMiB());
  }
  return classed;
}

// The options of one representation: register-mi's policy (points over the whole image, their
// LiDAR image being constant over the overlap; the orientation classes of the intensity) and
// the environment's knobs.
RegistrationOptions SpeedOptions(Representation representation, int sectors) {
  RegistrationOptions options;
  options.render.representation = representation;
  if (const char* level = std::getenv("MI_FINEST_NM_LEVEL")) {
    options.finest_nelder_mead_level = std::atoi(level);
  }
  bench::ApplyEvaluatorEnv(&options);
  if (const char* cap = std::getenv("MI_POINTS_PER_PIXEL")) options.max_points_per_pixel = std::atof(cap);
  if (const char* v = std::getenv("MI_WEAK_SCAN")) options.scan_weak_direction = std::atoi(v) != 0;
  if (representation == Representation::kPoints) options.metric.region = Region::kWholeImage;
  if (representation == Representation::kIntensity && sectors > 0) {
    options.metric.lidar_classes = OrientationClassCount(sectors);
  }
  return options;
}

// One registration's line (offsets, checks, covariance honesty), its stages and its digest.
void PrintResult(Representation representation, const Vector6d& perturbation, const Street& street,
                 const Rigid3d& start, const RegistrationOptions& options, const View& view,
                 const RegistrationResult& result, double seconds) {
  const PixelOffsetStats before = PixelOffsets(street.points, view, street.truth, start, options.render);
  const PixelOffsetStats after =
      PixelOffsets(street.points, view, street.truth, result.cam_from_lidar, options.render);
  const AcceptanceChecks& c = result.checks;
  // Covariance honesty: actual error of each parameter over its predicted σ.
  const Vector6d error = result.correction - CorrectionBetween(start, street.truth);
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
              RepresentationName(representation).c_str(), result.status.c_str(), seconds,
              result.evaluations, 1000 * seconds / std::max(1, result.evaluations),
              before.median_px, after.median_px, before.p90_px, after.p90_px, c.sigma_px,
              c.sigma_px_calibrated, c.restart_spread_px, c.restart_rms_px, c.split_spread_px,
              c.mi_bits - c.mi_shuffled_bits, c.mi_significance, c.effective_samples,
              c.sample_inflation, ratio[0], ratio[1], ratio[2], ratio[3], ratio[4], ratio[5],
              PeakRssMiB(), result.reason.c_str());
  double cpu = 0;
  for (const StageStat& stage : result.stages) {
    std::printf("    %-28s %4d evals %7.3f s (cpu %7.3f s)\n", stage.name.c_str(),
                stage.evaluations, stage.seconds, stage.cpu_seconds);
    cpu += stage.cpu_seconds;
  }
  std::printf("    registration cpu %.2f s\n", cpu);
  bench::PrintDigest("    ", result);
}

}  // namespace

int main(int argc, char** argv) {
  mmba::ReexecWithHugePageMalloc(argv);  // as the mmba binary does (core/huge_pages.h)
  const double million = argc > 1 ? std::stod(argv[1]) : 1.0;
  const std::string which = argc > 2 ? argv[2] : "all";
  const int starts = argc > 3 ? std::atoi(argv[3]) : 1;
  if (std::getenv("MMBA_DEBUG") != nullptr) SetVerbosity(Verbosity::kVerbose);
  const bool incidence = std::getenv("MI_INCIDENCE") != nullptr && std::atoi(std::getenv("MI_INCIDENCE")) != 0;
  Street street = MakeStreet(million, incidence);
  Frame frame;
  frame.name = "street";
  frame.views = MakeViews(street.photo, street.camera, ViewOptions(), "street");
  const std::vector<Vector6d> perturbations = Perturbations(starts);
  int asked = -1;
  if (const char* v = std::getenv("MI_ORIENTATION")) asked = std::atoi(v);
  const int sectors = OrientationSectors(asked, Representation::kIntensity, false);
  LidarPoints classed;
  if (sectors > 0 && (which == "all" || which == "intensity")) {
    classed = ClassedPoints(street, sectors, incidence, ApplyCorrection(street.truth, perturbations[0]));
  }
  street.cloud = io::PointCloud();
  for (Representation r : {Representation::kIntensity, Representation::kPoints, Representation::kDepth}) {
    if (which != "all" && which != RepresentationName(r)) continue;
    for (const Vector6d& perturbation : perturbations) {
      const Rigid3d start = ApplyCorrection(street.truth, perturbation);
      const RegistrationOptions options = SpeedOptions(r, sectors);
      frame.points = r == Representation::kIntensity && sectors > 0 ? &classed : &street.points;
      Timer one;
      const RegistrationResult result = RegisterFrames({frame}, start, options);
      PrintResult(r, perturbation, street, start, options, frame.views[0], result, one.ElapsedSeconds());
    }
  }
  return 0;
}
