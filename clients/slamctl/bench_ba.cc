// slamctl bench --solver ba: bundle adjustment of a BAL file or a COLMAP text model.
#include <cstdio>

#include "clients/slamctl/bench.h"
#include "clients/slamctl/json_writer.h"
#include "core/ba/bundle_adjuster.h"
#include "core/ba/point_initialization.h"
#include "core/base/timing.h"
#include "core/io/sfm_io.h"

namespace slamd::clients::bench {

void RunBundleAdjustment(const BenchOptions& opt) {
  core::Stopwatch timer;
  core::Result<core::Reconstruction> read = core::ReadReconstruction(opt.dataset);
  if (!read.ok()) Fail(kExitFailure, read.status().ToString());
  const double read_s = timer.Seconds();
  core::Reconstruction reconstruction = std::move(read).value();
  // --init auto: points without a usable start are triangulated again; file: as read.
  if (opt.init != "auto" && opt.init != "file") {
    Fail(kExitUsage, "--init " + opt.init + ": bundle adjustment starts from auto or file");
  }
  core::PointInitializationReport retriangulated;
  if (opt.init == "auto") {
    core::Result<core::PointInitializationReport> r =
        core::RetriangulatePoorPoints(&reconstruction);
    if (!r.ok()) Fail(kExitFailure, r.status().ToString());
    retriangulated = r.value();
  }

  core::BundleAdjusterParams params;
  core::Result<core::BaLinearSolver> solver = core::ParseBaLinearSolver(opt.linear_solver);
  if (!solver.ok()) Fail(kExitUsage, "--linear-solver: " + solver.status().message());
  params.linear_solver = *solver;
  params.num_threads = opt.threads;
  params.robust = opt.robust;
  params.max_iterations = opt.ba_max_iterations;
  params.refine_intrinsics = !opt.fixed_intrinsics;
  params.refine_principal_point = opt.refine_principal_point;
  params.verbosity = opt.batch.verbosity;
  if (const core::Status valid = params.Validate(); !valid.ok()) Fail(kExitUsage, valid.message());
  core::Result<core::BundleAdjusterSummary> adjusted = core::BundleAdjust(params, &reconstruction);
  if (!adjusted.ok()) Fail(kExitFailure, adjusted.status().ToString());
  const core::BundleAdjusterSummary& s = adjusted.value();

  if (opt.json) {
    std::vector<JsonWriter> iterations;
    for (const core::BaIteration& it : s.iterations) {
      JsonWriter one;
      one.Add("cost", it.cost).Add("elapsed_s", it.elapsed_s).Add("step_taken", it.step_taken);
      if (s.linear_solver == core::BaLinearSolver::kIterativeSchur) {
        one.Add("cg_iterations", it.linear_iterations);
      }
      iterations.push_back(one);
    }
    JsonWriter phases;
    phases.Add("evaluate", s.evaluate_s)
        .Add("schur", s.schur_s)
        .Add("solve", s.solve_s)
        .Add("update", s.update_s);
    JsonWriter out;
    out.Add("dataset", opt.dataset)
        .Add("solver", "ba")
        .Add("linear_solver", core::BaLinearSolverName(s.linear_solver))
        .Add("threads", opt.threads)
        .Add("robust", RobustSpecString(opt.robust))
        .Add("init", opt.init)
        .Add("points_poor_start", retriangulated.poor)
        .Add("points_retriangulated", retriangulated.replaced)
        .Add("cameras", s.num_cameras)
        .Add("camera_block_dim", s.camera_block_dim)
        .Add("shared_calibrations", s.shared_calibrations)
        .Add("points", s.num_points)
        .Add("observations", s.num_observations)
        .Add("initial_cost", s.initial_cost)
        .Add("final_cost", s.final_cost)
        .Add("rms_reprojection_px", s.rms_reprojection_px)
        .Add("points_behind_cameras", s.points_behind_cameras)
        .Add("termination", s.termination)
        .Add("read_s", read_s)
        .Add("total_s", s.total_s)
        .Add("phase_s", phases)
        .Add("iterations", iterations)
        .Add("peak_rss_mb", PeakRssMb());
    std::printf("%s\n", out.str().c_str());
  } else {
    std::printf("%s: %d cameras (%d unknowns each), %d points, %d observations (read in %.3f s)\n",
                opt.dataset.c_str(), s.num_cameras, s.camera_block_dim, s.num_points,
                s.num_observations, read_s);
    if (s.shared_calibrations > 0) {
      std::printf("calibrations refined as shared by their images: %d\n", s.shared_calibrations);
    }
    if (opt.init == "auto") {
      std::printf("initial guess: %d points with a poor start, %d triangulated again\n",
                  retriangulated.poor, retriangulated.replaced);
    }
    std::printf("ba %s, %d threads: cost %.10g -> %.10g in %zu iterations (%s), %.3f s\n",
                core::BaLinearSolverName(s.linear_solver), opt.threads, s.initial_cost,
                s.final_cost, s.iterations.size(), s.termination.c_str(), s.total_s);
    std::printf("rms reprojection %.4f px, %d observations behind their camera\n",
                s.rms_reprojection_px, s.points_behind_cameras);
    std::printf(
        "phases: evaluate %.4f s, schur %.4f s, solve %.4f s, update %.4f s; peak RSS "
        "%.1f MB\n",
        s.evaluate_s, s.schur_s, s.solve_s, s.update_s, PeakRssMb());
  }
  if (!opt.output.empty()) {
    const core::Status written = WriteReconstruction(reconstruction, opt.output);
    if (!written.ok()) Fail(kExitFailure, written.ToString());
  }
}

}  // namespace slamd::clients::bench
