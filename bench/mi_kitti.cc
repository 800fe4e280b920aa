// MI registration on the real KITTI frame: start from the factory calibration perturbed by
// 0.1 m and 1° in known directions, register, and report the pixel offsets of the LiDAR points
// projected with the start and with the result against the calibration's own.
//   mi_kitti [DATA_DIR=data/kitti] [METRIC=nmi] [REGION=overlap] [BINS=64] [BOUND_M=0.5]
//            [BOUND_DEG=3] [STARTS=0,1,...,7]
// STARTS: indices 0..7 (the default) = each axis alone, then (+0.1, -0.1, +0.1; +1, -1, +1)
// and its opposite; 8 = the calibration itself; 9..16 = 0.1 m and 1° in random directions.
// The frame is prepared and registered as `mmba register-mi --kitti-calib` does (PrepareJob,
// RegisterJob: the intensity corrected for the angle of incidence, the orientation classes
// seen from the calibration's camera centre, the job's policy on the options).
// MMBA_DEBUG=1 in the environment logs each stage (time, evaluations);
// MI_POINT_RADIUS_M, MI_MAX_POINT_RADIUS_PX, MI_REPRESENTATION and the knobs of
// mi_bench_common.h (MI_LEVELS, MI_RESTART_LEVEL, MI_SPLIT_LEVEL, MI_PYRAMID_PATHS,
// MI_COARSE_STARTS, MI_POINT_SAMPLES, MI_SAMPLE_BLOCK, …) override the defaults;
// MI_INCIDENCE=0 leaves the intensity uncorrected (register-mi --incidence-correction off);
// MI_SURFACE_CLASSES=V: register-mi --surface-classes true --surface-voxel-m V;
// MI_ORIENTATION=N[,VOXEL]: register-mi --orientation-classes N [--surface-voxel-m VOXEL]
// (0 = the plain metric). Experiments on the data: MI_PHOTO_BLUR=SIGMA_PX smooths the photo;
// MI_MASK=x0,y0,x1,y1 drops the points that project into that box at the calibration.
// Diagnostics: MI_PROBE=1 (per-axis probe at every level, then exit; MI_PROBE_DIR writes it);
// MI_COMPARE=1 (the metric at the calibration, the start and the result at every level with
// the samples and MI at the calibration and the result, and on the line from the calibration
// to the result); MI_OVERLAY=PREFIX [MI_CROP=x0,y0,w,h] (PREFIX_<start>.png: photo / LiDAR
// image at the calibration / at the result).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "mi_bench_common.h"
#include "mmba/core/huge_pages.h"
#include "mmba/core/logging.h"
#include "mmba/registration/mi/image.h"
#include "mmba/registration/mi/job.h"
#include "mmba/registration/mi/mi_registration.h"

using namespace mmba;
using namespace mmba::registration::mi;

