// MI registration on the real KITTI frame: start from the factory calibration perturbed by
// 0.1 m and 1° in known directions, register, and report the pixel offsets of the LiDAR points
// projected with the start and with the result against the calibration's own.
//   mi_kitti [DATA_DIR=data/kitti] [METRIC=nmi] [REGION=overlap] [BINS=64] [BOUND_M=0.5]
//            [BOUND_DEG=3] [STARTS=0,1,...,7]
// STARTS: indices 0..7 (the default) = each axis alone, then (+0.1, -0.1, +0.1; +1, -1, +1)
// and its opposite; 8 = the calibration itself; 9..16 = 0.1 m and 1° in random directions.
// MMBA_DEBUG=1 in the environment logs each stage (time, evaluations);
// MI_POINT_RADIUS_M, MI_MAX_POINT_RADIUS_PX, MI_REPRESENTATION, MI_LEVELS, MI_RESTART_LEVEL,
// MI_SPLIT_LEVEL, MI_PYRAMID_PATHS, MI_COARSE_STARTS, MI_POINT_SAMPLES, MI_SAMPLE_BLOCK override
// the defaults; MI_INCIDENCE=0 leaves the intensity uncorrected for the angle of incidence;
// MI_PHOTO_BLUR=SIGMA_PX smooths the photo (diagnostic). MI_ORIENTATION=N[,VOXEL]: the orientation
// classes' sectors and voxel (register-mi --orientation-classes; default its default, 0 = plain metric).
// Diagnostics: MI_PROBE=1 (per-axis probe at every level, then exit); MI_COMPARE=1 (the
// metric at the calibration, the start and the result at every level with the samples and MI
// at the calibration and the result, and on the line from
// the calibration to the result); MI_OVERLAY=PREFIX [MI_CROP=x0,y0,w,h] (PREFIX_<start>.png:
// photo / LiDAR image at the calibration / at the result).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "mmba/core/huge_pages.h"
#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "mmba/io_kitti/kitti.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/registration/mi/image.h"
#include "mmba/registration/mi/job.h"
#include "mmba/registration/mi/mi_registration.h"

using namespace mmba;
using namespace mmba::registration::mi;

