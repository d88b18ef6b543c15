// ba_ceres_compare: slamd's bundle adjuster and Ceres Solver side by side on one BAL problem.
//
//   ba_ceres_compare FILE.bal [--runs N] [--threads N] [--max-iterations N]
//                    [--robust none|huber:K|cauchy:K] [--json]
//   defaults: 3 runs, 2 threads, 50 iterations, no robust loss; --json prints one JSON line
//   instead of the table.
//
// The file is read once, by slamd's ReadBal. Each run then solves it five times from the same
// starting values, in this order: Ceres SPARSE_SCHUR (the run's reference), Ceres ITERATIVE_SCHUR
// with SCHUR_JACOBI, slamd's kAuto (what a user gets), slamd's kSparseSchur (its exact solver,
// what the iterative one is checked against) and slamd's kIterativeSchur. All five minimise ½ Σ ρ(|uv − measured|²) by Levenberg-Marquardt with Ceres's
// default tolerances (slamd's defaults are the same numbers), the same iteration limit, the same
// number of threads and the same loss (slamd's Huber and Cauchy ρ are Ceres's HuberLoss and
// CauchyLoss).
//
// Ceres's model is written in the Reconstruction's own convention (core/sfm/reconstruction.h), so
// that both solvers start from the same numbers: camera = (angle-axis of R_cw, t_cw, f, k1, k2),
// P = R_cw X + t_cw, p = (P.x, P.y) / P.z, pixel = f (1 + k1 |p|² + k2 |p|⁴) p, differentiated by
// Ceres's automatic differentiation, the points eliminated first. The two sides' initial costs
// must agree (checked): otherwise they would not be solving the same problem.
//
// Times. total_s: slamd's BundleAdjusterSummary::total_s (setup, iterations, write-back); for
// Ceres the wall time over the same span: parameters out of the Reconstruction, building the
// ceres::Problem, Solve, parameters back (Solve alone, Ceres's total_time_in_seconds, is solve_s
// in the JSON). t->ref: when a solver's cost first fell to the final cost of the reference (Ceres
// SPARSE_SCHUR of the same run) or below: slamd's BaIteration::elapsed_s; for Ceres its setup
// plus IterationSummary::cumulative_time_in_seconds. Ratios are taken per run against that run's
// reference, then their median over the runs is shown.
//
// Memory. Each solve runs in a child process forked after the file was read (ba_compare_run.h),
// so each starts from the same memory and none inherits another's peak. peak: the child's peak
// RSS, which counts the pages it shares with the parent (the problem read, the libraries); +RSS:
// that minus the child's RSS when it started, i.e. what the solve allocated (for Ceres also its
// parameter arrays and the ceres::Problem, which any Ceres user needs).
//
// Exit codes: 0 every solve succeeded and lowered the cost; 1 a solve failed, crashed or did not
// lower the cost, or the two models' initial costs differ; 2 usage; 77 FILE does not exist (the
// test suite's "skipped").
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/ba/bundle_adjuster.h"
#include "core/base/timing.h"
#include "core/geometry/pose3.h"
#include "core/io/sfm_io.h"
#include "tests/benchmarks/ba_compare_run.h"

namespace {

namespace core = slamd::core;
using slamd::benchmarks::FailedRun;
using slamd::benchmarks::Run;
using slamd::benchmarks::RunInChild;

constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;
constexpr int kExitSkip = 77;
constexpr double kNaN = Run::kNaN;

struct Options {
  std::string path;
  int runs = 3;
  int threads = 2;
  int max_iterations = 50;
  core::RobustKernel robust;
  std::string robust_spec = "none";
  bool json = false;
};

// The five solves of a run, in the order they run; kCeresSparse is the reference.
enum SolverIndex : int {
  kCeresSparse,
  kCeresIterative,
  kSlamdAuto,
  kSlamdSparse,
  kSlamdIterative,
  kNumSolvers
};
constexpr std::array<const char*, kNumSolvers> kSolverKeys = {
    "ceres_sparse_schur", "ceres_iterative_schur", "slamd_auto", "slamd_sparse_schur",
    "slamd_iterative_schur"};

// ---------------------------------------------------------------------------------------------
// Ceres

// Reprojection residual in the Reconstruction's convention (file comment). camera: angle-axis of
// R_cw (3), t_cw (3), f, k1, k2; point: X in the world frame.
class Reprojection {
 public:
  explicit Reprojection(const core::Vector2& measured) : u_(measured.x()), v_(measured.y()) {}

