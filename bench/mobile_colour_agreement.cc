// How well `mmba adjust` coloured a simulated mobile cloud: the colours of
// <out>/<id>_corrected.ply against the simulated scene itself. For an even sample of the points,
// the surface at the point's TRUE position (truth/mobile_lidar_true.ply, same order) is found
// by a ray from the true rig frame nearest in time; its grey as the renderer made it — the
// procedural albedo with the sun's Lambert shading and gamma 1/2.2 (src/sim/render.cc, default
// RenderOptions) — is compared with the cloud's grey: Pearson r, mean |difference|, and r for
// the points outside the photo block's box (coloured by the rig images alone). The same measure
// as tests/adjust/mobile_test.cc, for a whole run (streamed: any cloud size).
//
// Usage: mobile_colour_agreement SIM_DIR OUT_DIR [CLOUD_ID=mls] [SAMPLES=20000]
// SIM_DIR: `mmba simulate --scene gate|cathedral` output (default scene options).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mmba/geometry/rigid3d.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/sim/ray_caster.h"
#include "mmba/sim/render.h"
#include "mmba/sim/scenes.h"
#include "mmba/sim/texture.h"
#include "mmba/stats/correlation.h"

using json = nlohmann::json;
using mmba::stats::Pearson;

namespace {

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    std::fprintf(stderr, "cannot read %s\n", path.c_str());
    std::exit(2);
  }
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s SIM_DIR OUT_DIR [CLOUD_ID=mls] [SAMPLES=20000]\n", argv[0]);
    return 2;
  }
  const std::string sim = argv[1], out = argv[2];
  const std::string id = argc > 3 ? argv[3] : "mls";
  const size_t samples = argc > 4 ? std::stoul(argv[4]) : 20000;
  const json truth = json::parse(ReadText(sim + "/truth/truth.json"));
  const std::string name = truth["scene"]["name"];
  const uint64_t seed = truth["scene"]["seed"];
  mmba::sim::SimScene scene;
  if (name == "gate") {
    scene = mmba::sim::MakeGateScene(mmba::sim::GateOptions(), seed);
  } else if (name == "cathedral") {
    scene = mmba::sim::MakeCathedralScene(mmba::sim::CathedralOptions(), seed);
  } else {
    std::fprintf(stderr, "%s/truth/truth.json: scene.name '%s': expected gate or cathedral\n", sim.c_str(), name.c_str());
    return 2;
  }
  const mmba::sim::RayCaster caster(scene.mesh);
  const mmba::sim::RenderOptions render;
  const Eigen::Vector3d sun = render.sun_direction.normalized();
  // True rig frame centres with their times.
  std::map<std::string, double> times;
  {
    std::istringstream csv(ReadText(sim + "/rig_frames.csv"));
    for (std::string line; std::getline(csv, line);) {
      if (line.empty() || line[0] == '#' || line.rfind("frame,", 0) == 0) continue;
      times[line.substr(0, line.find(','))] = std::stod(line.substr(line.find(',') + 1));
    }
  }
  std::vector<std::pair<double, Eigen::Vector3d>> frames;
  for (const json& f : truth["rig"]["frames"]) {
    const json& q = f["rig_from_world"]["qvec_wxyz"];
    const json& t = f["rig_from_world"]["tvec"];
    const mmba::Rigid3d rig_from_world(Eigen::Quaterniond(q[0], q[1], q[2], q[3]), Eigen::Vector3d(t[0], t[1], t[2]));
    frames.push_back({times.at(f["name"].get<std::string>()), rig_from_world.Inverse().translation});
  }
  std::sort(frames.begin(), frames.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  // The photo block's box: its tie points, 1 m around (as the adjustment's).
  const mmba::io::PointCloud ties = mmba::io::ReadPly(out + "/tie_points.ply");
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e30), hi = -lo;
  for (const Eigen::Vector3d& p : ties.points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  lo.array() -= 1.0;
  hi.array() += 1.0;
  // An even sample of the coloured cloud (index, colour, time), then the same true points.
  struct Sample {
    size_t index;
    std::array<uint8_t, 3> rgb;
    double time;
    Eigen::Vector3d truth;
  };
  std::vector<Sample> picked;
  size_t total = 0, grey = 0, stride = 1;
  mmba::io::StreamPointCloud(out + "/" + id + "_corrected.ply", 1000000,
                             [&](const mmba::io::PointCloud& chunk, size_t first, size_t n) {
    if (first == 0) stride = std::max<size_t>(1, n / samples);
    total = n;
    if (chunk.colors.size() != chunk.size()) {
      std::fprintf(stderr, "%s_corrected.ply has no colours\n", id.c_str());
      std::exit(3);
    }
    for (size_t i = 0; i < chunk.size(); ++i) {
      const bool is_grey = chunk.colors[i] == std::array<uint8_t, 3>{128, 128, 128};
      grey += is_grey ? 1 : 0;
      if ((first + i) % stride == 0) picked.push_back({first + i, chunk.colors[i], chunk.time[i], Eigen::Vector3d::Zero()});
    }
  });
  size_t next = 0;
  mmba::io::StreamPointCloud(sim + "/truth/mobile_lidar_true.ply", 1000000,
                             [&](const mmba::io::PointCloud& chunk, size_t first, size_t) {
    while (next < picked.size() && picked[next].index < first + chunk.size()) {
      picked[next].truth = chunk.points[picked[next].index - first];
      ++next;
    }
  });
  std::vector<std::pair<double, double>> all, rig_only;
  for (const Sample& s : picked) {
    if (s.rgb == std::array<uint8_t, 3>{128, 128, 128}) continue;
    const auto nearest = std::min_element(frames.begin(), frames.end(), [&](const auto& a, const auto& b) {
      return std::abs(a.first - s.time) < std::abs(b.first - s.time);
    });
    const Eigen::Vector3d ray = s.truth - nearest->second;
    const mmba::sim::RayHit hit = caster.Intersect(nearest->second, ray, 0.0, ray.norm() + 0.1);
    if (!hit.hit || (hit.point - s.truth).norm() > 0.03) continue;
    const mmba::sim::Material& material = scene.mesh.materials[scene.mesh.triangle_material[hit.triangle]];
    if (material.material_class != mmba::sim::MaterialClass::kDiffuse) continue;
    const double albedo = mmba::sim::Albedo(material, hit.point, hit.normal, seed);
    const double radiance = albedo * (render.ambient + (1.0 - render.ambient) * std::max(0.0, hit.normal.dot(sun)));
    const double expected = 255.0 * std::pow(std::clamp(radiance * render.exposure, 0.0, 1.0), 1.0 / 2.2);
    const double g = (s.rgb[0] + s.rgb[1] + s.rgb[2]) / 3.0;
    all.push_back({expected, g});
    if (!((s.truth.array() >= lo.array()).all() && (s.truth.array() <= hi.array()).all())) rig_only.push_back({expected, g});
  }
  if (all.size() < 10) {
    std::fprintf(stderr, "only %zu sample points on diffuse surfaces seen from their nearest frame\n", all.size());
    return 3;
  }
  double mean_abs = 0.0;
  for (const auto& [a, b] : all) mean_abs += std::abs(a - b);
  // Mid-grey marks a point no image saw, but a grey image also gives it where it reads 128:
  // the fraction below is a lower bound (report.json mobile_lidar_coloured has the count).
  std::printf("%s: %zu points, %.2f %% not mid-grey (%zu mid-grey: unseen, or seen at 128); against the scene over "
              "%zu sampled points: r = %.3f, "
              "mean |grey difference| %.1f; outside the photo block (rig images alone) %zu points: r = %.3f\n",
              name.c_str(), total, 100.0 * (total - grey) / total, grey, all.size(), Pearson(all),
              mean_abs / all.size(), rig_only.size(), rig_only.size() > 10 ? Pearson(rig_only) : NAN);
  return 0;
}