int main(int argc, char** argv) {
  mmba::ReexecWithHugePageMalloc(argv);  // as the mmba binary does (core/huge_pages.h)
  const std::string dir = argc > 1 ? argv[1] : "data/kitti";
  RegistrationOptions options;
  if (argc > 2 && !ParseMetric(argv[2], &options.metric.kind)) return 2;
  if (argc > 3 && !ParseRegion(argv[3], &options.metric.region)) return 2;
  if (argc > 4) options.metric.bins = std::stoi(argv[4]);
  if (argc > 5) options.bound_translation_m = std::stod(argv[5]);
  if (argc > 6) options.bound_rotation_deg = std::stod(argv[6]);
  std::vector<int> starts;
  if (argc > 7) {
    std::stringstream list(argv[7]);
    for (std::string item; std::getline(list, item, ',');) starts.push_back(std::stoi(item));
  }
  if (std::getenv("MMBA_DEBUG") != nullptr) SetVerbosity(Verbosity::kVerbose);
  // Experiments: the point footprint (radius = MI_POINT_RADIUS_M · f / range, at most
  // MI_MAX_POINT_RADIUS_PX) and the representation.
  // Point-sample evaluator (0 = render every evaluation), per-point samples from this level,
  // point samples in the restarts and halves.
  if (const char* v = std::getenv("MI_POINT_SAMPLES")) options.point_samples = std::atoi(v) != 0;
  if (const char* v = std::getenv("MI_PER_POINT_FROM_LEVEL")) {
    options.per_point_samples_from_level = std::atoi(v);
  }
  if (const char* v = std::getenv("MI_SAMPLE_BLOCK")) options.sample_block_px = std::atoi(v);
  if (const char* v = std::getenv("MI_SAMPLES_IN_CHECKS")) {
    options.point_samples_in_checks = std::atoi(v) != 0;
  }
  // MI_COV_PER_POINT=0: the covariance fit on per-pixel samples.
  if (const char* v = std::getenv("MI_COV_PER_POINT")) {
    options.covariance_per_point_samples = std::atoi(v) != 0;
  }
  // Search structure: pyramid levels, the levels of the restarts and of the halves, coarse
  // starts (as in mi_panoramas).
  if (const char* v = std::getenv("MI_LEVELS")) options.pyramid_levels = std::atoi(v);
  if (const char* v = std::getenv("MI_RESTART_LEVEL")) options.restart_level = std::atoi(v);
  if (const char* v = std::getenv("MI_SPLIT_LEVEL")) options.split_level = std::atoi(v);
  if (const char* v = std::getenv("MI_PYRAMID_PATHS")) options.pyramid_paths = std::atoi(v);
  if (const char* v = std::getenv("MI_PATHS_ADAPTIVE")) {
    options.pyramid_paths_adaptive = std::atoi(v) != 0;
  }
  if (const char* v = std::getenv("MI_COARSE_STARTS")) options.coarse_starts = std::atoi(v);
  if (const char* v = std::getenv("MI_THREADS")) options.threads = std::atoi(v);
  if (const char* v = std::getenv("MI_SURFACE_CLASSES"); v != nullptr && std::atof(v) > 0) {
    options.metric.lidar_classes = 2;
  }
  // MI_ALL_CHECKS=1: every acceptance check measured also after one failed.
  if (const char* v = std::getenv("MI_ALL_CHECKS")) options.measure_all_checks = std::atoi(v) != 0;
  if (const char* v = std::getenv("MI_POLISH")) options.polish_rounds = std::atoi(v);
  if (const char* v = std::getenv("MI_POINT_RADIUS_M")) {
    options.render.point_radius_m = std::atof(v);
  }
  if (const char* v = std::getenv("MI_MAX_POINT_RADIUS_PX")) {
    options.render.max_point_radius_px = std::atoi(v);
  }
  if (const char* v = std::getenv("MI_REPRESENTATION")) {
    if (!ParseRepresentation(v, &options.render.representation)) return 2;
  }
  GrayImage image = ReadGrayImage(dir + "/image_2/000000.png");
  if (const char* v = std::getenv("MI_PHOTO_BLUR")) {
    // Diagnostic: the photo smoothed by a Gaussian of this sigma (px), separable, clamped
    // edges — does a smoother photo move the metric's maximum?
    const double sigma = std::atof(v);
    const int radius = static_cast<int>(std::ceil(3 * sigma));
    std::vector<double> kernel(2 * radius + 1);
    double sum = 0;
    for (int k = -radius; k <= radius; ++k) sum += kernel[k + radius] = std::exp(-0.5 * k * k / (sigma * sigma));
    for (double& w : kernel) w /= sum;
    for (int pass = 0; pass < 2; ++pass) {
      GrayImage out = image;
      for (int r = 0; r < image.height; ++r) {
        for (int c = 0; c < image.width; ++c) {
          double acc = 0;
          for (int k = -radius; k <= radius; ++k) {
            const int cc = pass == 0 ? std::clamp(c + k, 0, image.width - 1) : c;
            const int rr = pass == 1 ? std::clamp(r + k, 0, image.height - 1) : r;
            acc += kernel[k + radius] * image.at(cc, rr);
          }
          out.at(c, r) = static_cast<float>(acc);
        }
      }
      image = std::move(out);
    }
  }
  const io::KittiCameraPose kitti = io::KittiCamera(
      io::ReadKittiCalibration(dir + "/calib/000000.txt"), 2, image.width, image.height);
  // register-mi's default for a KITTI scan: the intensity corrected for the angle of incidence
  // with the scanner at the velodyne's origin and the exponent fitted to the scan
  // (IncidenceCorrection); MI_INCIDENCE=0: the intensity as measured.
  const char* incidence_env = std::getenv("MI_INCIDENCE");
  LidarPoints points;
  if (incidence_env == nullptr || std::atoi(incidence_env) != 0) {
    IncidenceCorrection correction;
    correction.scanner = [](size_t) -> Eigen::Vector3d { return Eigen::Vector3d::Zero(); };
    IncidenceFit fit;
    points = PrepareLidarPoints(io::ReadPointCloud(dir + "/velodyne/000000.bin"), correction, &fit);
    std::printf("incidence correction: exponent %.3f (correlation %.3f, %zu points)\n", fit.exponent,
                fit.correlation, fit.points);
  } else {
    points = PrepareLidarPoints(io::ReadPointCloud(dir + "/velodyne/000000.bin"));
  }
  if (const char* v = std::getenv("MI_SURFACE_CLASSES"); v != nullptr && std::atof(v) > 0) {
    // register-mi --surface-classes true --surface-voxel-m V (MI_SURFACE_CLASSES=V).
    EncodeSurfaceClasses(SurfaceClasses(points.points_in_lidar, Eigen::Vector3f::UnitZ(),
                                        static_cast<float>(std::atof(v))),
                         &points);
  }
  // register-mi --orientation-classes N (MI_ORIENTATION=N; by default register-mi's, none with
  // MI_SURFACE_CLASSES; 0 = the plain metric): seen
  // from the calibration's camera centre.
  int sectors = points.classes > 1 ? 0 : kDefaultOrientationSectors;
  float voxel = static_cast<float>(kDefaultSurfaceVoxelM);
  if (const char* v = std::getenv("MI_ORIENTATION")) std::sscanf(v, "%d,%f", &sectors, &voxel);
  if (sectors > 0 && points.has_intensity() &&
      options.render.representation == Representation::kIntensity) {
    const Eigen::Vector3f centre =
        kitti.cam_from_lidar.Inverse().translation.cast<float>();
    std::vector<size_t> per_class;
    options.metric.lidar_classes = EncodeOrientationClasses(centre, sectors, voxel, &points, &per_class);
    std::printf("orientation classes (%d sectors, voxel %.2f m):", sectors, voxel);
    for (size_t n : per_class) std::printf(" %zu", n);
    std::printf("\n");
  }
  if (const char* mask = std::getenv("MI_MASK")) {
    // Diagnostic: drop the points that project (with the calibration) into the image box
    // "x0,y0,x1,y1" (e.g. a moving object), to see whether it pulls the metric.
    double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    std::sscanf(mask, "%lf,%lf,%lf,%lf", &x0, &y0, &x1, &y1);
    LidarPoints kept;
    for (size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3d p = kitti.cam_from_lidar * points.points_in_lidar[i].cast<double>();
      const std::optional<Eigen::Vector2d> xy =
          p.z() > 0 ? kitti.camera.ImgFromCam(p) : std::nullopt;
      if (xy && (*xy)[0] >= x0 && (*xy)[0] <= x1 && (*xy)[1] >= y0 && (*xy)[1] <= y1) continue;
      kept.points_in_lidar.push_back(points.points_in_lidar[i]);
      if (points.has_intensity()) kept.intensity01.push_back(points.intensity01[i]);
    }
    std::printf("MI_MASK: %zu of %zu points dropped\n", points.size() - kept.size(),
                points.size());
    points = std::move(kept);
  }
  Frame frame;
  frame.name = "kitti_000000";
  frame.views = MakeViews(image, kitti.camera, ViewOptions(), "image");
  frame.points = &points;
  if (std::getenv("MI_PROBE") != nullptr) {
    // Where does the metric peak around the calibration? Each axis ±1 unit (m, deg) in 0.02
    // steps at every pyramid level: a peak away from 0 is a bias of the metric on this frame
    // (data or rendering), not of the search.
    RegistrationOptions probe_options = options;
    probe_options.bound_translation_m = 1.0;
    probe_options.bound_rotation_deg = 1.0;
    const FrameSetEvaluator evaluator({frame}, kitti.cam_from_lidar, probe_options);
    for (int level = 0; level < evaluator.levels(); ++level) {
      const std::vector<ProbeSample> probe =
          Probe(evaluator, kitti.cam_from_lidar, 1.0, 0.02, level);
      std::printf("probe level %d (%s, %s), argmax:", level,
                  RepresentationName(options.render.representation).c_str(),
                  MetricName(options.metric.kind).c_str());
      for (int axis = 0; axis < 6; ++axis) {
        const ProbeSample* best = nullptr;
        for (const ProbeSample& s : probe) {
          if (s.axis == axis && (best == nullptr || s.metric.value > best->metric.value)) {
            best = &s;
          }
        }
        std::printf(" %s %+.2f", ParameterName(axis), best->offset);
      }
      std::printf("\n");
      if (const char* dir_out = std::getenv("MI_PROBE_DIR")) {
        WriteProbe(probe, std::string(dir_out) + "/level" + std::to_string(level));
      }
    }
    return 0;
  }
  // Known directions: each axis alone (+0.1 m or +1°), then combinations of both signs.
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
  // Index 8 (only when asked for in STARTS): the calibration itself — does the search stay?
  perturbations.push_back(Vector6d::Zero());
  // Indices 9..16 (only when asked for): 0.1 m and 1° in random directions (the translation a
  // random unit vector · 0.1 m, the rotation a random unit vector of (roll, pitch, yaw) · 1°;
  // fixed seed) — more starts to look for a wrong "ok".
  std::mt19937 rng(2026);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int k = 0; k < 8; ++k) {
    Eigen::Vector3d t(normal(rng), normal(rng), normal(rng));
    Eigen::Vector3d r(normal(rng), normal(rng), normal(rng));
    Vector6d q;
    q << 0.1 * t.normalized(), 1.0 * r.normalized();
    perturbations.push_back(q);
  }
  const size_t kDefaultStarts = 8;
  std::printf("%-40s %-6s %8s %8s  %-44s %6s %7s %6s %6s %6s\n",
              "perturbation (tx ty tz m, r p y deg)", "status", "before", "after",
              "residual error (m, deg)", "time", "sigma", "restart", "MIgain", "z");
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  int recovered = 0;
  if (starts.empty()) {
    for (size_t i = 0; i < kDefaultStarts; ++i) starts.push_back(static_cast<int>(i));
  }
  for (int index : starts) {
    const Vector6d& perturbation = perturbations.at(index);
    const Rigid3d start = ApplyCorrection(kitti.cam_from_lidar, perturbation);
    const RegistrationResult result = RegisterFrames({frame}, start, options);
    const PixelOffsetStats before =
        PixelOffsets(points, frame.views[0], kitti.cam_from_lidar, start, options.render);
    const PixelOffsetStats after = PixelOffsets(points, frame.views[0], kitti.cam_from_lidar,
                                                result.cam_from_lidar, options.render);
    const Vector6d error = CorrectionBetween(kitti.cam_from_lidar, result.cam_from_lidar);
    recovered += after.median_px < 1.0;
    if (const char* out = std::getenv("MI_OVERLAY")) {
      // Diagnostic picture: the photo (top), the LiDAR image at the calibration (middle) and
      // at the result (bottom), empty pixels showing the photo darkened; crop
      // MI_CROP="x0,y0,w,h" magnified 3x.
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
          RenderLidarImage(points, frame.views[0],
                           panel == 1 ? kitti.cam_from_lidar : result.cam_from_lidar,
                           options.render, &rendered);
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
      WriteGrayPng(picture, std::string(out) + "_" + std::to_string(index) + ".png");
    }
    if (std::getenv("MI_COMPARE") != nullptr) {
      // Is the result's metric above the calibration's? (Then the metric, not the search,
      // puts its maximum away from the calibration on this frame.) Every level, rendered
      // histogram and B-spline one.
      const FrameSetEvaluator evaluator({frame}, start, options);
      MetricOptions smooth = options.metric;
      smooth.smoothing = Smoothing::kBSpline;
      MetricOptions hard = options.metric;
      hard.smoothing = Smoothing::kNone;
      // The full-resolution metric on the straight line (in the correction) from the
      // calibration (t = 0) to the result (t = 1) and beyond.
      const Vector6d to_result = CorrectionBetween(kitti.cam_from_lidar, result.cam_from_lidar);
      std::printf("  line calibration->result, level 0 (%s):",
                  SmoothingName(smooth.smoothing).c_str());
      for (int k = 0; k <= 15; ++k) {
        const double t = 0.1 * k;
        std::printf(" %.1f:%.6f", t,
                    evaluator.Evaluate(ApplyCorrection(kitti.cam_from_lidar, t * to_result), 0,
                                       smooth).value);
      }
      std::printf("\n");
      for (int level = 0; level < evaluator.levels(); ++level) {
        const MetricValue a = evaluator.Evaluate(kitti.cam_from_lidar, level, smooth);
        const MetricValue b = evaluator.Evaluate(result.cam_from_lidar, level, smooth);
        std::printf("  level %d samples: calibration %.0f (mi %.5f) result %.0f (mi %.5f)\n", level,
                    a.samples, a.mi, b.samples, b.mi);
        std::printf("  level %d: %s calibration %.6f result %.6f start %.6f | none "
                    "calibration %.6f result %.6f\n",
                    level, SmoothingName(smooth.smoothing).c_str(),
                    evaluator.Evaluate(kitti.cam_from_lidar, level, smooth).value,
                    evaluator.Evaluate(result.cam_from_lidar, level, smooth).value,
                    evaluator.Evaluate(start, level, smooth).value,
                    evaluator.Evaluate(kitti.cam_from_lidar, level, hard).value,
                    evaluator.Evaluate(result.cam_from_lidar, level, hard).value);
      }
    }
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
    // The result bit for bit: equal digests = a reproduced registration.
    std::printf("  digest %016llx  metric %a  iterations %d  evaluations %d\n",
                static_cast<unsigned long long>(result.Digest()), result.metric_after.value,
                result.iterations, result.evaluations);
  }
  std::printf("median offset < 1 px after registration: %d of %zu starts\n", recovered,
              starts.size());
  return 0;
}
