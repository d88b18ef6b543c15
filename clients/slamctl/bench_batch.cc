// slamctl bench --solver batch: the batch solver on a whole dataset.
#include <cstdio>

#include "clients/slamctl/bench.h"
#include "clients/slamctl/json_writer.h"
#include "clients/slamctl/plot_reconstruction.h"
#include "core/ba/reconstruction_graph.h"
#include "core/base/timing.h"
#include "core/batch/auto_initialization.h"
#include "core/batch/batch_solver.h"
#include "core/batch/initialization.h"
#include "core/io/sfm_io.h"

namespace slamd::clients::bench {

using core::BatchParams;

void RunBatch(const BenchOptions& opt) {
  double read_s = 0.0;
  AccuracyReport accuracy;
  const core::Dataset data = Load(opt, &read_s, &accuracy.loop_closures);

  core::FactorGraph graph = data.graph;
  if (!data.poses.empty()) {
    const core::Status anchored =
        core::AddGaugePrior(data.initial, data.poses.front(), opt.anchor_sigma, &graph);
    if (!anchored.ok()) Fail(kExitFailure, anchored.ToString());
  }
  BatchParams params = opt.batch;
  params.algorithm = opt.algorithm == "gn" ? BatchParams::Algorithm::kGaussNewton
                                           : BatchParams::Algorithm::kLevenbergMarquardt;
  params.damping =
      opt.damping == "diagonal" ? BatchParams::Damping::kDiagonal : BatchParams::Damping::kIdentity;
  core::Stopwatch init_timer;
  core::Values initial = data.initial;
  std::string init = opt.init;
  core::BatchResult result;
  std::vector<JsonWriter> tried;  // --init auto: each start and the cost it reached
  std::string tried_text;
  if (opt.init == "auto") {
    core::Result<core::AutoInitialization> solved = core::OptimizeWithAutoInitialization(
        graph, data.initial, data.poses, params, opt.init_chunk);
    if (!solved.ok()) Fail(kExitFailure, solved.status().ToString());
    for (const auto& [method, cost] : solved->tried) {
      JsonWriter one;
      one.Add("init", core::InitialGuessName(method)).Add("final_cost", cost);
      tried.push_back(one);
      tried_text += std::string(tried_text.empty() ? "" : ", ") + core::InitialGuessName(method) +
                    " reached " + std::to_string(cost);
    }
    init = std::string("auto:") + core::InitialGuessName(solved->chosen);
    result = std::move(solved.value().result);
  } else if (opt.init != "odometry") {  // odometry composition happens while reading
    core::Result<core::Values> guess = core::MakeInitialGuess(
        *core::ParseInitialGuess(opt.init), data.graph, data.initial, data.poses, opt.init_chunk);
    if (!guess.ok()) Fail(kExitFailure, guess.status().ToString());
    initial = std::move(guess).value();
  }
  // With auto, the solves are part of choosing the start: init_s covers them all, and total_s
  // is the chosen start's solve.
  const double init_s = init_timer.Seconds();
  if (opt.init != "auto") result = core::Optimize(graph, initial, params);
  const core::BatchSummary& s = result.summary;
  if (result.status.ok()) Ate(opt, result.values, &accuracy);
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
        .Add("init", init)
        .Add("init_tried", tried)
        .Add("landmarks_first", s.landmarks_first)
        .Add("iterations", s.iterations)
        .Add("linear_solves", s.linear_solves)
        .Add("initial_chi2", s.initial_chi2)
        .Add("final_chi2", s.final_chi2)
        .Add("final_cost", s.final_cost)  // Σρ: differs from chi2 only with --robust
        .Add("termination", core::BatchTerminationName(s.termination))
        .Add("status", result.status.ToString())
        .Add("read_s", read_s)
        .Add("init_s", init_s)
        .Add("total_s", s.total_s)
        .Add("phase_s", phases)
        .Add("peak_rss_mb", PeakRssMb());
    AddAccuracy(opt, accuracy, &out);
    std::printf("%s\n", out.str().c_str());
  } else {
    std::printf("%s: %zu poses, %zu landmarks, %zu factors (read in %.3f s)\n", opt.dataset.c_str(),
                data.poses.size(), data.landmarks.size(), data.graph.size(), read_s);
    std::printf("initial guess: %s (%.4f s)%s%s%s\n", init.c_str(), init_s,
                tried_text.empty() ? "" : " (", tried_text.c_str(), tried_text.empty() ? "" : ")");
    std::printf("%s %s: %s\n", opt.solver.c_str(), opt.algorithm.c_str(), s.Brief().c_str());
    std::printf(
        "phases: setup %.4f s (ordering %.4f s, %d landmarks first), linearize %.4f s, "
        "factorize %.4f s, solve %.4f s, evaluate %.4f s; peak RSS %.1f MB\n",
        s.setup_s, s.order_s, s.landmarks_first, s.linearize_s, s.factorize_s, s.solve_s,
        s.evaluate_s, PeakRssMb());
    PrintAccuracy(opt, accuracy);
  }
  if (!result.status.ok()) Fail(kExitFailure, result.status.ToString());
  if (!opt.output.empty() && plot::IsReconstructionPath(opt.dataset)) {
    // The graph's keys follow the reconstruction's order: read it again and write the estimate.
    core::Result<core::Reconstruction> r = core::ReadReconstruction(opt.dataset);
    if (!r.ok()) Fail(kExitFailure, r.status().ToString());
    core::UpdateReconstruction(core::ReconstructionKeys(*r, true), result.values, &*r);
    const core::Status written = WriteReconstruction(*r, opt.output);
    if (!written.ok()) Fail(kExitFailure, written.ToString());
  } else if (!opt.output.empty()) {
    core::Dataset solved = data;
    solved.initial = result.values;
    const core::Status written = core::WriteG2o(solved, opt.output);
    if (!written.ok()) Fail(kExitFailure, written.ToString());
  }
}

}  // namespace slamd::clients::bench