  template <typename T>
  bool operator()(const T* camera, const T* point, T* residual) const {
    T p_c[3];
    ceres::AngleAxisRotatePoint(camera, point, p_c);
    for (int i = 0; i < 3; ++i) p_c[i] += camera[3 + i];
    const T x = p_c[0] / p_c[2];
    const T y = p_c[1] / p_c[2];
    const T r2 = x * x + y * y;
    const T scale = camera[6] * (1.0 + r2 * (camera[7] + r2 * camera[8]));
    residual[0] = scale * x - u_;
    residual[1] = scale * y - v_;
    return true;
  }

 private:
  double u_, v_;
};

std::unique_ptr<ceres::LossFunction> NewLoss(const core::RobustKernel& kernel) {
  switch (kernel.kind()) {
    case core::RobustKernel::Kind::kHuber:
      return std::make_unique<ceres::HuberLoss>(kernel.parameter());
    case core::RobustKernel::Kind::kCauchy:
      return std::make_unique<ceres::CauchyLoss>(kernel.parameter());
    default:  // ParseRobust admits only none, Huber and Cauchy
      return nullptr;
  }
}

// Solves `rec` with Ceres and writes the result back into it. ReadBal gives every image its own
// Cal3Bundler.
Run SolveWithCeres(bool iterative, const Options& opt, core::Reconstruction* rec) {
  const core::Stopwatch wall;
  const size_t num_images = rec->images.size();
  std::vector<double> cameras(9 * num_images), points(3 * rec->points.size());
  for (size_t i = 0; i < num_images; ++i) {
    const core::SfmImage& image = rec->images[i];
    const core::Rot3 R_cw = image.pose.rotation().Inverse();
    const core::Vector3 t_cw = -(R_cw.matrix() * image.pose.translation());
    const auto& cal = std::get<core::Cal3Bundler>(rec->intrinsics[image.intrinsics].calibration);
    Eigen::Matrix<double, 9, 1>::Map(&cameras[9 * i]) << core::Rot3::Log(R_cw), t_cw, cal.vector();
  }
  for (size_t j = 0; j < rec->points.size(); ++j) {
    core::Vector3::Map(&points[3 * j]) = rec->points[j].position;
  }

  // One loss object serves every residual; the problem must then not delete it.
  const std::unique_ptr<ceres::LossFunction> loss = NewLoss(opt.robust);
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  std::vector<bool> image_used(num_images, false), point_used(rec->points.size(), false);
  for (const core::SfmObservation& o : rec->observations) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<Reprojection, 2, 9, 3>(new Reprojection(o.uv)), loss.get(),
        &cameras[9 * o.image], &points[3 * o.point]);
    image_used[o.image] = true;
    point_used[o.point] = true;
  }
  // Points first, then cameras: the Schur elimination order slamd uses (and Ceres's BAL example).
  // Only blocks the problem has may be named.
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (size_t j = 0; j < point_used.size(); ++j) {
    if (point_used[j]) ordering->AddElementToGroup(&points[3 * j], 0);
  }
  for (size_t i = 0; i < num_images; ++i) {
    if (image_used[i]) ordering->AddElementToGroup(&cameras[9 * i], 1);
  }

  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.linear_solver_type = iterative ? ceres::ITERATIVE_SCHUR : ceres::SPARSE_SCHUR;
  options.preconditioner_type = ceres::SCHUR_JACOBI;
  options.linear_solver_ordering = ordering;
  options.max_num_iterations = opt.max_iterations;
  options.num_threads = opt.threads;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  const double setup_s = wall.Seconds();
  ceres::Solve(options, &problem, &summary);

  for (size_t i = 0; i < num_images; ++i) {
    const Eigen::Map<const Eigen::Matrix<double, 9, 1>> c(&cameras[9 * i]);
    const core::Pose3 T_cw(core::Rot3::Exp(c.head<3>()), c.segment<3>(3));
    rec->images[i].pose = T_cw.Inverse();
    rec->intrinsics[rec->images[i].intrinsics].calibration = core::Cal3Bundler(c.tail<3>());
  }
  for (size_t j = 0; j < rec->points.size(); ++j) {
    rec->points[j].position = Eigen::Map<const core::Vector3>(&points[3 * j]);
  }

  Run run;
  run.total_s = wall.Seconds();
  run.ok = summary.IsSolutionUsable();
  run.linear_solver = ceres::LinearSolverTypeToString(summary.linear_solver_type_used);
  if (iterative) {
    run.linear_solver +=
        std::string(", ") + ceres::PreconditionerTypeToString(summary.preconditioner_type_used);
  }
  run.message = summary.message;
  run.initial_cost = summary.initial_cost;
  run.final_cost = summary.final_cost;
  run.solve_s = summary.total_time_in_seconds;
  // Ceres's iteration 0 is the starting point, not an iteration.
  for (size_t k = 1; k < summary.iterations.size(); ++k) {
    const ceres::IterationSummary& it = summary.iterations[k];
    run.trace.push_back({setup_s + it.cumulative_time_in_seconds, it.cost});
  }
  return run;
}