namespace {

// The command line and the options it and the environment set.
struct Args {
  std::string dir = "data/kitti";
  RegistrationOptions options;
  bool region_given = false;
  std::vector<int> starts;  ///< indices into Perturbations()
};

bool ParseArgs(int argc, char** argv, Args* args) {
  if (argc > 1) args->dir = argv[1];
  RegistrationOptions& options = args->options;
  if (argc > 2 && !ParseMetric(argv[2], &options.metric.kind)) return false;
  if (argc > 3 && !ParseRegion(argv[3], &options.metric.region)) return false;
  args->region_given = argc > 3;
  if (argc > 4) options.metric.bins = std::stoi(argv[4]);
  if (argc > 5) options.bound_translation_m = std::stod(argv[5]);
  if (argc > 6) options.bound_rotation_deg = std::stod(argv[6]);
  if (argc > 7) {
    for (const std::string& item : bench::SplitList(argv[7])) args->starts.push_back(std::stoi(item));
  }
  if (args->starts.empty()) {
    for (int i = 0; i < 8; ++i) args->starts.push_back(i);
  }
  bench::ApplyEvaluatorEnv(&options);
  bench::ApplySearchEnv(&options);
  // The rendering: the point footprint (radius = MI_POINT_RADIUS_M · f / range, at most
  // MI_MAX_POINT_RADIUS_PX) and the representation.
  if (const char* v = std::getenv("MI_POINT_RADIUS_M")) options.render.point_radius_m = std::atof(v);
  if (const char* v = std::getenv("MI_MAX_POINT_RADIUS_PX")) {
    options.render.max_point_radius_px = std::atoi(v);
  }
  if (const char* v = std::getenv("MI_REPRESENTATION")) {
    if (!ParseRepresentation(v, &options.render.representation)) return false;
  }
  return true;
}

// register-mi's request for the frame (--kitti-calib, camera 2) with the bench's options and
// the classes and incidence correction the environment asks for.
JobRequest KittiRequest(const Args& args) {
  JobRequest request;
  request.image = {args.dir + "/image_2/000000.png"};
  request.lidar = {args.dir + "/velodyne/000000.bin"};
  request.kitti_calib = args.dir + "/calib/000000.txt";
  request.kitti_camera = 2;
  request.options = args.options;
  request.region_given = args.region_given;
  if (const char* v = std::getenv("MI_INCIDENCE"); v != nullptr && std::atoi(v) == 0) {
    request.incidence_correction = "off";
  }
  if (const char* v = std::getenv("MI_SURFACE_CLASSES"); v != nullptr && std::atof(v) > 0) {
    request.surface_classes = true;
    request.surface_voxel_m = std::atof(v);
  }
  if (const char* v = std::getenv("MI_ORIENTATION")) {
    float voxel = static_cast<float>(kDefaultSurfaceVoxelM);
    std::sscanf(v, "%d,%f", &request.orientation_classes, &voxel);
    request.surface_voxel_m = voxel;
  }
  return request;
}

// The preparation's figures: the incidence fit and the points of each orientation class.
void PrintPreparation(const JobRequest& request, const Job& job) {
  const nlohmann::json& fit = job.incidence_json.at(0);
  if (!fit.is_null()) {
    std::printf("incidence correction: exponent %.3f (correlation %.3f, %zu points)\n",
                fit.at("exponent").get<double>(), fit.at("correlation").get<double>(),
                fit.at("points").get<size_t>());
  }
  if (job.orientation_sectors > 0) {
    std::vector<size_t> per_class(OrientationClassCount(job.orientation_sectors), 0);
    for (float value : job.clouds[0].intensity01) {
      ++per_class[std::clamp(static_cast<int>(std::floor(value)), 0, static_cast<int>(per_class.size()) - 1)];
    }
    std::printf("orientation classes (%d sectors, voxel %.2f m):", job.orientation_sectors,
                static_cast<float>(request.surface_voxel_m));
    for (size_t n : per_class) std::printf(" %zu", n);
    std::printf("\n");
  }
}

// MI_PHOTO_BLUR (diagnostic): the photo smoothed by a Gaussian of `sigma` px, separable,
// clamped edges — does a smoother photo move the metric's maximum?
void BlurPhoto(double sigma, GrayImage* image) {
  const int radius = static_cast<int>(std::ceil(3 * sigma));
  std::vector<double> kernel(2 * radius + 1);
  double sum = 0;
  for (int k = -radius; k <= radius; ++k) sum += kernel[k + radius] = std::exp(-0.5 * k * k / (sigma * sigma));
  for (double& w : kernel) w /= sum;
  for (int pass = 0; pass < 2; ++pass) {
    GrayImage out = *image;
    for (int r = 0; r < image->height; ++r) {
      for (int c = 0; c < image->width; ++c) {
        double acc = 0;
        for (int k = -radius; k <= radius; ++k) {
          const int cc = pass == 0 ? std::clamp(c + k, 0, image->width - 1) : c;
          const int rr = pass == 1 ? std::clamp(r + k, 0, image->height - 1) : r;
          acc += kernel[k + radius] * image->at(cc, rr);
        }
        out.at(c, r) = static_cast<float>(acc);
      }
    }
    *image = std::move(out);
  }
}

// MI_MASK (diagnostic): drops the points that project (with the calibration) into the image
// box "x0,y0,x1,y1" (e.g. a moving object), to see whether it pulls the metric.
void MaskPoints(const char* box, const Rigid3d& calibration, const sensors::Camera& camera,
                LidarPoints* points) {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  std::sscanf(box, "%lf,%lf,%lf,%lf", &x0, &y0, &x1, &y1);
  LidarPoints kept;
  for (size_t i = 0; i < points->size(); ++i) {
    const Eigen::Vector3d p = calibration * points->points_in_lidar[i].cast<double>();
    const std::optional<Eigen::Vector2d> xy = p.z() > 0 ? camera.ImgFromCam(p) : std::nullopt;
    if (xy && (*xy)[0] >= x0 && (*xy)[0] <= x1 && (*xy)[1] >= y0 && (*xy)[1] <= y1) continue;
    kept.points_in_lidar.push_back(points->points_in_lidar[i]);
    if (points->has_intensity()) kept.intensity01.push_back(points->intensity01[i]);
  }
  std::printf("MI_MASK: %zu of %zu points dropped\n", points->size() - kept.size(), points->size());
  *points = std::move(kept);
}

// MI_PROBE: where does the metric peak around the calibration? Each axis ±1 unit (m, deg) in
// 0.02 steps at every pyramid level: a peak away from 0 is a bias of the metric on this frame
// (data or rendering), not of the search.
void ProbeAtCalibration(const Job& job) {
  RegistrationOptions probe_options = job.options;
  probe_options.bound_translation_m = 1.0;
  probe_options.bound_rotation_deg = 1.0;
  const FrameSetEvaluator evaluator(job.frames, job.calibration, probe_options);
  for (int level = 0; level < evaluator.levels(); ++level) {
    const std::vector<ProbeSample> probe = Probe(evaluator, job.calibration, 1.0, 0.02, level);
    std::printf("probe level %d (%s, %s), argmax:", level,
                RepresentationName(job.options.render.representation).c_str(),
                MetricName(job.options.metric.kind).c_str());
    bench::PrintProbeArgmax(probe);
    std::printf("\n");
    if (const char* dir_out = std::getenv("MI_PROBE_DIR")) {
      WriteProbe(probe, std::string(dir_out) + "/level" + std::to_string(level));
    }
  }
}

// The starts: indices 0..7 each axis alone (+0.1 m or +1°), then combinations of both signs;
// 8 the calibration itself (does the search stay?); 9..16 0.1 m and 1° in random directions
// (the translation a random unit vector · 0.1 m, the rotation a random unit vector of (roll,
// pitch, yaw) · 1°; fixed seed) — more starts to look for a wrong "ok".
std::vector<Vector6d> Perturbations() {
  std::vector<Vector6d> perturbations;
  for (int axis = 0; axis < 6; ++axis) {
    Vector6d p = Vector6d::Zero();
    p[axis] = axis < 3 ? 0.1 : 1.0;
    perturbations.push_back(p);
  }
  Vector6d p;
  p << 0.1, -0.1, 0.1, 1.0, -1.0, 1.0;
  perturbations.push_back(p);
  perturbations.push_back(-p);
  perturbations.push_back(Vector6d::Zero());
  std::mt19937 rng(2026);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int k = 0; k < 8; ++k) {
    Eigen::Vector3d t(normal(rng), normal(rng), normal(rng));
    Eigen::Vector3d r(normal(rng), normal(rng), normal(rng));
    Vector6d q;
    q << 0.1 * t.normalized(), 1.0 * r.normalized();
    perturbations.push_back(q);
  }
  return perturbations;
}

