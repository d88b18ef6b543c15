// Internal to `slamctl bench`: its options and the runners (batch, isam2, ba).
#pragma once

#include <string>

#include "clients/slamctl/commands.h"
#include "clients/slamctl/json_writer.h"
#include "core/batch/batch_params.h"
#include "core/factors/robust_kernel.h"
#include "core/io/dataset.h"
#include "core/isam/isam2_params.h"
#include "core/sfm/reconstruction.h"

namespace slamd::clients::bench {

struct BenchOptions {
  std::string dataset;
  std::string solver = "batch";
  bool json = false;
  std::string algorithm = "lm";
  std::string damping = "identity";
  std::string init = "auto";
  std::string isam_noise = "sqrt-information";
  double anchor_sigma = 1e-3;
  int init_chunk = 100;
  std::string output;
  core::RobustKernel robust;  // --robust: applied to the loop closures (robustify.h)
  std::string ground_truth;   // --ground-truth FILE: report the ATE against it
  core::BatchParams batch;
  // isam2
  core::Isam2Params isam2;
  bool compare_batch = false;
  double settle_s = 0.0;
  std::string step_times;          // CSV of per-step times (isam2)
  double rate_hz = 0.0;            // isam2: model a server fed this many poses per second (0: none)
  std::string marginals = "none";  // isam2: none, latest or all
  int marginals_every = 1;
  int threads = 2;  // isam2 (Isam2Params::threads) and ba
  double min_parallax_deg = 1.0;  // isam2 on a reconstruction: when a point enters
  double drop_parallax_deg = 0.0;  // isam2 on a reconstruction: when a point leaves (0: never)
  bool fixed_intrinsics = false;  // isam2 and ba on a reconstruction: calibrations held
  // ba
  std::string linear_solver = "auto";
  int ba_max_iterations = 50;
  bool refine_principal_point = false;
};

// Peak resident memory of this process so far.
double PeakRssMb();
// Prints "slamctl bench: <message>" to stderr and ends the command with `code`.
[[noreturn]] void Fail(int code, const std::string& message);
// Reads the dataset as the options say; fails the command on error. With --robust, its loop
// closures carry the kernel. *loop_closures (when given) receives their count (robustify.h).
core::Dataset Load(const BenchOptions& opt, double* read_s, std::size_t* loop_closures = nullptr);
// -o of a reconstruction: PLY for *.ply, BAL for *.bal / *.txt, a COLMAP text model (a
// directory) otherwise.
core::Status WriteReconstruction(const core::Reconstruction& r, const std::string& path);

// --robust and --ground-truth output. Ate() reads the ground truth and measures `estimate`
// against it (fails the command on error); no-op without --ground-truth.
struct AccuracyReport {
  std::size_t loop_closures = 0;  // loop closures in the dataset (the kernel's targets)
  bool has_ate = false;
  double ate_rmse = 0.0, ate_max = 0.0;  // metres
  std::size_t ate_poses = 0;
};
void Ate(const BenchOptions& opt, const core::Values& estimate, AccuracyReport* report);
// Adds "robust" (KERNEL:PARAM or none), "loop_closures" and (with a ground truth) "ate_rmse",
// "ate_max", "ate_poses" to `out`; PrintAccuracy prints the same as one or two human lines.
void AddAccuracy(const BenchOptions& opt, const AccuracyReport& report, JsonWriter* out);
void PrintAccuracy(const BenchOptions& opt, const AccuracyReport& report);

void RunBatch(const BenchOptions& opt);
void RunIsam2(const BenchOptions& opt);
// A reconstruction replayed camera by camera into Isam2.
void RunIsam2Reconstruction(const BenchOptions& opt);
void RunBundleAdjustment(const BenchOptions& opt);

}  // namespace slamd::clients::bench
