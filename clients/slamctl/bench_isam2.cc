// slamctl bench --solver isam2: streams a dataset into Isam2, one update per new pose.
//
// Protocol (the one the GTSAM reference figures use): the first pose is anchored by a prior
// (sigma --anchor-sigma); each step adds the new pose, initialised from the current estimate of
// its odometry predecessor composed with the odometry, and every factor whose newest pose it is
// (landmarks initialised from their first observation at that predicted pose); a step is the
// update plus reading the newest pose's estimate. `step_ms_per_factor` counts each step's time
// once per factor it adds: a server fed the same stream one message per factor (slamctl replay)
// counts its ingest-to-publish latency per message, so its percentiles compare with these.
// --rate HZ adds `queued_ms`: the latencies of those messages in a server with nothing but these
// steps to do, fed a pose every 1/HZ s, running the steps in order as they are due (a pose's
// messages all arrive at its time slot and are answered when its step ends). It does not merge
// what queued into one update, as slamd does: a floor for a server that runs the solver like this,
// not for slamd.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>

#include "clients/slamctl/bench.h"
#include "clients/slamctl/json_writer.h"
#include "core/ba/reconstruction_stream.h"
#include "core/base/memory_usage.h"
#include "core/base/percentile.h"
#include "core/base/timing.h"
#include "core/batch/batch_solver.h"
#include "core/factors/prior_factor.h"
#include "core/io/dataset_stream.h"
#include "core/io/sfm_io.h"
#include "core/isam/isam2.h"
#include "core/marginals/marginals.h"

namespace slamd::clients::bench {
namespace {

using core::Percentile;

// Each step's time [ms] once per factor it added (step_ms_per_factor above).
std::vector<double> PerFactor(const std::vector<double>& step_ms,
                              const std::vector<std::size_t>& factors) {
  std::vector<double> out;
  for (std::size_t i = 0; i < step_ms.size(); ++i) out.insert(out.end(), factors[i], step_ms[i]);
  return out;
}

// The message latencies [ms] of the --rate model above: step i is due at i * 1000 / rate_hz ms,
// starts when it is due and the previous step has ended, and counts factors[i] messages.
std::vector<double> QueuedLatencies(const std::vector<double>& step_ms,
                                    const std::vector<std::size_t>& factors, double rate_hz) {
  std::vector<double> latency;
  double end_ms = 0.0;
  for (std::size_t i = 0; i < step_ms.size(); ++i) {
    const double due_ms = static_cast<double>(i) * 1e3 / rate_hz;
    end_ms = std::max(end_ms, due_ms) + step_ms[i];
    latency.insert(latency.end(), factors[i], end_ms - due_ms);
  }
  return latency;
}

// Where the bytes are after the stream (before settling and the marginals' cache), and at rest:
// after what the server's idle time gives back (Isam2::TrimMemory, done here).
struct MemoryFigures {
  core::Isam2Memory solver;
  double rss = 0.0, trimmed_solver = 0.0, trimmed_rss = 0.0;  // [bytes]
  double heap_peak = 0.0;  // the allocator's high-water mark (core::AllocatorBytes) [bytes]
  double n = 1.0;          // variables