// ---------------------------------------------------------------------------------------------
// slamd

Run SolveWithSlamd(core::BaLinearSolver solver, const Options& opt, core::Reconstruction* rec) {
  const core::BundleAdjusterParams params{.linear_solver = solver,
                                          .num_threads = opt.threads,
                                          .robust = opt.robust,
                                          .max_iterations = opt.max_iterations};
  const core::Result<core::BundleAdjusterSummary> result = core::BundleAdjust(params, rec);
  if (!result.ok()) return FailedRun(result.status().ToString());
  const core::BundleAdjusterSummary& s = *result;
  Run run;
  run.ok = true;
  run.linear_solver = core::BaLinearSolverName(s.linear_solver);
  run.message = s.termination;
  run.initial_cost = s.initial_cost;
  run.final_cost = s.final_cost;
  run.total_s = s.total_s;
  run.solve_s = s.total_s;
  for (const core::BaIteration& it : s.iterations) run.trace.push_back({it.elapsed_s, it.cost});
  return run;
}

// ---------------------------------------------------------------------------------------------
// Figures over the runs

double Median(std::vector<double> values) {
  std::erase_if(values, [](double v) { return !std::isfinite(v); });
  if (values.empty()) return kNaN;
  std::sort(values.begin(), values.end());
  const size_t mid = values.size() / 2;
  return values.size() % 2 == 1 ? values[mid] : 0.5 * (values[mid - 1] + values[mid]);
}

// Seconds until `run` first reached `cost` or less; NaN if it never did.
double TimeToCost(const Run& run, double cost) {
  if (run.initial_cost <= cost) return 0.0;
  for (const auto& [t, c] : run.trace) {
    if (c <= cost) return t;
  }
  return kNaN;
}

// One solver's medians over the runs; `vs_ref` figures are ratios to the same run's reference.
struct Figures {
  std::string label;
  double total_s, total_min_s, total_max_s, solve_s, iterations, initial_cost, final_cost;
  double final_cost_vs_ref;  // final cost / reference's − 1
  double time_to_ref_s;      // over the runs that reached the reference's cost
  int time_to_ref_reached;
  double total_vs_ref, time_to_ref_vs_ref, rss_increase_mb, peak_rss_mb;
};

Figures Summarise(const std::vector<std::array<Run, kNumSolvers>>& runs, int solver) {
  std::vector<double> total, solve, iterations, initial, final, cost_vs_ref, to_ref, total_vs_ref,
      to_ref_vs_ref, rss_increase, peak_rss;
  Figures f{};
  for (const std::array<Run, kNumSolvers>& run : runs) {
    const Run& r = run[solver];
    const Run& ref = run[kCeresSparse];
    total.push_back(r.total_s);
    solve.push_back(r.solve_s);
    iterations.push_back(static_cast<double>(r.trace.size()));
    initial.push_back(r.initial_cost);
    final.push_back(r.final_cost);
    cost_vs_ref.push_back(r.final_cost / ref.final_cost - 1.0);
    const double t = TimeToCost(r, ref.final_cost);
    if (std::isfinite(t)) ++f.time_to_ref_reached;
    to_ref.push_back(t);
    total_vs_ref.push_back(r.total_s / ref.total_s);
    to_ref_vs_ref.push_back(t / ref.total_s);
    rss_increase.push_back(r.peak_rss_mb - r.start_rss_mb);
    peak_rss.push_back(r.peak_rss_mb);
  }
  std::string used = runs.front()[solver].linear_solver;
  if (used.empty()) used = kSolverKeys[solver];  // the first run failed
  f.label = solver <= kCeresIterative ? "ceres " + used
            : solver == kSlamdAuto    ? "slamd auto: " + used
                                      : "slamd " + used;
  f.total_s = Median(total);
  f.total_min_s = *std::min_element(total.begin(), total.end());
  f.total_max_s = *std::max_element(total.begin(), total.end());
  f.solve_s = Median(solve);
  f.iterations = Median(iterations);
  f.initial_cost = Median(initial);
  f.final_cost = Median(final);
  f.final_cost_vs_ref = Median(cost_vs_ref);
  f.time_to_ref_s = Median(to_ref);
  f.total_vs_ref = Median(total_vs_ref);
  f.time_to_ref_vs_ref = Median(to_ref_vs_ref);
  f.rss_increase_mb = Median(rss_increase);
  f.peak_rss_mb = Median(peak_rss);
  return f;
}

