// Internal to `slamctl bench`: its options and the two runners (batch and isam2).
#pragma once

#include <string>

#include "clients/slamctl/commands.h"
#include "core/batch/batch_params.h"
#include "core/io/dataset.h"
#include "core/isam/isam2_params.h"

namespace slamd::clients::bench {

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
  core::BatchParams batch;
  // isam2
  core::Isam2Params isam2;
  bool compare_batch = false;
  double settle_s = 0.0;
  std::string step_times;  // CSV of per-step times (isam2)
  std::string marginals = "none";  // isam2: none, latest or all
  int marginals_every = 1;
};

// Peak resident memory of this process so far.
double PeakRssMb();
// Prints "slamctl bench: <message>" to stderr and ends the command with `code`.
[[noreturn]] void Fail(int code, const std::string& message);
// Reads the dataset as the options say; fails the command on error.
core::Dataset Load(const BenchOptions& opt, double* read_s);

void RunBatch(const BenchOptions& opt);
void RunIsam2(const BenchOptions& opt);

}  // namespace slamd::clients::bench
