// slamctl bench: runs a core solver on a dataset and reports time, iterations, chi2 and memory.
// The options live here; the runners are bench_batch.cc, bench_isam2.cc and bench_ba.cc.
#include "clients/slamctl/bench.h"

#include <sys/resource.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "clients/slamctl/plot_reconstruction.h"
#include "clients/slamctl/robustify.h"
#include "clients/slamctl/trajectory_error.h"
#include "core/ba/reconstruction_graph.h"
#include "core/base/timing.h"
#include "core/io/sfm_io.h"

namespace slamd::clients {
namespace bench {

double PeakRssMb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

void Fail(int code, const std::string& message) {
  std::fprintf(stderr, "slamctl bench: %s\n", message.c_str());
  throw CommandExit{code};
}

namespace {

// A reconstruction's bundle adjustment problem as a factor graph (core/ba/reconstruction_graph.h),
// --robust on every observation.
core::Dataset LoadReconstruction(const BenchOptions& opt) {
  core::Result<core::Reconstruction> r = core::ReadReconstruction(opt.dataset);
  if (!r.ok()) Fail(kExitFailure, r.status().ToString());
  core::Result<core::ReconstructionGraph> built =
      core::BuildReconstructionGraph(*r, {.robust = opt.robust});
  if (!built.ok()) Fail(kExitFailure, built.status().ToString());
  core::Dataset data;
  data.path = opt.dataset;
  data.is_3d = true;
  data.graph = std::move(built->graph);
  data.initial = std::move(built->values);
  data.poses = std::move(built->images);
  data.landmarks = std::move(built->points);
  data.num_landmark_observations = data.graph.size();
  return data;
}

}  // namespace

// -o: PLY for *.ply, BAL for *.bal / *.txt, a COLMAP text model (a directory) otherwise.
core::Status WriteReconstruction(const core::Reconstruction& r, const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".ply") return core::WritePly(r, path);
  if (ext == ".bal" || ext == ".txt") return core::WriteBal(r, path);
  std::error_code error;
  std::filesystem::create_directories(path, error);
  if (error) return core::IoError(path + ": " + error.message());
  return core::WriteColmapText(r, path);
}

core::Dataset Load(const BenchOptions& opt, double* read_s, std::size_t* loop_closures) {
  if (plot::IsReconstructionPath(opt.dataset)) {
    core::Stopwatch timer;
    core::Dataset data = LoadReconstruction(opt);
    *read_s = timer.Seconds();
    if (loop_closures != nullptr) *loop_closures = 0;
    return data;
  }
  core::ReadOptions read;
  read.isam_noise = opt.isam_noise == "covariance" ? core::ReadOptions::IsamNoise::kCovariance
                                                   : core::ReadOptions::IsamNoise::kSqrtInformation;
  read.compose_initial_from_odometry = opt.init == "odometry";
  core::Stopwatch timer;
  core::Result<core::Dataset> loaded = core::ReadDataset(opt.dataset, read);
  if (!loaded.ok()) Fail(kExitFailure, loaded.status().ToString());
  *read_s = timer.Seconds();
  core::Dataset data = std::move(loaded).value();
  if (!opt.robust.is_none()) {
    data.graph = RobustifyLoopClosures(data.graph, opt.robust, loop_closures);
  } else if (loop_closures != nullptr) {
    *loop_closures = 0;
    for (const core::FactorPtr& f : data.graph) *loop_closures += IsLoopClosure(*f) ? 1 : 0;
  }
  return data;
}

void Ate(const BenchOptions& opt, const core::Values& estimate, AccuracyReport* report) {
  if (opt.ground_truth.empty()) return;
  core::Result<core::Values> truth = ReadGroundTruth(opt.ground_truth);
  if (!truth.ok()) Fail(kExitFailure, "ground truth: " + truth.status().ToString());
  core::Result<TrajectoryError> ate = AbsoluteTrajectoryError(estimate, *truth);
  if (!ate.ok())
    Fail(kExitFailure, "ground truth " + opt.ground_truth + ": " + ate.status().ToString());
  report->has_ate = true;
  report->ate_rmse = ate->rmse;
  report->ate_max = ate->max;
  report->ate_poses = ate->poses;
}

void AddAccuracy(const BenchOptions& opt, const AccuracyReport& report, JsonWriter* out) {
  out->Add("robust", RobustSpecString(opt.robust)).Add("loop_closures", report.loop_closures);
  if (report.has_ate) {
    out->Add("ate_rmse", report.ate_rmse)
        .Add("ate_max", report.ate_max)
        .Add("ate_poses", report.ate_poses);
  }
}

void PrintAccuracy(const BenchOptions& opt, const AccuracyReport& report) {
  if (!opt.robust.is_none()) {
    std::printf("robust kernel %s on the %zu loop closures\n", RobustSpecString(opt.robust).c_str(),
                report.loop_closures);
  }
  if (report.has_ate) {
    std::printf("ATE vs %s: rmse %.6g m, max %.6g m over %zu poses\n", opt.ground_truth.c_str(),
                report.ate_rmse, report.ate_max, report.ate_poses);
  }
}

}  // namespace bench