// Median over the runs of the iterative solve's final cost relative to the exact one's, − 1.
double IterativeGap(const std::vector<std::array<Run, kNumSolvers>>& runs, int iterative,
                    int exact) {
  std::vector<double> gap;
  for (const auto& run : runs) gap.push_back(run[iterative].final_cost / run[exact].final_cost - 1);
  return Median(gap);
}

std::string Sci(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.9e", v);
  return buffer;
}

// Why the runs do not count, one message a line; empty when every solve succeeded, lowered the
// cost, and both models started from the same cost.
std::string CheckRuns(const std::vector<std::array<Run, kNumSolvers>>& runs) {
  std::string problems;
  for (size_t r = 0; r < runs.size(); ++r) {
    const std::string run_name = "run " + std::to_string(r + 1) + ", ";
    for (int s = 0; s < kNumSolvers; ++s) {
      const Run& run = runs[r][s];
      if (!run.ok) {
        problems += run_name + kSolverKeys[s] + " failed: " + run.message + "\n";
      } else if (!(run.final_cost < run.initial_cost)) {
        problems += run_name + kSolverKeys[s] + " did not lower the cost (" +
                    Sci(run.initial_cost) + " -> " + Sci(run.final_cost) + ")\n";
      }
    }
    // Rounding differs between the two models' arithmetic by far less than this.
    const double ceres = runs[r][kCeresSparse].initial_cost;
    const double slamd = runs[r][kSlamdAuto].initial_cost;
    if (!(std::abs(ceres - slamd) <= 1e-8 * std::max(ceres, slamd))) {
      problems += run_name + "the initial costs differ: ceres " + Sci(ceres) + ", slamd " +
                  Sci(slamd) + "\n";
    }
  }
  return problems;
}

// ---------------------------------------------------------------------------------------------
// Output

std::string JsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.10g", v);
  return buffer;
}

std::string JsonString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

struct Header {
  const Options* options;
  const core::Reconstruction* problem;
  double load_start, load_end;  // one-minute load averages before and after the runs
};