  static MemoryFigures Measure(core::Isam2* isam) {
    MemoryFigures m{
        .solver = isam->MemoryUse(),
        .rss = static_cast<double>(core::ResidentBytes()),
        .heap_peak = static_cast<double>(core::AllocatorBytes()),
        .n = static_cast<double>(std::max<std::size_t>(1, isam->linearization_point().size()))};
    isam->TrimMemory();
    m.trimmed_solver = static_cast<double>(isam->MemoryUse().Total());
    m.trimmed_rss = static_cast<double>(core::ResidentBytes());
    return m;
  }
  JsonWriter PerVariable() const {
    JsonWriter out;
    out.Add("linearization_point", solver.linearization_point / n)
        .Add("variables", solver.variables / n)
        .Add("factor_lists", solver.factor_lists / n)
        .Add("linearizations", solver.linearizations / n)
        .Add("variable_index", solver.variable_index / n)
        .Add("tree", solver.tree / n)
        .Add("tree_free", solver.tree_free / n)
        .Add("scratch", solver.scratch / n)
        .Add("solver_total", solver.Total() / n)
        .Add("rss", rss / n)
        .Add("solver_total_trimmed", trimmed_solver / n)
        .Add("rss_trimmed", trimmed_rss / n);
    return out;
  }
  void Print() const {
    std::printf(
        "memory per variable after the stream [bytes]: RSS %.0f, solver %.0f = theta %.0f, "
        "per-variable arrays %.0f, factor lists %.0f, linearisations %.0f, index %.0f, tree %.0f "
        "(+ %.0f free), scratch %.0f\n",
        rss / n, solver.Total() / n, solver.linearization_point / n, solver.variables / n,
        solver.factor_lists / n, solver.linearizations / n, solver.variable_index / n,
        solver.tree / n, solver.tree_free / n, solver.scratch / n);
    std::printf("  at rest (Isam2::TrimMemory): RSS %.0f, solver %.0f\n", trimmed_rss / n,
                trimmed_solver / n);
  }
};

}  // namespace

void RunIsam2(const BenchOptions& opt) {
  double read_s = 0.0;
  AccuracyReport accuracy;
  const core::Dataset data = Load(opt, &read_s, &accuracy.loop_closures);
  if (data.poses.empty()) Fail(kExitFailure, opt.dataset + ": no poses");
  // Made one at a time: holding them all was ~0.23 kB a pose (0.8 MB of input_M3500's peak).
  const core::IncrementalSteps steps(data);
  core::Result<std::unique_ptr<core::Isam2>> created = core::Isam2::Create(opt.isam2);
  if (!created.ok()) Fail(kExitUsage, created.status().message());
  core::Isam2& isam = **created;
  // --threads also sets the marginals' (only a large fresh pass uses them: the final one below).
  const core::MarginalsParams marginals_params{.threads = opt.isam2.threads};
  const core::Status marginals_valid = marginals_params.Validate();
  if (!marginals_valid.ok()) Fail(kExitUsage, marginals_valid.message());

  std::vector<double> step_ms, marginal_ms;
  std::vector<std::size_t> step_factors;  // factors added per step
  step_ms.reserve(steps.size());
  // Per step: its only factor is the odometry (no loop closure, no observation).
  std::vector<char> odometry_only;
  odometry_only.reserve(steps.size());
  core::Isam2Marginals marginals(&isam, marginals_params);
  using Frame = core::Isam2Marginals::Frame;
  Eigen::MatrixXd cov;
  long long relinearized = 0, reeliminated = 0;
  std::string worst_step;  // Isam2Result::Brief() of the slowest step
  std::FILE* csv = nullptr;
  if (!opt.step_times.empty()) {
    csv = std::fopen(opt.step_times.c_str(), "w");
    if (csv == nullptr) Fail(kExitFailure, "cannot write " + opt.step_times);
    std::fprintf(csv,
                 "step,pose,factors,ms,relinearized,reeliminated,add_ms,relinearize_ms,"
                 "remove_top_ms,order_ms,eliminate_ms,solve_ms\n");
  }
  double worst_ms = -1.0;
  core::Stopwatch total;
  for (int k = 0; k < steps.size(); ++k) {
    const core::DatasetStep step = steps.Step(k);
    core::Stopwatch timer;
    core::FactorGraph factors;
    core::Values values;
    core::PrepareStep(
        step, [&](core::Key key) { return isam.CalculateEstimate(key); }, &factors, &values);
    if (k == 0) {
      const core::Status anchored = core::AddGaugePrior(values, step.pose, opt.anchor_sigma, &factors);
      if (!anchored.ok()) Fail(kExitFailure, anchored.ToString());
    }
    const core::Isam2Result r = isam.Update(factors, values);
    if (!r.status.ok()) {
      Fail(kExitFailure, "update for " + core::KeyToString(step.pose) + ": " + r.status.ToString());
    }
    (void)isam.CalculateEstimate(step.pose);  // the step includes reading the newest estimate
    step_ms.push_back(timer.Seconds() * 1e3);
    step_factors.push_back(factors.size());
    odometry_only.push_back(step.odometry != nullptr && step.factors.size() == 1);
    if (step_ms.back() > worst_ms) {
      worst_ms = step_ms.back();
      worst_step = core::KeyToString(step.pose) + ": " + r.Brief();
    }
    if (csv) {
      const core::Isam2Result::Seconds& t = r.seconds;
      std::fprintf(csv, "%zu,%s,%zu,%.6f,%d,%d,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f\n", step_ms.size() - 1,
                   core::KeyToString(step.pose).c_str(), factors.size(), step_ms.back(),
                   r.relinearized_variables, r.reeliminated_variables, t.add * 1e3,
                   t.relinearize * 1e3, t.remove_top * 1e3, t.order * 1e3, t.eliminate * 1e3,
                   t.solve * 1e3);
    }
    if (opt.marginals != "none" && step_ms.size() % opt.marginals_every == 0) {
      core::Stopwatch marginal_timer;
      if (opt.marginals == "latest") {
        const core::Status s = marginals.Marginal(step.pose, Frame::kEstimate, &cov);
        if (!s.ok()) Fail(kExitFailure, "marginal of " + core::KeyToString(step.pose) + ": " + s.ToString());
      } else {
        marginals.ComputeAll();
      }
      marginal_ms.push_back(marginal_timer.Seconds() * 1e3);
    }
    relinearized += r.relinearized_variables;
    reeliminated += r.reeliminated_variables;
  }
  const double total_s = total.Seconds();
  if (csv && std::fclose(csv) != 0) Fail(kExitFailure, "cannot write " + opt.step_times);
  const MemoryFigures memory = MemoryFigures::Measure(&isam);
  const double chi2_before_settle = isam.Chi2();
  double final_chi2 = chi2_before_settle;
  double settle_used_s = 0.0;
  if (opt.settle_s > 0.0) {
    const core::Isam2::RefineResult refined = isam.Refine(opt.settle_s);
    if (!refined.status.ok()) Fail(kExitFailure, "settling: " + refined.status.ToString());
    settle_used_s = refined.seconds;
    final_chi2 = isam.Chi2();
  }
  // Every variable's marginal once at the end, from scratch (a fresh cache), in the estimate's
  // tangent space.
  double marginals_final_all_ms = 0.0;
  int marginals_final_threads = 0;
  if (opt.marginals != "none") {
    core::Stopwatch timer;
    core::Isam2Marginals fresh(&isam, marginals_params);
    fresh.ComputeAll();
    for (core::Key key : isam.linearization_point().keys()) {
      const core::Status s = fresh.CachedMarginal(key, Frame::kEstimate, &cov);
      if (!s.ok()) Fail(kExitFailure, "marginal of " + core::KeyToString(key) + ": " + s.ToString());
    }
    marginals_final_all_ms = timer.Seconds() * 1e3;
    marginals_final_threads = fresh.tree_marginals().stats().threads_used;
  }
  double batch_chi2 = -1.0;
  if (opt.compare_batch) {
    core::FactorGraph graph = isam.Factors();
    const core::BatchResult b = core::Optimize(graph, isam.CalculateEstimate());
    if (!b.status.ok()) Fail(kExitFailure, "batch comparison: " + b.status.ToString());
    batch_chi2 = b.summary.final_chi2;
  }

  Ate(opt, isam.CalculateEstimate(), &accuracy);

  // Step-time growth: p50 over two windows (steps 500-1000 and the last 500), of all steps and
  // of the odometry-only steps among them (the O(1) criterion: the share of loop-closure
  // steps differs between windows, and they are slower).
  const auto window = [&](std::size_t a, std::size_t b, bool odometry) {
    if (b > step_ms.size() || a >= b) return 0.0;
    std::vector<double> in;
    for (std::size_t i = a; i < b; ++i) {
      if (!odometry || odometry_only[i]) in.push_back(step_ms[i]);
    }
    return in.empty() ? 0.0 : Percentile(in, 0.5);
  };
  const std::size_t late = step_ms.size() > 500 ? step_ms.size() - 500 : 0;
  const std::vector<double> step_ms_per_factor = PerFactor(step_ms, step_factors);
  const std::vector<double> queued_ms =
      opt.rate_hz > 0 ? QueuedLatencies(step_ms, step_factors, opt.rate_hz) : std::vector<double>{};
  const auto percentiles = [](const std::vector<double>& v) {
    JsonWriter ms;
    ms.Add("p50", Percentile(v, 0.5))
        .Add("p90", Percentile(v, 0.9))
        .Add("p99", Percentile(v, 0.99))
        .Add("max", *std::max_element(v.begin(), v.end()));
    return ms;
  };
  if (opt.json) {
    JsonWriter out;
    out.Add("dataset", opt.dataset)
        .Add("poses", data.poses.size())
        .Add("landmarks", data.landmarks.size())
        .Add("factors", data.graph.size())
        .Add("solver", "isam2")
        .Add("steps", steps.size())
        .Add("total_s", total_s)
        .Add("step_ms", percentiles(step_ms))
        .Add("step_ms_per_factor", percentiles(step_ms_per_factor))
        .Add("p50_early_ms", window(500, 1000, false))
        .Add("p50_late_ms", window(late, step_ms.size(), false))
        .Add("odometry_p50_early_ms", window(500, 1000, true))
        .Add("odometry_p50_late_ms", window(late, step_ms.size(), true))
        .Add("chi2_before_settle", chi2_before_settle)
        .Add("final_chi2", final_chi2)
        .Add("settle_s", settle_used_s)
        .Add("relinearized_total", relinearized)
        .Add("reeliminated_total", reeliminated)
        .Add("read_s", read_s)
        .Add("worst_step", worst_step)
        .Add("peak_rss_mb", PeakRssMb())
        .Add("heap_peak_mb", memory.heap_peak / (1 << 20))
        .Add("memory_bytes_per_variable", memory.PerVariable());
    if (opt.compare_batch) out.Add("batch_chi2", batch_chi2);
    if (opt.rate_hz > 0) {
      out.Add("rate_hz", opt.rate_hz).Add("queued_ms", percentiles(queued_ms));
    }
    AddAccuracy(opt, accuracy, &out);
    if (opt.marginals != "none") {
      JsonWriter mm;
      mm.Add("p50", Percentile(marginal_ms, 0.5))
          .Add("p90", Percentile(marginal_ms, 0.9))
          .Add("p99", Percentile(marginal_ms, 0.99))
          .Add("max", marginal_ms.empty() ? 0.0 : *std::max_element(marginal_ms.begin(), marginal_ms.end()));
      out.Add("marginals", opt.marginals).Add("marginal_ms", mm).Add("marginals_final_all_ms", marginals_final_all_ms)
          .Add("marginals_final_threads", marginals_final_threads);
    }
    std::printf("%s\n", out.str().c_str());
  } else {
    std::printf("%s: %zu poses, %zu landmarks, %zu factors, %d steps\n", opt.dataset.c_str(),
                data.poses.size(), data.landmarks.size(), data.graph.size(), steps.size());
    std::printf("isam2: %.3f s total; step ms p50 %.3f, p90 %.3f, p99 %.3f, max %.3f\n", total_s,
                Percentile(step_ms, 0.5), Percentile(step_ms, 0.9), Percentile(step_ms, 0.99),
                *std::max_element(step_ms.begin(), step_ms.end()));
    std::printf("       counted once per factor: p50 %.3f, p90 %.3f, p99 %.3f\n",
                Percentile(step_ms_per_factor, 0.5), Percentile(step_ms_per_factor, 0.9),
                Percentile(step_ms_per_factor, 0.99));
    if (opt.rate_hz > 0) {
      std::printf(
          "       one at a time at %g poses/s, per message with queueing: p50 %.3f, p99 %.3f, "
          "max %.3f\n",
          opt.rate_hz, Percentile(queued_ms, 0.5), Percentile(queued_ms, 0.99),
          *std::max_element(queued_ms.begin(), queued_ms.end()));
    }
    std::printf("chi2 %.9g after the last step, %.9g final (settled %.3f s)%s\n", chi2_before_settle,
                final_chi2, settle_used_s, opt.compare_batch ? "" : "");
    if (opt.compare_batch) std::printf("batch chi2 of the final graph: %.9g\n", batch_chi2);
    if (opt.marginals != "none") {
      std::printf("marginals (%s) ms per step p50 %.4f, p99 %.4f; all marginals at the end %.2f ms\n",
                  opt.marginals.c_str(), Percentile(marginal_ms, 0.5), Percentile(marginal_ms, 0.99),
                  marginals_final_all_ms);
    }
    PrintAccuracy(opt, accuracy);
    std::printf("slowest step %s\n", worst_step.c_str());
    std::printf("relinearized %lld variables, re-eliminated %lld; peak RSS %.1f MB, heap %.1f MB\n",
                relinearized, reeliminated, PeakRssMb(), memory.heap_peak / (1 << 20));
    memory.Print();
  }
}

// A reconstruction camera by camera (core/ba/reconstruction_stream.h): one update per image,
// points entering once two views see them with parallax. Costs are Ceres's (½ Σ ρ, pixels²) of
// the whole graph (the anchors' priors add ~0); `batch_cost` is the batch optimum of the same
// graph (--compare-batch).
// A point more than 80° off a camera's optical axis that observes it has left its field of view
// (a pixel measured there would be far outside the image): its projection's derivatives grow
// without bound towards 90°.
constexpr double kMinCosFromAxis = 0.17;

// The largest angle [deg] between the rays from `images`' camera centres to `point` at the
// estimate, or -1 when the point is behind one of them or more than 80° off its axis. `cameras`
// holds the images' estimates of this step, indexed by image (read once per step, not once per
// observation); `rays` is scratch.
double RayParallaxDeg(const core::Isam2& isam, const core::ReconstructionStream& stream, int point,
                      const std::vector<int>& images, const std::vector<core::Pose3>& cameras,
                      std::vector<core::Vector3>* rays) {
  const core::Point3 X =
      std::get<core::Point3>(isam.CalculateEstimate(stream.keys().points[point]));
  rays->clear();
  for (int i : images) {
    const core::Pose3& pose = cameras[i];
    const core::Point3 in_camera = pose.TransformTo(X);
    if (in_camera.z() <= kMinCosFromAxis * in_camera.norm()) return -1.0;
    rays->push_back((X - pose.translation()).normalized());
  }
  double min_cos = 1.0;
  for (size_t a = 0; a < rays->size(); ++a) {
    for (size_t c = a + 1; c < rays->size(); ++c) {
      min_cos = std::min(min_cos, (*rays)[a].dot((*rays)[c]));
    }
  }
  return std::acos(std::clamp(min_cos, -1.0, 1.0)) * 180.0 / M_PI;
}

// Takes `points` out of the solver, `graph` and `initial`: their factors removed (weak priors
// holding them meanwhile), then the variables, which then have nothing to summarise. Adds the
// observations removed to *removed.
core::Status DropPoints(const std::vector<int>& points, core::ReconstructionStream* stream,
                        core::Isam2* isam, core::FactorGraph* graph, core::Values* initial,
                        int* removed) {
  std::set<core::Key> keys;
  for (int j : points) keys.insert(stream->keys().points[j]);
  const auto touches = [&](const core::FactorPtr& f) {
    return std::any_of(f->keys().begin(), f->keys().end(),
                       [&](core::Key k) { return keys.count(k) > 0; });
  };
  std::vector<int> indices;
  const std::vector<core::FactorPtr>& slots = isam->factor_slots();
  for (int f = 0; f < static_cast<int>(slots.size()); ++f) {
    if (slots[f] && touches(slots[f])) indices.push_back(f);
  }
  core::FactorGraph hold;
  for (core::Key key : keys) {
    hold.Emplace<core::PriorFactor<core::Point3>>(
        key, std::get<core::Point3>(isam->CalculateEstimate(key)),
        core::NoiseModel::Isotropic(3, 1e3).value());
  }
  SLAMD_RETURN_IF_ERROR(isam->Update(hold, {}, {.remove_factors = indices}).status);
  *removed += static_cast<int>(indices.size());
  const core::KeyVector removed_keys(keys.begin(), keys.end());
  SLAMD_RETURN_IF_ERROR(isam->RemoveVariables(removed_keys).status);
  core::FactorGraph kept;
  for (const core::FactorPtr& f : *graph) {
    if (!touches(f)) kept.Add(f);
  }
  *graph = std::move(kept);
  for (core::Key key : keys) SLAMD_RETURN_IF_ERROR(initial->Erase(key));
  for (int j : points) stream->Drop(j);
  return core::Status::Ok();
}

void RunIsam2Reconstruction(const BenchOptions& opt) {
  core::Stopwatch read_timer;
  core::Result<core::Reconstruction> r = core::ReadReconstruction(opt.dataset);
  if (!r.ok()) Fail(kExitFailure, r.status().ToString());
  const double read_s = read_timer.Seconds();
  core::Result<core::ReconstructionStream> stream =
      core::ReconstructionStream::Create(*r, {.refine_intrinsics = !opt.fixed_intrinsics,
                                              .min_parallax_deg = opt.min_parallax_deg,
                                              .robust = opt.robust});
  if (!stream.ok()) Fail(kExitFailure, stream.status().ToString());
  core::Result<std::unique_ptr<core::Isam2>> created = core::Isam2::Create(opt.isam2);
  if (!created.ok()) Fail(kExitUsage, created.status().message());
  core::Isam2& isam = **created;

  core::FactorGraph graph;  // every factor the solver took, for the batch reference
  core::Values initial;
  std::vector<double> step_ms;
  int observations_in = 0, observations_removed = 0;  // entered; taken out with dropped points
  std::string failure;
  std::FILE* csv = nullptr;
  if (!opt.step_times.empty()) {
    csv = std::fopen(opt.step_times.c_str(), "w");
    if (csv == nullptr) Fail(kExitFailure, "cannot write " + opt.step_times);
    std::fprintf(csv,
                 "step,points_entered,observations_entered,ms,relinearized,reeliminated,cost\n");
  }
  std::vector<core::Pose3> cameras;  // the images' estimates, for the parallax check
  std::vector<core::Vector3> rays;
  double untimed_s = 0.0;  // the CSV's costs, not part of the steps
  core::Stopwatch total;
  for (int i = 0; i < stream->num_steps(); ++i) {
    core::Stopwatch timer;
    const core::ReconstructionStep step = stream->Next();
    const core::Isam2Result u = isam.Update(step.factors, step.values);
    if (!u.status.ok()) {  // nothing changed; later cameras need this one: stop here
      failure = "update for image " + std::to_string(i) + ": " + u.status.ToString();
      break;
    }
    if (!step.images_entered.empty()) {  // the newest camera's estimate
      (void)isam.CalculateEstimate(stream->keys().images[step.images_entered.back()]);
    }
    for (const core::FactorPtr& f : step.factors) graph.Add(f);
    for (int s = 0; s < static_cast<int>(step.values.size()); ++s) {
      (void)initial.Insert(step.values.KeyAt(s), step.values.VariableAt(s));
    }
    // Points whose rays at the estimate have become nearly parallel (run off along them) or that
    // went behind a camera: out before their depth becomes indeterminate.
    std::string drop_failure;
    if (opt.drop_parallax_deg > 0.0) {
      cameras.resize(r->images.size());
      for (int k = 0; k < static_cast<int>(r->images.size()); ++k) {
        const core::Key key = stream->keys().images[k];
        if (isam.linearization_point().Contains(key)) {
          cameras[k] = std::get<core::Pose3>(isam.CalculateEstimate(key));
        }
      }
      std::vector<int> degenerate;
      for (int j = 0; j < static_cast<int>(r->points.size()); ++j) {
        if (stream->Droppable(j) && RayParallaxDeg(isam, *stream, j, stream->ImagesSeeing(j),
                                                   cameras, &rays) < opt.drop_parallax_deg) {
          degenerate.push_back(j);
        }
      }
      if (!degenerate.empty()) {
        const core::Status dropped =
            DropPoints(degenerate, &*stream, &isam, &graph, &initial, &observations_removed);
        if (!dropped.ok()) drop_failure = dropped.ToString();
      }
    }
    if (!drop_failure.empty()) {
      failure = "dropping a point after image " + std::to_string(i) + ": " + drop_failure;
      break;
    }
    step_ms.push_back(timer.Seconds() * 1e3);
    observations_in += step.observations_entered;
    if (csv) {
      core::Stopwatch untimed;
      std::fprintf(csv, "%d,%d,%d,%.6f,%d,%d,%.10g\n", i, step.points_entered,
                   step.observations_entered, step_ms.back(), u.relinearized_variables,
                   u.reeliminated_variables, 0.5 * graph.Cost(isam.CalculateEstimate()));
      untimed_s += untimed.Seconds();
    }
  }
  const double total_s = total.Seconds() - untimed_s;
  if (csv && std::fclose(csv) != 0) Fail(kExitFailure, "cannot write " + opt.step_times);
  const double cost = 0.5 * graph.Cost(isam.CalculateEstimate());
  // The same graph at the values its cameras and points entered with: an estimate above it has
  // diverged (Gauss-Newton on calibrations a few images determine), which the summary says.
  const double initial_cost = 0.5 * graph.Cost(initial);
  const bool diverged = std::isnan(cost) || cost > initial_cost;
  if (diverged) {
    std::fprintf(stderr,
                 "slamctl bench: warning: the estimate after the last step costs more than the "
                 "values it was given (%.6g > %.6g): the incremental solve diverged; refining "
                 "calibrations camera by camera needs --trust-region --relinearize-skip 1 "
                 "--drop-parallax 0.05, or hold them with --fixed-intrinsics\n",
                 cost, initial_cost);
  }
  const MemoryFigures memory = MemoryFigures::Measure(&isam);
  double settled_cost = cost;
  if (opt.settle_s > 0.0 && failure.empty()) {
    (void)isam.Refine(opt.settle_s);
    settled_cost = 0.5 * graph.Cost(isam.CalculateEstimate());
  }
  double batch_cost = -1.0;
  if (opt.compare_batch) {
    const core::BatchResult batch = core::Optimize(graph, initial, opt.batch);
    if (!batch.status.ok()) Fail(kExitFailure, "batch reference: " + batch.status.ToString());
    batch_cost = 0.5 * batch.summary.final_cost;
  }
  const int failed_updates = failure.empty() ? 0 : 1;
  if (opt.json) {
    JsonWriter out;
    out.Add("dataset", opt.dataset)
        .Add("solver", opt.solver)
        .Add("cameras", r->images.size())
        .Add("steps", step_ms.size())
        .Add("failed_updates", failed_updates)
        .Add("observations", r->observations.size())
        .Add("observations_in_graph", observations_in - observations_removed)
        .Add("points_in_graph", stream->points_in() - stream->dropped_points())
        .Add("points_dropped", stream->dropped_points())
        .Add("observations_dropped", observations_removed + stream->dropped_observations())
        .Add("images_in_graph", r->images.size() - stream->held_images())
        .Add("read_s", read_s)
        .Add("total_s", total_s)
        .Add("step_ms_p50", Percentile(step_ms, 0.5))
        .Add("step_ms_p99", Percentile(step_ms, 0.99))
        .Add("step_ms_max", Percentile(step_ms, 1.0))
        .Add("initial_cost", initial_cost)
        .Add("final_cost", cost)
        .Add("diverged", diverged)
        .Add("settled_cost", settled_cost)
        .Add("peak_rss_mb", PeakRssMb())
        .Add("heap_peak_mb", memory.heap_peak / (1 << 20))
        .Add("memory_bytes_per_variable", memory.PerVariable());
    if (opt.compare_batch) out.Add("batch_cost", batch_cost);
    std::printf("%s\n", out.str().c_str());
  } else {
    std::printf("%s: %zu cameras, %zu points, %zu observations (read in %.3f s)\n",
                opt.dataset.c_str(), r->images.size(), r->points.size(), r->observations.size(),
                read_s);
    std::printf(
        "isam2 camera by camera: %zu steps in %.3f s (step p50 %.2f ms, p99 %.2f ms, max "
        "%.2f ms), %d of %zu observations, %d points and %zu images in the graph\n",
        step_ms.size(), total_s, Percentile(step_ms, 0.5), Percentile(step_ms, 0.99),
        Percentile(step_ms, 1.0), observations_in - observations_removed, r->observations.size(),
        stream->points_in() - stream->dropped_points(), r->images.size() - stream->held_images());
    if (stream->dropped_points() > 0) {
      std::printf("dropped: %d points whose rays became parallel, %d observations\n",
                  stream->dropped_points(), observations_removed + stream->dropped_observations());
    }
    std::printf(
        "cost (½Σρ, px²) at the values as entered %.10g, after the last step %.10g, "
        "settled %.10g",
        initial_cost, cost, settled_cost);
    if (opt.compare_batch) std::printf(", batch optimum %.10g", batch_cost);
    std::printf("; peak RSS %.1f MB\n", PeakRssMb());
    memory.Print();
  }
  if (!failure.empty()) Fail(kExitFailure, failure);
}

}  // namespace slamd::clients::bench
