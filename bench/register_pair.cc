// bench/register_pair: times the cloud registration (and each descriptor) on one pair and
// prints wall time and peak memory. Usage:
//   register_pair SOURCE TARGET [descriptor=auto] [key=value ...]
// keys: normal_radius, support_radius, max_points_features, max_points_icp, gravity (0/1),
//       paper (0/1), icp (0/1), min_keypoints, sac_ia_iterations, keypoint_threshold,
//       min_fitness, min_normal_agreement, max_resolution_spacing, … (see below);
//       truth=FILE (the true target_from_source, 16 numbers row-major: prints the error);
//       source_viewpoints=FILE, target_viewpoints=FILE (sensor positions, x y z a line);
//       conf=FILE.conf: also print the error against a Stanford .conf alignment (lines
//       "bmesh NAME tx ty tz qx qy qz qw", p_common = R(q)ᵀ·p + t, as in bun.conf; the
//       clouds are looked up by file name)
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>

#include <Eigen/Geometry>

#include "mmba/core/huge_pages.h"
#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/registration/cloud/feature_registration.h"
#include "mmba/registration/cloud/registration_settings.h"
#include "mmba/registration/cloud/scene_evaluation.h"

namespace {

// common_from_scan of every scan of a Stanford .conf file.
std::map<std::string, Eigen::Matrix4d> ReadConf(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    std::cerr << "cannot read " << path << "\n";
    std::exit(2);
  }
  std::map<std::string, Eigen::Matrix4d> out;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string kind, name;
    double t[3], q[4];
    if (!(s >> kind >> name) || kind != "bmesh") continue;
    if (!(s >> t[0] >> t[1] >> t[2] >> q[0] >> q[1] >> q[2] >> q[3])) {
      std::cerr << path << ": bad line '" << line << "'\n";
      std::exit(2);
    }
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() =
        Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized().toRotationMatrix().transpose();
    m.topRightCorner<3, 1>() = Eigen::Vector3d(t[0], t[1], t[2]);
    out[name] = m;
  }
  return out;
}

std::string BaseName(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

}  // namespace

