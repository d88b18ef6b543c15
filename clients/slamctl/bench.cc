// slamctl bench: runs a core solver on a dataset and reports time, iterations, chi2 and memory.
#include <sys/resource.h>

#include <cstdio>
#include <string>

#include "clients/slamctl/commands.h"
#include "clients/slamctl/json_writer.h"
#include "core/base/timing.h"
#include "core/batch/batch_solver.h"
#include "core/batch/initialization.h"
#include "core/io/dataset.h"

namespace slamd::clients {
namespace {

using core::BatchParams;

struct BenchOptions {
  std::string dataset;
  std::string solver = "batch";
  bool json = false;
  std::string algorithm = "lm";
  std::string damping = "identity";
  std::string init = "file";
  std::string isam_noise = "sqrt-information";
  double anchor_sigma = 1e-3;
  int init_chunk = 100;
  std::string output;
  BatchParams batch;
};

double PeakRssMb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

[[noreturn]] void Fail(int code, const std::string& message) {
  std::fprintf(stderr, "slamctl bench: %s\n", message.c_str());
  throw CommandExit{code};
}

void RunBench(const BenchOptions& opt) {
  core::ReadOptions read;
  read.isam_noise = opt.isam_noise == "covariance" ? core::ReadOptions::IsamNoise::kCovariance
                                                   : core::ReadOptions::IsamNoise::kSqrtInformation;
  read.compose_initial_from_odometry = opt.init == "odometry";
  core::Stopwatch read_timer;
  core::Result<core::Dataset> loaded = core::ReadDataset(opt.dataset, read);
  if (!loaded.ok()) Fail(kExitFailure, loaded.status().ToString());
  const double read_s = read_timer.Seconds();
  const core::Dataset& data = *loaded;

  core::FactorGraph graph = data.graph;
  if (!data.poses.empty()) {
    const core::Status anchored = core::AddGaugePrior(data.initial, data.poses.front(), opt.anchor_sigma, &graph);
    if (!anchored.ok()) Fail(kExitFailure, anchored.ToString());
  }
  core::Stopwatch init_timer;
  core::Values initial = data.initial;
  if (opt.init != "odometry") {  // odometry composition happens while reading
    core::Result<core::Values> init = core::MakeInitialGuess(
        *core::ParseInitialGuess(opt.init), data.graph, data.initial, data.poses, opt.init_chunk);
    if (!init.ok()) Fail(kExitFailure, init.status().ToString());
    initial = std::move(init).value();
  }
  const double init_s = init_timer.Seconds();

  BatchParams params = opt.batch;
  params.algorithm = opt.algorithm == "gn" ? BatchParams::Algorithm::kGaussNewton
                                           : BatchParams::Algorithm::kLevenbergMarquardt;
  params.damping = opt.damping == "diagonal" ? BatchParams::Damping::kDiagonal
                                             : BatchParams::Damping::kIdentity;
  const core::BatchResult result = core::Optimize(graph, initial, params);
  const core::BatchSummary& s = result.summary;
  if (opt.json) {
    JsonWriter phases;
    phases.Add("setup", s.setup_s)
        .Add("order", s.order_s)
        .Add("linearize", s.linearize_s)
        .Add("factorize", s.factorize_s)
        .Add("solve", s.solve_s)
        .Add("evaluate", s.evaluate_s);
    JsonWriter out;
    out.Add("dataset", opt.dataset)
        .Add("poses", data.poses.size())
        .Add("landmarks", data.landmarks.size())
        .Add("factors", data.graph.size())
        .Add("solver", opt.solver)
        .Add("algorithm", opt.algorithm)
        .Add("init", opt.init)
        .Add("iterations", s.iterations)
        .Add("linear_solves", s.linear_solves)
        .Add("initial_chi2", s.initial_chi2)
        .Add("final_chi2", s.final_chi2)
        .Add("termination", core::BatchTerminationName(s.termination))
        .Add("status", result.status.ToString())
        .Add("read_s", read_s)
        .Add("init_s", init_s)
        .Add("total_s", s.total_s)
        .Add("phase_s", phases)
        .Add("peak_rss_mb", PeakRssMb());
    std::printf("%s\n", out.str().c_str());
  } else {
    std::printf("%s: %zu poses, %zu landmarks, %zu factors (read in %.3f s)\n",
                opt.dataset.c_str(), data.poses.size(), data.landmarks.size(), data.graph.size(),
                read_s);
    std::printf("initial guess: %s (%.4f s)\n", opt.init.c_str(), init_s);
    std::printf("%s %s: %s\n", opt.solver.c_str(), opt.algorithm.c_str(), s.Brief().c_str());
    std::printf("phases: setup %.4f s (ordering %.4f s), linearize %.4f s, factorize %.4f s, solve %.4f s, "
                "evaluate %.4f s; peak RSS %.1f MB\n",
                s.setup_s, s.order_s, s.linearize_s, s.factorize_s, s.solve_s, s.evaluate_s, PeakRssMb());
  }
  if (!result.status.ok()) Fail(kExitFailure, result.status.ToString());
  if (!opt.output.empty()) {
    core::Dataset solved = data;
    solved.initial = result.values;
    const core::Status written = core::WriteG2o(solved, opt.output);
    if (!written.ok()) Fail(kExitFailure, written.ToString());
  }
}

}  // namespace

void RegisterBench(CLI::App& app) {
  auto opt = std::make_shared<BenchOptions>();
  CLI::App* cmd = app.add_subcommand("bench", "Run a solver offline on a dataset and report time, "
                                              "iterations, chi2 and peak memory");
  cmd->add_option("dataset", opt->dataset, "Dataset file (g2o 2D/3D, TORO .graph, iSAM .txt)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--solver", opt->solver, "Solver to run")
      ->check(CLI::IsMember({"batch"}))
      ->capture_default_str();
  cmd->add_flag("--json", opt->json, "Print one JSON object instead of a human summary");
  cmd->add_option("--algorithm", opt->algorithm, "Batch algorithm: lm (Levenberg-Marquardt) or gn")
      ->check(CLI::IsMember({"lm", "gn"}))
      ->capture_default_str();
  cmd->add_option("--damping", opt->damping, "LM damping: identity (H + λI) or diagonal (H + λ·diag H)")
      ->check(CLI::IsMember({"identity", "diagonal"}))
      ->capture_default_str();
  cmd->add_option("--init", opt->init,
                  "Initial guess: file (vertices in the file, odometry where missing) or "
                  "odometry (compose along odometry in file order, ignoring vertices), "
                  "spanning-tree (compose along the most certain edges) or lago (linear "
                  "orientation then position estimate; 2D) or incremental (re-optimise "
                  "while adding poses in order; 2D)")
      ->check(CLI::IsMember({"file", "odometry", "spanning-tree", "lago", "incremental"}))
      ->capture_default_str();
  cmd->add_option("--isam-noise", opt->isam_noise,
                  "How iSAM-format noise columns are read: sqrt-information or covariance "
                  "(GTSAM's victoria_park.txt)")
      ->check(CLI::IsMember({"sqrt-information", "covariance"}))
      ->capture_default_str();
  cmd->add_option("--init-chunk", opt->init_chunk,
                  "--init incremental: poses added between re-optimisations")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--anchor-sigma", opt->anchor_sigma,
                  "Sigma of the prior that anchors the first pose at its initial value")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("-o,--output", opt->output, "Write the optimised graph as a g2o file");
  cmd->add_option("--max-iterations", opt->batch.max_iterations)->capture_default_str();
  cmd->add_option("--relative-tolerance", opt->batch.relative_tolerance)->capture_default_str();
  cmd->add_option("--absolute-tolerance", opt->batch.absolute_tolerance)->capture_default_str();
  cmd->add_option("--initial-lambda", opt->batch.initial_lambda)->capture_default_str();
  cmd->add_flag("-v,--verbose", opt->batch.verbosity, "Print one line per LM iteration to stderr");
  cmd->callback([opt] {
    const core::Status valid = opt->batch.Validate();
    if (!valid.ok()) Fail(kExitUsage, valid.message());
    RunBench(*opt);
  });
}

}  // namespace slamd::clients