void PrintJson(const Header& h, const std::vector<Figures>& figures, double ceres_gap,
               double slamd_gap, bool ok) {
  std::string out = "{\"dataset\":" + JsonString(h.options->path) +
                    ",\"cameras\":" + std::to_string(h.problem->images.size()) +
                    ",\"points\":" + std::to_string(h.problem->points.size()) +
                    ",\"observations\":" + std::to_string(h.problem->observations.size()) +
                    ",\"runs\":" + std::to_string(h.options->runs) +
                    ",\"threads\":" + std::to_string(h.options->threads) +
                    ",\"max_iterations\":" + std::to_string(h.options->max_iterations) +
                    ",\"robust\":" + JsonString(h.options->robust_spec) +
                    ",\"ceres_version\":" + JsonString(CERES_VERSION_STRING) +
                    ",\"load_average\":[" + JsonNumber(h.load_start) + "," +
                    JsonNumber(h.load_end) + "],\"solvers\":[";
  for (int s = 0; s < kNumSolvers; ++s) {
    const Figures& f = figures[s];
    out += std::string(s > 0 ? "," : "") + "{\"solver\":" + JsonString(kSolverKeys[s]) +
           ",\"label\":" + JsonString(f.label) + ",\"total_s\":" + JsonNumber(f.total_s) +
           ",\"total_min_s\":" + JsonNumber(f.total_min_s) +
           ",\"total_max_s\":" + JsonNumber(f.total_max_s) +
           ",\"solve_s\":" + JsonNumber(f.solve_s) + ",\"iterations\":" + JsonNumber(f.iterations) +
           ",\"initial_cost\":" + JsonNumber(f.initial_cost) +
           ",\"final_cost\":" + JsonNumber(f.final_cost) +
           ",\"final_cost_vs_ref\":" + JsonNumber(f.final_cost_vs_ref) +
           ",\"time_to_ref_s\":" + JsonNumber(f.time_to_ref_s) +
           ",\"time_to_ref_reached\":" + std::to_string(f.time_to_ref_reached) +
           ",\"total_vs_ref\":" + JsonNumber(f.total_vs_ref) +
           ",\"time_to_ref_vs_ref\":" + JsonNumber(f.time_to_ref_vs_ref) +
           ",\"rss_increase_mb\":" + JsonNumber(f.rss_increase_mb) +
           ",\"peak_rss_mb\":" + JsonNumber(f.peak_rss_mb) + "}";
  }
  out += "],\"iterative_vs_exact\":{\"ceres\":" + JsonNumber(ceres_gap) +
         ",\"slamd\":" + JsonNumber(slamd_gap) + "},\"ok\":" + (ok ? "true" : "false") + "}";
  std::printf("%s\n", out.c_str());
}

void PrintTable(const Header& h, const std::vector<Figures>& figures, double ceres_gap,
                double slamd_gap) {
  const Options& o = *h.options;
  std::printf("%s: %zu cameras, %zu points, %zu observations, initial cost %.6e\n", o.path.c_str(),
              h.problem->images.size(), h.problem->points.size(), h.problem->observations.size(),
              figures[kCeresSparse].initial_cost);
  std::printf(
      "runs %d, threads %d, iterations at most %d, robust %s; Ceres %s; load average %.2f "
      "before, %.2f after\n",
      o.runs, o.threads, o.max_iterations, o.robust_spec.c_str(), CERES_VERSION_STRING,
      h.load_start, h.load_end);
  std::printf(
      "Medians over runs. ref = Ceres SPARSE_SCHUR of the same run; t->ref = time to "
      "reach its final cost; +RSS = peak RSS - RSS at the solve's start (MiB)\n");
  std::printf("%-36s %8s %19s %5s %14s %10s %8s %7s %9s %10s %7s %7s\n", "solver", "total s",
              "[min, max]", "iters", "final cost", "vs ref", "t->ref s", "reached", "total/ref",
              "t->ref/ref", "+RSS", "peak");
  for (const Figures& f : figures) {
    std::printf(
        "%-36s %8.3f [%8.3f, %8.3f] %5.0f %14.8e %+10.2e %8.3f %5d/%d %9.3f %10.3f %7.1f "
        "%7.1f\n",
        f.label.c_str(), f.total_s, f.total_min_s, f.total_max_s, f.iterations, f.final_cost,
        f.final_cost_vs_ref, f.time_to_ref_s, f.time_to_ref_reached, o.runs, f.total_vs_ref,
        f.time_to_ref_vs_ref, f.rss_increase_mb, f.peak_rss_mb);
  }
  std::printf("iterative vs exact, final cost / exact's - 1: ceres %+.3e, slamd %+.3e\n", ceres_gap,
              slamd_gap);
}

double LoadAverage() {
  double load = kNaN;
  getloadavg(&load, 1);
  return load;
}

// ---------------------------------------------------------------------------------------------
// Command line

bool ParseInt(std::string_view text, int min, int* out) {
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), *out);
  return ec == std::errc() && end == text.data() + text.size() && *out >= min;
}

// "none", "huber:K" or "cauchy:K" (the kernels Ceres has too).
std::optional<core::RobustKernel> ParseRobust(std::string_view spec) {
  if (spec == "none") return core::RobustKernel();
  const size_t colon = spec.find(':');
  if (colon == std::string_view::npos) return std::nullopt;
  const core::Result<core::RobustKernel::Kind> kind =
      core::RobustKernel::ParseKind(spec.substr(0, colon));
  if (!kind.ok() ||
      (*kind != core::RobustKernel::Kind::kHuber && *kind != core::RobustKernel::Kind::kCauchy)) {
    return std::nullopt;
  }
  const std::string_view number = spec.substr(colon + 1);
  double k = 0.0;
  const auto [end, ec] = std::from_chars(number.data(), number.data() + number.size(), k);
  if (ec != std::errc() || end != number.data() + number.size()) return std::nullopt;
  core::Result<core::RobustKernel> kernel = core::RobustKernel::Create(*kind, k);
  if (!kernel.ok()) return std::nullopt;
  return *kernel;
}