// MI_OVERLAY (diagnostic picture): the photo (top), the LiDAR image at the calibration
// (middle) and at the result (bottom), empty pixels showing the photo darkened; crop
// MI_CROP="x0,y0,w,h" magnified 3x; written to PREFIX_<index>.png.
void WriteOverlay(const std::string& prefix, int index, const Job& job, const Rigid3d& result) {
  const View& view = job.frames[0].views[0];
  const GrayImage& image = view.image;
  int cx = 0, cy = 0, cw = image.width, ch = image.height;
  if (const char* crop = std::getenv("MI_CROP")) {
    std::sscanf(crop, "%d,%d,%d,%d", &cx, &cy, &cw, &ch);
    cx = std::clamp(cx, 0, image.width - 1);
    cy = std::clamp(cy, 0, image.height - 1);
    cw = std::clamp(cw, 1, image.width - cx);
    ch = std::clamp(ch, 1, image.height - cy);
  }
  const int zoom = 3;
  GrayImage picture(cw * zoom, 3 * ch * zoom);
  LidarImage rendered;
  for (int panel = 0; panel < 3; ++panel) {
    if (panel > 0) {
      RenderLidarImage(job.clouds[0], view, panel == 1 ? job.calibration : result,
                       job.options.render, &rendered);
    }
    for (int r = 0; r < ch * zoom; ++r) {
      for (int c = 0; c < cw * zoom; ++c) {
        const int ic = cx + c / zoom, ir = cy + r / zoom;
        float v = image.at(ic, ir);
        if (panel > 0) {
          const float l = rendered.value[size_t(ir) * image.width + ic];
          v = l >= 0 ? 255.f * l : 0.3f * v;
        }
        picture.at(c, panel * ch * zoom + r) = v;
      }
    }
  }
  WriteGrayPng(picture, prefix + "_" + std::to_string(index) + ".png");
}