using bench::BenchOptions;
using bench::Fail;

void RegisterBench(CLI::App& app) {
  auto opt = std::make_shared<BenchOptions>();
  CLI::App* cmd = app.add_subcommand("bench",
                                     "Run a solver offline on a dataset and report time, "
                                     "iterations, chi2 and peak memory");
  cmd->add_option("dataset", opt->dataset,
                  "Dataset: a pose graph (g2o 2D/3D, TORO .graph, iSAM .txt) for batch and isam2; "
                  "a BAL file or a COLMAP text model (a directory with cameras.txt, images.txt, "
                  "points3D.txt) for ba, for batch as a factor graph (projection factors refining "
                  "the calibrations whose model can write every parameter back) and for isam2 "
                  "camera by camera (an image enters once it sees 5 points in the graph, a point "
                  "once two views see it with --min-parallax; camera 0 and the scale anchored)")
      ->required()
      ->check(CLI::ExistingPath);
  cmd->add_option("--solver", opt->solver,
                  "Solver to run: batch, isam2, or ba (bundle adjustment: Levenberg-Marquardt with "
                  "the points eliminated)")
      ->check(CLI::IsMember({"batch", "isam2", "ba"}))
      ->capture_default_str();
  cmd->add_option("--linear-solver", opt->linear_solver,
                  "ba: how the reduced camera system is solved: auto (the exact solver, dense "
                  "for few cameras else sparse Cholesky, or conjugate gradients, whichever is "
                  "less work per iteration), dense-schur, sparse-schur, iterative-schur")
      ->check(CLI::IsMember({"auto", "dense-schur", "sparse-schur", "iterative-schur"}))
      ->capture_default_str();
  auto ordering = std::make_shared<std::string>("auto");
  cmd->add_option("--ordering", *ordering,
                  "batch: elimination order: auto (landmarks first when they outnumber the other "
                  "variables), colamd, landmarks-first (the Schur complement on the poses)")
      ->check(CLI::IsMember({"auto", "colamd", "landmarks-first"}))
      ->capture_default_str();
  cmd->add_flag("--json", opt->json, "Print one JSON object instead of a human summary");
  cmd->add_option("--algorithm", opt->algorithm, "Batch algorithm: lm (Levenberg-Marquardt) or gn")
      ->check(CLI::IsMember({"lm", "gn"}))
      ->capture_default_str();
  cmd->add_option("--damping", opt->damping,
                  "LM damping: identity (H + λI) or diagonal (H + λ·diag H)")
      ->check(CLI::IsMember({"identity", "diagonal"}))
      ->capture_default_str();
  cmd->add_option("--init", opt->init,
                  "Initial guess: auto (solve from the file's guess and from a spanning tree, "
                  "and from the incremental guess when both leave chi2 above 5 per residual "
                  "dimension; keep the lowest; 2D, else file), file (vertices in the file, "
                  "odometry where missing) or odometry (compose along odometry in file order, "
                  "ignoring vertices), spanning-tree (compose along the most certain edges) or "
                  "lago (linear orientation then position estimate; 2D) or incremental "
                  "(re-optimise while adding poses in order; 2D). ba: auto (points whose start "
                  "reprojects worse than 100 px or lies behind most of their cameras are "
                  "triangulated again) or file")
      ->check(CLI::IsMember({"auto", "file", "odometry", "spanning-tree", "lago", "incremental"}))
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
  cmd->add_option("-o,--output", opt->output,
                  "Write the result: batch, isam2: the optimised graph as a g2o file; ba, and "
                  "batch on a reconstruction: a PLY file (*.ply: points and camera centres), a BAL "
                  "file (*.bal, *.txt) or a COLMAP text model (any other path: a directory)");
  auto robust_spec = std::make_shared<std::string>("none");
  cmd->add_option(
         "--robust", *robust_spec,
         "Robust kernel KERNEL[:PARAM] on the loop closures (pose-pose between factors "
         "that are not odometry, i.e. not |i - j| = 1 on one robot), both solvers. KERNEL: "
         "none, huber (k, default 3), cauchy (k, default 3), gemanmcclure (k, default 3), "
         "dcs (Phi, default 9); k is a whitened residual norm, Phi a squared one "
         "(core/factors/robust_kernel.h). ba: on every observation, k in pixels "
         "(e.g. huber:1)")
      ->capture_default_str();
  cmd->add_option(
         "--ground-truth", opt->ground_truth,
         "Report the absolute trajectory error (ate_rmse, ate_max in m, after the best "
         "rigid alignment) of the final estimate against this file: a g2o file with VERTEX "
         "lines (slamctl sim's *_groundtruth.g2o) or noise-free measurements composed "
         "from the first pose (iSAM's *_groundtruth.txt)")
      ->check(CLI::ExistingFile);
  auto max_iterations = cmd->add_option("--max-iterations", opt->batch.max_iterations,
                                        "Iterations at most (batch; ba: default 50, as Ceres)")
                            ->capture_default_str();
  cmd->add_option("--relative-tolerance", opt->batch.relative_tolerance)->capture_default_str();
  cmd->add_option("--absolute-tolerance", opt->batch.absolute_tolerance)->capture_default_str();
  cmd->add_option("--initial-lambda", opt->batch.initial_lambda)->capture_default_str();
  cmd->add_flag("-v,--verbose", opt->batch.verbosity,
                "Print one line per LM iteration to stderr (batch, ba)");
  // isam2 (Isam2Params; defaults as GTSAM's ISAM2).
  auto relin_threshold = std::make_shared<std::optional<double>>();
  cmd->add_option("--relinearize-threshold", *relin_threshold,
                  "isam2: relinearise a variable when an entry of its update exceeds this "
                  "(rotation radians and translation metres; default 0.1)");
  cmd->add_option("--relinearize-skip", opt->isam2.relinearization.skip,
                  "isam2: check for relinearisation every N updates")
      ->capture_default_str();
  cmd->add_option("--relinearize-error", opt->isam2.relinearization.error_threshold,
                  "isam2: also relinearise a variable when one of its factors' linearisation "
                  "error at the estimate exceeds this many sigmas (0: off, as GTSAM)")
      ->capture_default_str();
  cmd->add_option("--threads", opt->threads,
                  "isam2: threads for the large steps (relinearising factors, eliminating "
                  "independent subtrees) and for a fresh all-marginals pass; results do not "
                  "depend on it. ba: threads for the Jacobians, the Schur complement and the "
                  "implicit products")
      ->capture_default_str();
  cmd->add_option("--relinearize-max", opt->isam2.relinearization.max_variables,
                  "isam2: relinearise at most this many variables per update, most changed first "
                  "(0: no limit)")
      ->capture_default_str();
  cmd->add_option("--pivot-tolerance", opt->isam2.elimination.relative_pivot_tolerance,
                  "isam2: a pivot must exceed this times the information that flowed into it, "
                  "or the system is reported indeterminate")
      ->capture_default_str();
  cmd->add_option(
         "--wildfire", opt->isam2.wildfire_threshold,
         "isam2: partial back-substitution threshold (0: solve every clique below a change)")
      ->capture_default_str();
  cmd->add_flag("--trust-region", opt->isam2.trust_region.enabled,
                "isam2: end every update with Powell's dog leg instead of the Gauss-Newton step "
                "(the chi2 never rises above the linearisation point's; O(graph) per update)");
  cmd->add_option("--batch-every", opt->isam2.batch_every,
                  "isam2: relinearise and re-eliminate everything every N updates (0: never)")
      ->capture_default_str();
  cmd->add_option(
      "--step-times", opt->step_times,
      "isam2: write one line per step to this CSV file (index, pose, factors added, ms, "
      "relinearised and re-eliminated variables, then ms per phase of the update: add, "
      "relinearize, remove_top, order, eliminate, solve); on a reconstruction: index, points "
      "and observations entered, ms, relinearised and re-eliminated variables, cost after the "
      "step (computed outside the step's time)");
  cmd->add_option("--rate", opt->rate_hz,
                  "isam2: also model a server fed HZ poses per second (a pose's factors as one "
                  "message each, at its time slot) that runs these steps one at a time, in order: "
                  "the latency percentiles of its messages, queueing included (queued_ms)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--marginals", opt->marginals,
                  "isam2: after every step compute the newest pose's marginal covariance (latest) "
                  "or every variable's (all), timed apart from the step")
      ->check(CLI::IsMember({"none", "latest", "all"}))
      ->capture_default_str();
  cmd->add_option("--marginals-every", opt->marginals_every,
                  "isam2 --marginals all: only every K steps")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--min-parallax", opt->min_parallax_deg,
                  "isam2 on a reconstruction: a point enters once two views see it with at least "
                  "this angle (degrees) between their rays")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--drop-parallax", opt->drop_parallax_deg,
                  "isam2 on a reconstruction: a point leaves the graph (its observations dropped) "
                  "once its rays at the estimate are closer than this (degrees) or it is behind "
                  "or more than 80 degrees off the axis of a camera that sees it; 0: never")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_flag("--fixed-intrinsics", opt->fixed_intrinsics,
                "isam2 and ba on a reconstruction: hold every calibration at the file's values "
                "(otherwise ba refines focal lengths and distortion, each intrinsics once however "
                "many images share it; isam2 the calibrations whose model can write every "
                "parameter back)");
  cmd->add_flag("--refine-principal-point", opt->refine_principal_point,
                "ba: refine the principal point of pinhole and OpenCV calibrations too");
  cmd->add_flag("--compare-batch", opt->compare_batch,
                "isam2: also solve the final graph in batch and report batch_chi2");
  cmd->add_option("--settle", opt->settle_s,
                  "isam2: after the last step, refine for up to this many seconds")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->callback([opt, relin_threshold, robust_spec, max_iterations, ordering] {
    opt->batch.ordering = *ordering == "colamd" ? core::BatchParams::Ordering::kColamd
                          : *ordering == "landmarks-first"
                              ? core::BatchParams::Ordering::kLandmarksFirst
                              : core::BatchParams::Ordering::kAuto;
    core::Result<core::RobustKernel> robust = ParseRobustSpec(*robust_spec);
    if (!robust.ok()) Fail(kExitUsage, "--robust: " + robust.status().message());
    opt->robust = *robust;
    opt->isam2.threads = opt->threads;
    if (max_iterations->count() > 0) opt->ba_max_iterations = opt->batch.max_iterations;
    if (relin_threshold->has_value()) {  // one value for both; Validate() checks it
      opt->isam2.relinearization.rotation_threshold = **relin_threshold;
      opt->isam2.relinearization.translation_threshold = **relin_threshold;
    }
    for (const core::Status& valid : {opt->batch.Validate(), opt->isam2.Validate()}) {
      if (!valid.ok()) Fail(kExitUsage, valid.message());
    }
    if (opt->solver == "isam2") {
      if (plot::IsReconstructionPath(opt->dataset)) {
        bench::RunIsam2Reconstruction(*opt);
      } else {
        bench::RunIsam2(*opt);
      }
    } else if (opt->solver == "ba") {
      bench::RunBundleAdjustment(*opt);
    } else {
      bench::RunBatch(*opt);
    }
  });
}

}  // namespace slamd::clients