std::optional<Options> ParseArgs(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--json") {
      o.json = true;
    } else if (arg == "--runs" && has_value) {
      if (!ParseInt(argv[++i], 1, &o.runs)) return std::nullopt;
    } else if (arg == "--threads" && has_value) {
      if (!ParseInt(argv[++i], 1, &o.threads)) return std::nullopt;
    } else if (arg == "--max-iterations" && has_value) {
      if (!ParseInt(argv[++i], 1, &o.max_iterations)) return std::nullopt;
    } else if (arg == "--robust" && has_value) {
      o.robust_spec = argv[++i];
      const std::optional<core::RobustKernel> kernel = ParseRobust(o.robust_spec);
      if (!kernel) return std::nullopt;
      o.robust = *kernel;
    } else if (!arg.starts_with("-") && o.path.empty()) {
      o.path = arg;
    } else {
      return std::nullopt;
    }
  }
  if (o.path.empty()) return std::nullopt;
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  const std::optional<Options> parsed = ParseArgs(argc, argv);
  if (!parsed) {
    std::fprintf(stderr,
                 "usage: ba_ceres_compare FILE.bal [--runs N (3)] [--threads N (2)] "
                 "[--max-iterations N (50)] [--robust none|huber:K|cauchy:K] [--json]\n");
    return kExitUsage;
  }
  const Options& opt = *parsed;
  const double load_start = LoadAverage();
  core::Result<core::Reconstruction> read = core::ReadBal(opt.path);
  if (!read.ok()) {
    std::fprintf(stderr, "ba_ceres_compare: %s\n", read.status().ToString().c_str());
    return read.status().code() == core::StatusCode::kNotFound ? kExitSkip : kExitFailure;
  }
  // Each solve writes its result into the child's copy of this (copy-on-write), so every solve
  // starts from the values read.
  core::Reconstruction problem = std::move(read).value();

  const std::array<std::function<Run()>, kNumSolvers> solves = {
      [&] { return SolveWithCeres(false, opt, &problem); },
      [&] { return SolveWithCeres(true, opt, &problem); },
      [&] { return SolveWithSlamd(core::BaLinearSolver::kAuto, opt, &problem); },
      [&] { return SolveWithSlamd(core::BaLinearSolver::kSparseSchur, opt, &problem); },
      [&] { return SolveWithSlamd(core::BaLinearSolver::kIterativeSchur, opt, &problem); }};
  std::vector<std::array<Run, kNumSolvers>> runs(opt.runs);
  for (int r = 0; r < opt.runs; ++r) {
    for (int s = 0; s < kNumSolvers; ++s) {
      runs[r][s] = RunInChild(solves[s]);
      std::fprintf(stderr, "run %d/%d %-22s %-28s %8.3f s  cost %.6e -> %.6e  %s\n", r + 1,
                   opt.runs, kSolverKeys[s], runs[r][s].linear_solver.c_str(), runs[r][s].total_s,
                   runs[r][s].initial_cost, runs[r][s].final_cost, runs[r][s].message.c_str());
    }
  }

  const Header header{&opt, &problem, load_start, LoadAverage()};
  std::vector<Figures> figures;
  for (int s = 0; s < kNumSolvers; ++s) figures.push_back(Summarise(runs, s));
  const double ceres_gap = IterativeGap(runs, kCeresIterative, kCeresSparse);
  const double slamd_gap = IterativeGap(runs, kSlamdIterative, kSlamdSparse);
  const std::string problems = CheckRuns(runs);
  if (opt.json) {
    PrintJson(header, figures, ceres_gap, slamd_gap, problems.empty());
  } else {
    PrintTable(header, figures, ceres_gap, slamd_gap);
  }
  if (!problems.empty()) {
    std::fprintf(stderr, "ba_ceres_compare: %s", problems.c_str());
    return kExitFailure;
  }
  return 0;
}