// MI_COMPARE: is the result's metric above the calibration's? (Then the metric, not the
// search, puts its maximum away from the calibration on this frame.) Every level, B-spline
// and unsmoothed histogram, and the full-resolution metric on the straight line (in the
// correction) from the calibration (t = 0) to the result (t = 1) and beyond.
void CompareMetric(const Job& job, const Rigid3d& start, const Rigid3d& result) {
  const Rigid3d& calibration = job.calibration;
  const FrameSetEvaluator evaluator(job.frames, start, job.options);
  MetricOptions smooth = job.options.metric;
  smooth.smoothing = Smoothing::kBSpline;
  MetricOptions hard = job.options.metric;
  hard.smoothing = Smoothing::kNone;
  const Vector6d to_result = CorrectionBetween(calibration, result);
  std::printf("  line calibration->result, level 0 (%s):", SmoothingName(smooth.smoothing).c_str());
  for (int k = 0; k <= 15; ++k) {
    const double t = 0.1 * k;
    std::printf(" %.1f:%.6f", t,
                evaluator.Evaluate(ApplyCorrection(calibration, t * to_result), 0, smooth).value);
  }
  std::printf("\n");
  for (int level = 0; level < evaluator.levels(); ++level) {
    const MetricValue a = evaluator.Evaluate(calibration, level, smooth);
    const MetricValue b = evaluator.Evaluate(result, level, smooth);
    std::printf("  level %d samples: calibration %.0f (mi %.5f) result %.0f (mi %.5f)\n", level,
                a.samples, a.mi, b.samples, b.mi);
    std::printf("  level %d: %s calibration %.6f result %.6f start %.6f | none "
                "calibration %.6f result %.6f\n",
                level, SmoothingName(smooth.smoothing).c_str(),
                evaluator.Evaluate(calibration, level, smooth).value,
                evaluator.Evaluate(result, level, smooth).value,
                evaluator.Evaluate(start, level, smooth).value,
                evaluator.Evaluate(calibration, level, hard).value,
                evaluator.Evaluate(result, level, hard).value);
  }
}

void PrintHeader() {
  std::printf("%-40s %-6s %8s %8s  %-44s %6s %7s %6s %6s %6s\n",
              "perturbation (tx ty tz m, r p y deg)", "status", "before", "after",
              "residual error (m, deg)", "time", "sigma", "restart", "MIgain", "z");
}

