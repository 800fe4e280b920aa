// Survey benchmark: a simulated 3-D total-station network of 1,000 points and
// ~10,000 observations (directions, slope distances, zenith angles from 334 set-ups to
// their 10 nearest points) is adjusted with the covariance of every point and the statistics
// of every observation; prints wall time per stage and peak memory.
//   build-*/bench/survey_network [num_points] [neighbours]
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <iostream>
#include <random>

#include "mmba/survey/adjust.h"

using namespace mmba::survey;

int main(int argc, char** argv) {
  const int num_points = argc > 1 ? std::atoi(argv[1]) : 1000;
  const int neighbours = argc > 2 ? std::atoi(argv[2]) : 10;
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> uniform(0.0, 3000.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  SurveyNetwork net;
  net.source = "simulated";
  net.sigma0_apriori = 10.0;
  std::vector<Eigen::Vector3d> truth;
  for (int i = 0; i < num_points; ++i) {
    truth.emplace_back(uniform(rng), uniform(rng), 200.0 + 0.02 * uniform(rng));
    SurveyPoint& p = net.GetOrAdd("P" + std::to_string(i), i + 1);
    const bool control = i < 4;
    p.xy = p.z = control ? CoordStatus::kFixed : CoordStatus::kAdjusted;
    // Approximate coordinates: truth + 0.5 m noise (control exact).
    const Eigen::Vector3d noise(gauss(rng), gauss(rng), gauss(rng));
    p.coords = truth[i] + (control ? Eigen::Vector3d::Zero() : Eigen::Vector3d(0.5 * noise));
    p.has_xy = p.has_z = p.given_xy = p.given_z = true;
  }
  const double sigma_dir = 5.0 * M_PI / 2.0e6, sigma_zen = 10.0 * M_PI / 2.0e6;
  const double sigma_dist = 0.002;
  int num_obs = 0;
  for (int s = 0; s < num_points; s += 3) {
    std::vector<std::pair<double, int>> near;
    for (int j = 0; j < num_points; ++j) {
      if (j != s) near.emplace_back((truth[j] - truth[s]).head<2>().norm(), j);
    }
    std::partial_sort(near.begin(), near.begin() + neighbours, near.end());
    Cluster c;
    c.type = Cluster::Type::kStandpoint;
    c.station = "P" + std::to_string(s);
    const double orientation = uniform(rng) / 3000.0 * 2 * M_PI;
    for (int k = 0; k < neighbours; ++k) {
      const int t = near[k].second;
      const Eigen::Vector3d d = truth[t] - truth[s];
      Observation o;
      o.from = c.station;
      o.to = "P" + std::to_string(t);
      o.kind = ObsKind::kDirection;
      o.value = std::atan2(d.x(), d.y()) - orientation + sigma_dir * gauss(rng);
      o.sigma = sigma_dir;
      c.observations.push_back(o);
      o.kind = ObsKind::kSlopeDistance;
      o.value = d.norm() + sigma_dist * gauss(rng);
      o.sigma = sigma_dist;
      c.observations.push_back(o);
      o.kind = ObsKind::kZenithAngle;
      o.value = std::atan2(d.head<2>().norm(), d.z()) + sigma_zen * gauss(rng);
      o.sigma = sigma_zen;
      c.observations.push_back(o);
      num_obs += 3;
    }
    const int n = static_cast<int>(c.observations.size());
    c.covariance = Eigen::MatrixXd::Zero(n, n);
    for (int i = 0; i < n; ++i) c.covariance(i, i) = std::pow(c.observations[i].sigma, 2);
    net.clusters.push_back(c);
  }
  std::cout << "points " << num_points << ", set-ups " << net.clusters.size()
            << ", observations " << num_obs << "\n";
  const auto t0 = std::chrono::steady_clock::now();
  SurveyAdjustment adj = AdjustNetwork(&net, SurveyAdjustOptions());
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  double max_error = 0.0;
  int unobserved = 0;
  for (int i = 0; i < num_points; ++i) {
    if (i >= 4 && !adj.statistics.IsFree(net.points[i].xy_block())) {
      ++unobserved;  // no observation reaches it: left out, as Gama does
      continue;
    }
    max_error = std::max(max_error, (net.points[i].coords - truth[i]).norm());
  }
  double max_sigma = 0.0;
  for (const SurveyPoint& p : net.points) {
    const Eigen::Matrix3d cov = PointCovariance(adj, net, p);
    max_sigma = std::max(max_sigma, std::sqrt(cov.trace()));
  }
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::cout << "status " << adj.status << ", iterations " << adj.iterations << "\n"
            << "stages: prepare (approximations, robust pre-adjustment, datum check) "
            << adj.prepare_seconds << " s, Ceres solve " << adj.solve_seconds
            << " s, statistics (cofactor, redundancy, tests) " << adj.statistics_seconds
            << " s\n"
            << "unknowns " << adj.statistics.num_unknowns << ", dof "
            << adj.statistics.degrees_of_freedom << ", sigma0 ratio "
            << adj.statistics.sigma0_ratio << "\n"
            << "cofactor " << adj.statistics.cofactor.rows() << "x"
            << adj.statistics.cofactor.cols() << ", stored entries "
            << adj.statistics.cofactor.StoredEntries() << ", max point sigma (3-D) "
            << max_sigma * 1000
            << " mm, max error vs truth " << max_error * 1000 << " mm (" << unobserved
            << " points without observations)\n"
            << "total wall time " << seconds << " s, peak memory " << usage.ru_maxrss / 1024.0
            << " MiB\n";
  return adj.converged ? 0 : 3;
}
