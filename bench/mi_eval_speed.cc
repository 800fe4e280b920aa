// Cost of one MI evaluation: the synthetic street of mi_speed (940×452
// pinhole view, N million points with intensity), evaluated at the true pose and at small
// offsets, per pyramid level, by rendering the z-buffer (FrameSetEvaluator::Evaluate) and
// from point samples with the visibility frozen at the true pose (point_samples.h).
//   mi_eval_speed [MILLION_POINTS=1] [REPEATS=20] [THREADS=2] [PER_POINT=1] [RENDERED=1]
// RENDERED = 0: the sampled evaluations only (a profile of them alone).
// Prints per level: samples, ms per evaluation (wall, threads as given; and CPU of this
// thread, the comparable figure on a shared machine with THREADS=1), the largest difference
// between the two metrics over the offsets, and the sum of the sampled metric over the
// offsets (to compare builds: equal up to rounding when only the speed changed). "least" =
// the smallest CPU time of one evaluation over the repeats (the least disturbed by other load).
#include <time.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "mmba/core/progress.h"
#include "mmba/registration/mi/mi_registration.h"
#include "registration/mi/synthetic_scene.h"

using namespace mmba;
using namespace mmba::registration::mi;

static double ThreadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

int main(int argc, char** argv) {
  const double million = argc > 1 ? std::stod(argv[1]) : 1.0;
  const int repeats = argc > 2 ? std::atoi(argv[2]) : 20;
  const double area_m2 = 1114.0;  // surfaces of testing::StreetScene(), as mi_speed
  io::PointCloud cloud = testing::StreetCloud(std::sqrt(area_m2 / (million * 1e6)));
  const sensors::Camera camera = testing::StreetCamera(940, 452, 470.0);
  const Rigid3d truth = testing::StreetCamFromLidar(Eigen::Vector3d(0.5, 0.3, 0.2), 4.0);
  const GrayImage photo = testing::StreetPhoto(camera, truth);
  const LidarPoints points = PrepareLidarPoints(cloud);
  Frame frame;
  frame.name = "street";
  frame.views = MakeViews(photo, camera, ViewOptions(), "street");
  frame.points = &points;
  RegistrationOptions options;
  options.point_samples = true;  // the default; explicit here
  if (argc > 3) options.threads = std::atoi(argv[3]);
  const bool per_point = argc > 4 ? std::atoi(argv[4]) != 0 : true;
  const bool with_rendered = argc > 5 ? std::atoi(argv[5]) != 0 : true;
  const FrameSetEvaluator evaluator({frame}, truth, options);
  std::printf("%.2f M points, threads %d, %s\n", points.size() / 1e6, options.threads,
              per_point ? "one sample per point" : "one sample per pixel");
  for (int level = 0; level < evaluator.levels(); ++level) {
    Timer build;
    const FrameSetEvaluator::SampleSet set = evaluator.MakeSampleSet(truth, level, per_point);
    const double build_ms = 1e3 * build.ElapsedSeconds();
    double max_difference = 0;
    double rendered_ms = 0, sampled_ms = 0, rendered_cpu_ms = 0, sampled_cpu_ms = 0;
    double sampled_sum = 0;
    double rendered_min_ms = 1e9, sampled_min_ms = 1e9;  // least CPU: robust to other load
    for (int k = 0; k < repeats; ++k) {
      Vector6d offset;  // up to ±0.01 m / ±0.1° (≈ 1 px at level 0)
      for (int i = 0; i < 6; ++i) offset[i] = (i < 3 ? 0.01 : 0.1) * std::sin(1.7 * k + i);
      const Rigid3d pose = ApplyCorrection(truth, offset);
      Timer a;
      double cpu = ThreadCpuSeconds();
      const double rendered =
          with_rendered ? evaluator.Evaluate(pose, level, options.metric).value : NAN;
      rendered_ms += 1e3 * a.ElapsedSeconds();
      rendered_cpu_ms += 1e3 * (ThreadCpuSeconds() - cpu);
      rendered_min_ms = std::min(rendered_min_ms, 1e3 * (ThreadCpuSeconds() - cpu));
      Timer b;
      cpu = ThreadCpuSeconds();
      const double sampled = evaluator.Evaluate(pose, level, options.metric, &set).value;
      sampled_ms += 1e3 * b.ElapsedSeconds();
      sampled_cpu_ms += 1e3 * (ThreadCpuSeconds() - cpu);
      sampled_min_ms = std::min(sampled_min_ms, 1e3 * (ThreadCpuSeconds() - cpu));
      sampled_sum += sampled;
      max_difference = std::max(max_difference, std::abs(rendered - sampled));
    }
    size_t visible = 0;
    for (const ViewSamples& v : set.views) visible += v.points();
    std::printf("level %d: %zu visible points, %zu samples, build %.1f ms; rendered %.2f ms "
                "(cpu %.2f, least %.2f), sampled %.2f ms (cpu %.2f, least %.2f) per evaluation; largest |difference| "
                "%.2e (NMI); sampled sum %.12f (%a)\n",
                level, visible, set.samples, build_ms, rendered_ms / repeats,
                rendered_cpu_ms / repeats, rendered_min_ms, sampled_ms / repeats,
                sampled_cpu_ms / repeats, sampled_min_ms,
                max_difference, sampled_sum, sampled_sum);
  }
  return 0;
}