// One start's line: the perturbation, status, median offsets, the residual error, the checks.
void PrintRow(const Vector6d& perturbation, const RegistrationResult& result,
              const PixelOffsetStats& before, const PixelOffsetStats& after, const Vector6d& error) {
  const AcceptanceChecks& c = result.checks;
  std::printf("%5.2f %5.2f %5.2f %5.1f %5.1f %5.1f        %-6s %6.2fpx %6.2fpx  "
              "%6.3f %6.3f %6.3f %6.2f %6.2f %6.2f  %5.1fs %6.2fpx %6.2fpx %6.4f %6.0f  "
              "calibrated sigma %.2f px, restart rms %.2f px, halves %.2f px  %s\n",
              perturbation[0], perturbation[1], perturbation[2], perturbation[3],
              perturbation[4], perturbation[5], result.status.c_str(), before.median_px,
              after.median_px, error[0], error[1], error[2], error[3], error[4], error[5],
              result.runtime_seconds, c.sigma_px, c.restart_spread_px,
              c.mi_bits - c.mi_shuffled_bits, c.mi_significance, c.sigma_px_calibrated,
              c.restart_rms_px, c.split_spread_px, result.reason.c_str());
}

// Registers the job from each start (the calibration perturbed) and prints its line; returns
// the starts recovered (median offset below 1 px).
int RegisterStarts(const std::vector<int>& starts, Job* job) {
  const std::vector<Vector6d> perturbations = Perturbations();
  const LidarPoints& points = job->clouds[0];
  const View& view = job->frames[0].views[0];
  const Rigid3d calibration = job->calibration;
  int recovered = 0;
  for (int index : starts) {
    const Vector6d& perturbation = perturbations.at(index);
    job->start = ApplyCorrection(calibration, perturbation);
    const Rigid3d start = job->start;
    Rigid3d cam_from_local;
    const RegistrationResult result = RegisterJob(*job, &cam_from_local);
    const PixelOffsetStats before = PixelOffsets(points, view, calibration, start, job->options.render);
    const PixelOffsetStats after =
        PixelOffsets(points, view, calibration, cam_from_local, job->options.render);
    recovered += after.median_px < 1.0;
    if (const char* out = std::getenv("MI_OVERLAY")) WriteOverlay(out, index, *job, cam_from_local);
    if (std::getenv("MI_COMPARE") != nullptr) CompareMetric(*job, start, cam_from_local);
    PrintRow(perturbation, result, before, after, CorrectionBetween(calibration, cam_from_local));
    bench::PrintDigest("  ", result);
  }
  return recovered;
}

}  // namespace

int main(int argc, char** argv) {
  mmba::ReexecWithHugePageMalloc(argv);  // as the mmba binary does (core/huge_pages.h)
  Args args;
  if (!ParseArgs(argc, argv, &args)) return 2;
  // The job's messages (its preparation, as register-mi logs it) on stderr; the figures on stdout.
  SetVerbosity(std::getenv("MMBA_DEBUG") != nullptr ? Verbosity::kVerbose : Verbosity::kNormal);
  const JobRequest request = KittiRequest(args);
  Job job = PrepareJob(request, ListFrames(request));
  PrintPreparation(request, job);
  if (const char* v = std::getenv("MI_PHOTO_BLUR")) BlurPhoto(std::atof(v), &job.frames[0].views[0].image);
  if (const char* box = std::getenv("MI_MASK")) MaskPoints(box, job.calibration, job.camera, &job.clouds[0]);
  if (std::getenv("MI_PROBE") != nullptr) {
    ProbeAtCalibration(job);
    return 0;
  }
  PrintHeader();
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const int recovered = RegisterStarts(args.starts, &job);
  std::printf("median offset < 1 px after registration: %d of %zu starts\n", recovered,
              args.starts.size());
  return 0;
}
