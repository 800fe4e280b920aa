// mmba bal against a plain Ceres solve of the same BAL problem with the same settings
// (Ceres examples/bundle_adjuster: LM, SPARSE_SCHUR/SuiteSparse, JACOBI, no loss).
//
//   build/bench/bal_solve FILE.txt [FILE2.txt ...] [--benchmark_repetitions=3]
//
// "plain_ceres": Ceres' example functor (autodiff) and Ceres' own ordering search, i.e. what
// a user gets from Ceres without mmba. "mmba": SolveBal (analytic Jacobian, points-first
// ordering given explicitly). Counters: final_cost (½Σr²), iterations.
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include <ceres/ceres.h>

#include "mmba/factors/snavely_reprojection_error.h"
#include "mmba/io/bal.h"
#include "mmba/problem/bal_solver.h"

namespace {

void PlainCeres(benchmark::State& state, const std::string& path, int threads) {
  const mmba::io::BalProblem original = mmba::io::ReadBal(path);
  double final_cost = 0.0;
  int iterations = 0;
  for (auto _ : state) {
    state.PauseTiming();
    mmba::io::BalProblem bal = original;
    ceres::Problem problem;
    for (const auto& obs : bal.observations) {
      problem.AddResidualBlock(
          mmba::factors::SnavelyReprojectionErrorAutoDiff::Create(obs.x, obs.y), nullptr,
          bal.mutable_camera(obs.camera_index), bal.mutable_point(obs.point_index));
    }
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::SPARSE_SCHUR;
    options.preconditioner_type = ceres::JACOBI;
    options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
    options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    options.max_num_iterations = 50;
    options.num_threads = threads;
    options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    state.ResumeTiming();
    ceres::Solve(options, &problem, &summary);
    final_cost = summary.final_cost;
    iterations = static_cast<int>(summary.iterations.size()) - 1;
  }
  state.counters["final_cost"] = final_cost;
  state.counters["iterations"] = iterations;
}

void Mmba(benchmark::State& state, const std::string& path, int threads) {
  const mmba::io::BalProblem original = mmba::io::ReadBal(path);
  double final_cost = 0.0;
  int iterations = 0;
  for (auto _ : state) {
    state.PauseTiming();
    mmba::io::BalProblem bal = original;
    mmba::BalSolveOptions options;
    options.num_threads = threads;
    options.log_progress = false;
    state.ResumeTiming();
    const mmba::BalSolveResult result = mmba::SolveBal(&bal, options);
    final_cost = result.final_cost;
    iterations = result.iterations;
  }
  state.counters["final_cost"] = final_cost;
  state.counters["iterations"] = iterations;
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i) files.emplace_back(argv[i]);
  if (files.empty()) {
    fprintf(stderr, "usage: %s BAL_FILE [BAL_FILE ...] [benchmark flags]\n", argv[0]);
    return 2;
  }
  for (const std::string& file : files) {
    const std::string name = file.substr(file.find_last_of('/') + 1);
    benchmark::RegisterBenchmark(("plain_ceres/" + name).c_str(), PlainCeres, file, 2)
        ->Unit(benchmark::kMillisecond)->UseRealTime();
    benchmark::RegisterBenchmark(("mmba/" + name).c_str(), Mmba, file, 2)
        ->Unit(benchmark::kMillisecond)->UseRealTime();
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
