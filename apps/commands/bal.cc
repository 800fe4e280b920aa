// mmba bal: solve a BAL problem with the settings of Ceres' examples/bundle_adjuster.
#include <iostream>

#include <nlohmann/json.hpp>

#include "command.h"
#include "mmba/core/atomic_file.h"
#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "mmba/io/bal.h"
#include "mmba/problem/bal_solver.h"
#include "mmba/core/version.h"

namespace mmba::app {
namespace {

struct BalArgs {
  std::string file;
  int threads = 2;
  int max_iterations = 50;
  std::string json;
  bool autodiff = false;
};

int RunBal(const BalArgs& args) {
  Timer wall;
  BalSolveOptions options;
  options.num_threads = args.threads;
  options.max_iterations = args.max_iterations;
  options.analytic_jacobian = !args.autodiff;
  options.log_progress = GetVerbosity() != Verbosity::kQuiet;
  std::string error;
  if (!options.Check(&error)) throw InputError::Message("options", error);
  RefuseToOverwriteInputs({{"--json", args.json}}, {{"FILE", args.file}});

  Timer read_timer;
  io::BalProblem problem = io::ReadBal(args.file);
  const double read_seconds = read_timer.ElapsedSeconds();
  spdlog::info("read {}: {} cameras, {} points, {} observations ({:.2f} s)", args.file,
               problem.num_cameras, problem.num_points, problem.observations.size(),
               read_seconds);
  const BalSolveResult result = SolveBal(&problem, options);

  nlohmann::json json = {
      {"file", args.file},
      {"status", result.status},
      {"reason", result.reason},
      {"num_cameras", result.num_cameras},
      {"num_points", result.num_points},
      {"num_observations", result.num_observations},
      {"num_residuals", result.num_residuals},
      {"initial_cost", result.initial_cost},
      {"final_cost", result.final_cost},
      {"initial_rms", result.initial_rms},
      {"final_rms", result.final_rms},
      {"iterations", result.iterations},
      {"solve_seconds", result.solve_seconds},
      {"read_seconds", read_seconds},
      {"wall_seconds", wall.ElapsedSeconds()},
      {"threads", args.threads},
      {"jacobian", args.autodiff ? "autodiff" : "analytic"},
      {"settings", "LEVENBERG_MARQUARDT, SPARSE_SCHUR (SuiteSparse), JACOBI, no loss"},
  };
  RecordBuild(&json);
  if (!args.json.empty()) {
    WriteFileAtomically(args.json, [&](std::ostream& out) { out << json.dump(2) << "\n"; });
  }
  std::cout << "mmba bal: " << result.status << " (" << result.reason << ")\n"
            << "  " << result.num_cameras << " cameras, " << result.num_points << " points, "
            << result.num_observations << " observations\n"
            << "  cost " << result.initial_cost << " -> " << result.final_cost
            << " (RMS " << result.initial_rms << " -> " << result.final_rms << ")\n"
            << "  " << result.iterations << " iterations, solve " << result.solve_seconds
            << " s\n";
  if (!args.json.empty()) std::cout << "  report: " << args.json << "\n";
  if (result.status == "failed") throw CommandFailed("BAL solve failed: " + result.reason);
  return kExitOk;
}

std::function<int()> SetupBal(CLI::App& app, CommonOptions* common) {
  auto args = std::make_shared<BalArgs>();
  CLI::App* sub = app.add_subcommand(
      "bal", "Solve a Bundle Adjustment in the Large problem (Ceres bundle_adjuster settings)");
  sub->add_option("file,--input", args->file, "BAL problem file, as --input or the first argument")->required();
  sub->add_option("--threads", args->threads, "Threads")->capture_default_str();
  sub->add_option("--max-iterations", args->max_iterations, "Levenberg-Marquardt iterations")
      ->capture_default_str();
  sub->add_option("--json", args->json, "Write a JSON report to this file");
  sub->add_flag("--autodiff", args->autodiff,
                "Use automatic differentiation (Ceres' example functor) instead of the "
                "analytic Jacobian");
  AddCommonOptions(sub, common);
  return [args] { return RunBal(*args); };
}

}  // namespace

MMBA_REGISTER_COMMAND(20, SetupBal);

}  // namespace mmba::app