int main(int argc, char** argv) {
  mmba::ReexecWithHugePageMalloc(argv);  // as the mmba binary does (core/huge_pages.h)
  using namespace mmba;
  if (argc < 3) {
    std::cerr << "usage: register_pair SOURCE TARGET [descriptor] [key=value ...]\n";
    return 2;
  }
  registration::CloudRegistrationOptions options;
  if (argc > 3 && !registration::ParseDescriptor(argv[3], &options.descriptor)) {
    std::cerr << "unknown descriptor " << argv[3] << "\n";
    return 2;
  }
  std::string conf, truth_file;
  for (int i = 4; i < argc; ++i) {
    const std::string kv = argv[i];
    const size_t eq = kv.find('=');
    const std::string key = kv.substr(0, eq);
    const double v = std::atof(kv.substr(eq + 1).c_str());
    const std::string value = kv.substr(eq + 1);
    std::string problem;
    if (key == "conf") conf = value;
    else if (key == "normal_radius") options.normal_radius_m = v;
    else if (key == "support_radius") options.support_radius_m = v;
    else if (key == "gravity") options.gravity_aligned = v != 0;
    else if (key == "paper") options.paper_only = v != 0;
    else if (key == "icp") options.icp = v != 0;
    else if (key == "truth") truth_file = value;
    else if (key == "search_window_m") options.search_window_m = v;
    else if (key == "search_window_deg") options.search_window_deg = v;
    else if (key == "source_viewpoints") options.source_viewpoints = registration::ReadViewpoints(value);
    else if (key == "target_viewpoints") options.target_viewpoints = registration::ReadViewpoints(value);
    // Every other setting by its name, as `register-cloud --set NAME=VALUE` (checked).
    else if (!registration::SetRegistrationSetting(key, value, &options, &problem)) {
      std::cerr << problem << "\n";
      return 2;
    }
  }
  if (std::getenv("MMBA_DEBUG") != nullptr) spdlog::set_level(spdlog::level::debug);
  Timer wall;
  const io::PointCloud source = io::ReadPointCloud(argv[1]);
  const io::PointCloud target = io::ReadPointCloud(argv[2]);
  const double read_s = wall.ElapsedSeconds();
  const registration::CloudRegistrationResult r =
      registration::RegisterClouds(source, target, options);
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::printf("points %zu / %zu, read %.3f s, %s\n", source.size(), target.size(), read_s,
              r.BriefReport().c_str());
  std::printf("spacing %.4g m, R_n %.4g m, R_s %.4g m, fine tau %.4g m, significance %.3g, "
              "resolution %.4g m (weak motions %.4g m; fine spacing %.4g m)\n",
              r.point_spacing_m, r.normal_radius_m, r.support_radius_m,
              r.fine_inlier_distance_m, r.significance, r.resolution_m, r.weak_motion_resolution_m,
              r.fine_spacing_m);
  std::printf("sigma RMS %.4g m (constraint ratio %.3g), sigma translation %.4g %.4g %.4g m, "
              "sigma rotation %.4g %.4g %.4g deg; weakest: %s\n",
              r.sigma_rms_m, r.constraint_ratio, r.sigma_translation_m.x(),
              r.sigma_translation_m.y(), r.sigma_translation_m.z(), r.sigma_rotation_deg.x(),
              r.sigma_rotation_deg.y(), r.sigma_rotation_deg.z(), r.weakest_motion.c_str());
  // truth=FILE: the true target_from_source, 16 numbers row-major.
  Eigen::Matrix4d truth = Eigen::Matrix4d::Identity();
  if (!truth_file.empty()) {
    std::ifstream in(truth_file);
    for (int i = 0; i < 16; ++i) {
      if (!(in >> truth(i / 4, i % 4))) {
        std::cerr << truth_file << ": expected 16 numbers (a row-major 4x4)\n";
        return 2;
      }
    }
  }
  auto rotation_error_deg = [&](const Eigen::Matrix4d& t) {
    const Eigen::Matrix3d dr = t.topLeftCorner<3, 3>() * truth.topLeftCorner<3, 3>().transpose();
    return std::acos(std::clamp((dr.trace() - 1.0) / 2.0, -1.0, 1.0)) * 180.0 / M_PI;
  };
  for (const auto& h : r.hypotheses) {
    std::printf("  hypothesis %-32s fitness %.3f normals %.3f conflict %.3f score %.3f",
                h.origin.c_str(), h.fitness, h.normal_agreement, h.conflict, h.score);
    if (!truth_file.empty()) {
      std::printf("  error %.3g m RMS, %.3g deg",
                  registration::TransformRmsOnCloud(source, h.target_from_source, truth),
                  rotation_error_deg(h.target_from_source));
    }
    std::printf("\n");
  }
  for (const auto& s : r.runtime) {
    std::printf("  %-22s %8.3f s wall %8.3f s CPU\n", s.stage.c_str(), s.seconds, s.cpu_seconds);
  }
  const double cpu_s = usage.ru_utime.tv_sec + usage.ru_utime.tv_usec * 1e-6 +
                      usage.ru_stime.tv_sec + usage.ru_stime.tv_usec * 1e-6;
  std::printf("wall %.3f s, CPU %.3f s, peak RSS %.1f MiB\n", wall.ElapsedSeconds(), cpu_s,
              usage.ru_maxrss / 1024.0);
  std::printf("target_from_source\n");
  for (int i = 0; i < 4; ++i) {
    std::printf("  %.9f %.9f %.9f %.9f\n", r.target_from_source(i, 0), r.target_from_source(i, 1),
                r.target_from_source(i, 2), r.target_from_source(i, 3));
  }
  for (const auto& n : r.notes) std::printf("note: %s\n", n.c_str());
  if (!truth_file.empty()) {
    std::printf("error vs %s: RMS over the source %.4g m, rotation %.4f deg, translation %.4f m\n",
                truth_file.c_str(),
                registration::TransformRmsOnCloud(source, r.target_from_source, truth),
                rotation_error_deg(r.target_from_source),
                (r.target_from_source.topRightCorner<3, 1>() - truth.topRightCorner<3, 1>()).norm());
  }
  if (!conf.empty()) {
    const std::map<std::string, Eigen::Matrix4d> scans = ReadConf(conf);
    const auto a = scans.find(BaseName(argv[1])), b = scans.find(BaseName(argv[2]));
    if (a == scans.end() || b == scans.end()) {
      std::cerr << conf << " has no line for " << BaseName(argv[1]) << " or "
                << BaseName(argv[2]) << "\n";
      return 2;
    }
    const Eigen::Matrix4d truth = b->second.inverse() * a->second;
    const Eigen::Matrix3d dr =
        r.target_from_source.topLeftCorner<3, 3>() * truth.topLeftCorner<3, 3>().transpose();
    const double angle =
        std::acos(std::clamp((dr.trace() - 1.0) / 2.0, -1.0, 1.0)) * 180.0 / M_PI;
    const double dt =
        (r.target_from_source.topRightCorner<3, 1>() - truth.topRightCorner<3, 1>()).norm();
    std::printf("error vs %s: rotation %.4f deg, translation %.4f mm\n", conf.c_str(), angle,
                1000.0 * dt);
  }
  return r.ok() ? 0 : 3;
}
