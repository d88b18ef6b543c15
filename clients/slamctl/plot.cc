// slamctl plot: a report-quality top-down picture of one or more datasets (one robot each):
// read -> optionally optimise (batch) -> optionally marginals -> PlotScene -> Cairo file.
// With --live, the running slamd's map instead: query_t -> map_t pages -> PlotScene (plot_live.h).
// A reconstruction (BAL file, COLMAP text model): read -> optionally bundle-adjust -> cameras and
// points in a plane (plot_reconstruction.h) -> PlotScene -> Cairo file.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "clients/slamctl/client_common.h"
#include "clients/slamctl/commands.h"
#include "clients/slamctl/plot_live.h"
#include "clients/slamctl/plot_reconstruction.h"
#include "clients/slamctl/plot_render.h"
#include "clients/slamctl/plot_scene.h"
#include "core/ba/bundle_adjuster.h"
#include "core/batch/batch_solver.h"
#include "core/io/dataset.h"
#include "core/io/sfm_io.h"
#include "server/journal/snapshot_file.h"
#include "server/snapshot/estimator_state.h"
#include "server/snapshot/state_codec.h"

namespace slamd::clients {
namespace {

struct PlotOptions {
  std::vector<std::string> datasets;
  std::string output;
  std::string format;             // empty: from the output's extension
  std::string size = "1200x900";  // WxH
  bool optimize = false;
  bool ba = false;             // --ba: bundle-adjust a reconstruction first
  std::string plane = "auto";  // a reconstruction's view plane: auto, xy, xz or yz
  bool covariances = false;
  int ellipse_every = 0;  // 0: about 50 pose ellipses per robot
  double sigma = 3.0;
  double anchor_sigma = 1e-3;
  std::string isam_noise = "sqrt-information";
  std::string title;
  core::BatchParams batch;
  std::string snapshot;     // --snapshot: a slamd snapshot file instead of datasets
  bool live = false;        // --live: the running server's map instead of datasets
  double timeout_s = 10.0;  // --live: longest wait for the whole answer [s]
  ConnectionOptions connection;
};

[[noreturn]] void Fail(int code, const std::string& message) {
  std::fprintf(stderr, "slamctl plot: %s\n", message.c_str());
  throw CommandExit{code};
}

struct Loaded {
  plot::PlotRobot robot;
  int ellipse_every = 1;  // the pose subsampling used
};

core::Dataset ReadRobot(const PlotOptions& opt, const std::string& path) {
  core::ReadOptions read;
  read.isam_noise = opt.isam_noise == "covariance" ? core::ReadOptions::IsamNoise::kCovariance
                                                   : core::ReadOptions::IsamNoise::kSqrtInformation;
  core::Result<core::Dataset> loaded = core::ReadDataset(path, read);
  if (!loaded.ok()) Fail(kExitFailure, loaded.status().ToString());
  return std::move(loaded).value();
}

// A slamd snapshot file (DATA_DIR/snapshot-*.snp) as one dataset per robot: its poses and
// landmarks at the snapshot's linearisation point and the factors among them (inter-robot
// loop closures are left out: each robot is drawn from its own graph).
std::vector<std::pair<std::string, core::Dataset>> SnapshotRobots(const std::string& path) {
  core::Result<std::string> bytes = server::ReadSnapshotFile(path);
  if (!bytes.ok()) Fail(kExitFailure, bytes.status().ToString());
  server::JournalPosition position;
  core::Result<server::EstimatorState> state = server::DecodeState(*bytes, &position);
  if (!state.ok()) Fail(kExitFailure, path + ": " + state.status().ToString());
  std::vector<std::pair<std::string, core::Dataset>> robots;
  for (const server::EstimatorState::Robot& r : state->robots) {
    core::Dataset d;
    d.path = path;
    const core::Values& theta = state->linearization_point;
    for (core::Key k : theta.keys()) {
      if (core::KeyRobot(k) != r.id) continue;
      (core::KeySymbol(k) == 'x' ? d.poses : d.landmarks).push_back(k);
    }
    if (d.poses.empty()) continue;
    std::sort(d.poses.begin(), d.poses.end());
    std::sort(d.landmarks.begin(), d.landmarks.end());
    for (const std::vector<core::Key>* keys : {&d.poses, &d.landmarks}) {
      for (core::Key k : *keys) (void)d.initial.Insert(k, theta.Get(k));
    }
    d.is_3d = std::holds_alternative<core::Pose3>(theta.Get(d.poses.front()));
    for (const core::FactorPtr& f : state->factors) {
      const bool own = std::all_of(f->keys().begin(), f->keys().end(),
                                   [&](core::Key k) { return core::KeyRobot(k) == r.id; });
      if (own) d.graph.Add(f);
    }
    robots.emplace_back(r.name, std::move(d));
  }
  if (robots.empty()) Fail(kExitFailure, path + ": the snapshot holds no robot with poses");
  return robots;
}

Loaded LoadRobot(const PlotOptions& opt, const std::string& name, const core::Dataset& data) {
  const std::string& path = data.path;
  Loaded out;

  // The gauge as in `slamctl bench`: a tight prior on the first pose where it is.
  core::Values values = data.initial;
  const auto anchored = [&](const core::Values& at) {
    core::FactorGraph graph = data.graph;
    if (!data.poses.empty()) {
      const core::Status s = core::AddGaugePrior(at, data.poses.front(), opt.anchor_sigma, &graph);
      if (!s.ok()) Fail(kExitFailure, path + ": " + s.ToString());
    }
    return graph;
  };
  if (opt.optimize) {
    const core::BatchResult result =
        core::Optimize(anchored(data.initial), data.initial, opt.batch);
    if (!result.status.ok())
      Fail(kExitFailure, path + ": optimisation failed: " + result.status.ToString());
    values = result.values;
    std::fprintf(stderr, "slamctl plot: %s: %s\n", name.c_str(), result.summary.Brief().c_str());
  }

  plot::SceneOptions scene_options{.sigma = opt.sigma};
  scene_options.ellipse_every =
      opt.ellipse_every > 0 ? opt.ellipse_every
                            : std::max<int>(1, static_cast<int>((data.poses.size() + 49) / 50));
  std::unique_ptr<plot::MarginalTable> marginals;
  if (opt.covariances) {
    // Only the keys that get an ellipse, in the tangent at the plotted values.
    std::vector<core::Key> keys;
    for (std::size_t i = 0; i < data.poses.size(); i += scene_options.ellipse_every)
      keys.push_back(data.poses[i]);
    if (!data.poses.empty() && keys.back() != data.poses.back()) keys.push_back(data.poses.back());
    keys.insert(keys.end(), data.landmarks.begin(), data.landmarks.end());
    core::Result<plot::MarginalTable> table =
        plot::ComputeMarginals(anchored(values), values, keys);
    if (!table.ok()) Fail(kExitFailure, path + ": marginals failed: " + table.status().ToString());
    marginals = std::make_unique<plot::MarginalTable>(std::move(table).value());
  }
  core::Result<plot::PlotRobot> robot =
      plot::BuildRobot(name, data, values, scene_options, marginals.get());
  if (!robot.ok()) Fail(kExitFailure, path + ": " + robot.status().ToString());
  out.robot = std::move(robot).value();
  out.ellipse_every = scene_options.ellipse_every;
  return out;
}

// 2 -> "2nd", 11 -> "11th", 23 -> "23rd".
std::string Ordinal(int n) {
  const int tens = n % 100, ones = n % 10;
  const char* suffix = (tens >= 11 && tens <= 13) ? "th"
                       : ones == 1                ? "st"
                       : ones == 2                ? "nd"
                       : ones == 3                ? "rd"
                                                  : "th";
  return std::to_string(n) + suffix;
}

std::string Title(const plot::PlotScene& scene) {
  std::string title = scene.robots.size() == 1 ? scene.robots.front().name
                                               : std::to_string(scene.robots.size()) + " robots";
  title += ": " + std::to_string(scene.NumPoses()) + " poses";
  if (scene.NumLandmarks() > 0) title += ", " + std::to_string(scene.NumLandmarks()) + " landmarks";
  title += ", " + std::to_string(scene.NumLoopClosures()) + " loop closures";
  return title;
}

// --live: one query for every robot's map (with marginals for --covariances), then the scene.
void RunPlotLive(const PlotOptions& opt, const plot::RenderOptions& render) {
  server::ChannelNames channels;
  std::unique_ptr<LcmClient> client = ConnectOrFail("plot", opt.connection, &channels);
  const core::Result<plot::MapPageCollector> answer =
      plot::FetchLiveMap(*client, channels, opt.covariances, opt.timeout_s);
  if (!answer.ok()) {
    Fail(kExitFailure, answer.status().message() + " (is slamd running on " + client->url() + "?)");
  }
  if (answer->reply().status == slamd::query_reply_t::STATUS_PARTIAL) {
    std::fprintf(stderr, "slamctl plot: warning: %s\n", answer->reply().error.c_str());
  }
  core::Result<plot::LiveScene> live = plot::BuildLiveScene(
      answer->pages(), {.ellipse_every = opt.ellipse_every, .sigma = opt.sigma});
  if (!live.ok()) Fail(kExitFailure, "map from slamd: " + live.status().message());
  plot::PlotScene& scene = live->scene;

  std::string title = "slamd live map: ";
  if (scene.robots.size() != 1) title += std::to_string(scene.robots.size()) + " robots, ";
  title += std::to_string(scene.NumPoses()) + " poses";
  if (scene.NumLandmarks() > 0) title += ", " + std::to_string(scene.NumLandmarks()) + " landmarks";
  title += " (update " + std::to_string(live->update_sequence) + ")";
  scene.title = opt.title.empty() ? title : opt.title;
  scene.subtitle = "the server's current estimate; loop closures not shown";
  if (opt.covariances) {
    char sigma[32];
    std::snprintf(sigma, sizeof sigma, "%g", opt.sigma);
    scene.subtitle += std::string("; ") + sigma + "\xcf\x83 ellipses of the x-y marginals";
    const std::vector<int>& every = live->ellipse_every;
    if (std::adjacent_find(every.begin(), every.end(), std::not_equal_to<>()) != every.end()) {
      scene.subtitle += " (subsampled poses)";
    } else if (!every.empty() && every.front() > 1) {
      scene.subtitle += " (every " + Ordinal(every.front()) + " pose)";
    }
    if (live->missing_covariances > 0) {
      scene.subtitle += "; " + std::to_string(live->missing_covariances) +
                        " without (marginals not ready in time)";
    }
  }
  const core::Status written = plot::RenderScene(scene, opt.output, render);
  if (!written.ok()) Fail(kExitFailure, written.ToString());
  std::printf("wrote %s (%dx%d): %zu robots, %zu poses, %zu landmarks, %zu ellipses, update %lld\n",
              opt.output.c_str(), render.width, render.height, scene.robots.size(),
              scene.NumPoses(), scene.NumLandmarks(), scene.NumEllipses(),
              static_cast<long long>(live->update_sequence));
}

// One reconstruction (opt.datasets holds only it), in the chosen plane.
void RunPlotReconstruction(const PlotOptions& opt, const plot::RenderOptions& render) {
  const std::string& path = opt.datasets.front();
  core::Result<core::Reconstruction> read = core::ReadReconstruction(path);
  if (!read.ok()) Fail(kExitFailure, read.status().ToString());
  core::Reconstruction r = std::move(read).value();
  std::string state = "as read from the file";
  core::Result<core::CameraCovariances> covariances =
      core::FailedPrecondition("no bundle adjustment");
  if (opt.ba) {
    const core::Result<core::BundleAdjusterSummary> adjusted =
        core::BundleAdjust(core::BundleAdjusterParams{}, &r);
    if (!adjusted.ok()) {
      Fail(kExitFailure, path + ": bundle adjustment failed: " + adjusted.status().ToString());
    }
    char line[160];
    std::snprintf(line, sizeof line, "cost %.6g -> %.6g in %zu iterations (%s), rms %.4f px",
                  adjusted->initial_cost, adjusted->final_cost, adjusted->iterations.size(),
                  adjusted->termination.c_str(), adjusted->rms_reprojection_px);
    std::fprintf(stderr, "slamctl plot: bundle adjustment: %s\n", line);
    std::snprintf(line, sizeof line, "bundle-adjusted (rms reprojection error %.3g px)",
                  adjusted->rms_reprojection_px);
    state = line;
    // The cameras' covariances for pixel noise of the rms error found.
    covariances = core::EstimateCameraCovariances(r, core::BundleAdjusterParams{},
                                                  std::max(adjusted->rms_reprojection_px, 1e-6));
    if (!covariances.ok()) {
      std::fprintf(stderr, "slamctl plot: no camera ellipses: %s\n",
                   covariances.status().ToString().c_str());
    }
  }
  const bool automatic = opt.plane == "auto";
  const core::Result<plot::ViewPlane> plane =
      automatic ? core::Result<plot::ViewPlane>(plot::ChooseViewPlane(r))
                : plot::ParseViewPlane(opt.plane);
  if (!plane.ok()) Fail(kExitUsage, "--plane: " + plane.status().message());

  plot::PlotScene scene;
  scene.reconstruction = plot::BuildReconstruction(r, *plane);
  scene.sigma = opt.sigma;
  if (covariances.ok()) {
    scene.reconstruction.camera_ellipses = plot::CameraEllipses(r, *covariances, *plane, opt.sigma);
    char gauge[120];
    std::snprintf(gauge, sizeof gauge, "; %gσ camera-centre ellipses (gauge: camera %d, scale %d)",
                  opt.sigma, covariances->gauge_image, covariances->scale_image);
    state += gauge;
  }
  scene.x_label = plot::HorizontalLabel(*plane);
  scene.y_label = plot::VerticalLabel(*plane);
  std::filesystem::path name(path);
  if (name.filename().empty()) name = name.parent_path();  // "model/"
  scene.title = opt.title.empty()
                    ? name.filename().string() + ": " + std::to_string(r.images.size()) +
                          " cameras, " + std::to_string(r.points.size()) + " points, " +
                          std::to_string(r.observations.size()) + " observations"
                    : opt.title;
  const std::string axes = plot::ViewPlaneName(*plane);  // "xz" -> "x-z plane"
  scene.subtitle = state + "; " + axes.substr(0, 1) + "-" + axes.substr(1) + " plane" +
                   (automatic ? " (the widest spread of the cameras)" : "");
  const core::Status written = plot::RenderScene(scene, opt.output, render);
  if (!written.ok()) Fail(kExitFailure, written.ToString());
  std::printf("wrote %s (%dx%d): %zu cameras, %zu points, %zu observations, %s plane\n",
              opt.output.c_str(), render.width, render.height, r.images.size(), r.points.size(),
              r.observations.size(), plot::ViewPlaneName(*plane));
}

void RunPlot(const PlotOptions& opt) {
  // Argument checks first (exit 2), before any work.
  if (opt.live && !opt.datasets.empty()) {
    Fail(kExitUsage, "--live plots the running server's map: give no dataset files with it");
  }
  if (!opt.snapshot.empty() && (opt.live || !opt.datasets.empty())) {
    Fail(kExitUsage, "--snapshot plots a snapshot file: give no dataset files or --live with it");
  }
  if (!opt.live && opt.datasets.empty() && opt.snapshot.empty()) {
    Fail(kExitUsage, "give dataset files to plot, --snapshot FILE, or --live");
  }
  const bool reconstruction =
      std::any_of(opt.datasets.begin(), opt.datasets.end(),
                  [](const std::string& p) { return plot::IsReconstructionPath(p); });
  if (reconstruction) {
    if (opt.datasets.size() > 1) {
      Fail(kExitUsage, "a reconstruction (BAL file or COLMAP directory) is plotted alone");
    }
    if (opt.optimize) {
      Fail(kExitUsage, "--optimize is for pose graphs: --ba bundle-adjusts a reconstruction");
    }
    if (opt.covariances) {
      Fail(kExitUsage, "--covariances: no camera covariances for a reconstruction yet");
    }
  } else {
    if (opt.ba) {
      Fail(kExitUsage,
           "--ba bundle-adjusts a reconstruction (a BAL file or COLMAP directory); use "
           "--optimize for pose graphs");
    }
    if (opt.plane != "auto") Fail(kExitUsage, "--plane is for reconstructions");
  }
  plot::RenderOptions render;
  if (!ParseSize(opt.size, &render.width, &render.height)) {
    Fail(kExitUsage, "--size '" + opt.size + "': expected WIDTHxHEIGHT, e.g. 1200x900");
  }
  const core::Result<plot::PlotFormat> format =
      opt.format.empty() ? plot::PlotFormatFromPath(opt.output) : plot::ParsePlotFormat(opt.format);
  if (!format.ok()) Fail(kExitUsage, format.status().message());
  render.format = *format;
  const std::filesystem::path dir = std::filesystem::path(opt.output).parent_path();
  if (!dir.empty() && !std::filesystem::is_directory(dir)) {
    Fail(kExitUsage, "-o " + opt.output + ": directory " + dir.string() + " does not exist");
  }
  for (const core::Status& valid : {render.Validate(), opt.batch.Validate()}) {
    if (!valid.ok()) Fail(kExitUsage, valid.message());
  }
  if (opt.live) {
    RunPlotLive(opt, render);
    return;
  }
  if (reconstruction) {
    RunPlotReconstruction(opt, render);
    return;
  }

  plot::PlotScene scene;
  scene.sigma = opt.sigma;
  std::vector<int> every;  // per robot
  std::vector<std::pair<std::string, core::Dataset>> robots;
  if (!opt.snapshot.empty()) robots = SnapshotRobots(opt.snapshot);
  for (const std::string& path : opt.datasets) {
    robots.emplace_back(std::filesystem::path(path).filename().string(), ReadRobot(opt, path));
  }
  for (const auto& [name, data] : robots) {
    Loaded loaded = LoadRobot(opt, name, data);
    scene.robots.push_back(std::move(loaded.robot));
    every.push_back(loaded.ellipse_every);
  }
  scene.title = opt.title.empty() ? Title(scene) : opt.title;
  char sigma[32];
  std::snprintf(sigma, sizeof sigma, "%g", opt.sigma);
  scene.subtitle = opt.optimize            ? "optimised (batch, first pose anchored)"
                   : !opt.snapshot.empty() ? "the snapshot's linearisation point"
                                           : "initial guess from the file";
  if (opt.covariances) {
    scene.subtitle += std::string("; ") + sigma + "\xcf\x83 ellipses of the x-y marginals";
    if (std::adjacent_find(every.begin(), every.end(), std::not_equal_to<>()) != every.end()) {
      scene.subtitle += " (subsampled poses)";
    } else if (every.front() > 1) {
      scene.subtitle += " (every " + Ordinal(every.front()) + " pose)";
    }
  }
  const core::Status written = plot::RenderScene(scene, opt.output, render);
  if (!written.ok()) Fail(kExitFailure, written.ToString());
  std::printf("wrote %s (%dx%d): %zu poses, %zu landmarks, %zu loop closures, %zu ellipses\n",
              opt.output.c_str(), render.width, render.height, scene.NumPoses(),
              scene.NumLandmarks(), scene.NumLoopClosures(), scene.NumEllipses());
}

}  // namespace

void RegisterPlot(CLI::App& app) {
  auto opt = std::make_shared<PlotOptions>();
  CLI::App* cmd = app.add_subcommand(
      "plot",
      "Draw datasets, or with --live the running slamd's map, top-down (trajectories, "
      "landmarks, loop closures, covariance ellipses), or a structure-from-motion "
      "reconstruction (cameras and points), to a PNG, SVG or PDF file");
  cmd->add_option("datasets", opt->datasets,
                  "Dataset files (g2o 2D/3D, TORO .graph, iSAM .txt); several = several robots. "
                  "Or one reconstruction: a COLMAP text model (a directory) or a BAL file (a file "
                  "whose first word is a number; pose-graph files start with a tag such as "
                  "VERTEX_SE2)")
      ->check(CLI::ExistingPath);
  cmd->add_option("-o,--output", opt->output, "Picture to write: *.png, *.svg or *.pdf")
      ->required();
  cmd->add_option("--format", opt->format, "png, svg or pdf (default: from the output's extension)")
      ->check(CLI::IsMember({"png", "svg", "pdf"}));
  cmd->add_option("--size", opt->size, "WIDTHxHEIGHT in pixels (PNG) or points (SVG, PDF)")
      ->capture_default_str();
  cmd->add_flag(
      "--optimize", opt->optimize,
      "Optimise each dataset first (batch Levenberg-Marquardt from the file's initial guess, "
      "first pose anchored)");
  CLI::Option* ba = cmd->add_flag(
      "--ba", opt->ba,
      "Reconstructions: bundle-adjust first (Levenberg-Marquardt, automatic linear solver, "
      "2 threads) and plot the result");
  cmd->add_option("--plane", opt->plane,
                  "Reconstructions: the plane to look at them in, xy, xz or yz; auto: the two "
                  "axes along which the camera centres spread most (xy when tied)")
      ->check(CLI::IsMember({"auto", "xy", "xz", "yz"}))
      ->capture_default_str();
  cmd->add_flag(
      "--covariances", opt->covariances,
      "Draw covariance ellipses of the x-y marginals at the plotted values (with the first pose "
      "anchored; after --optimize they are the optimum's)");
  cmd->add_option("--ellipse-every", opt->ellipse_every,
                  "--covariances: an ellipse for every K-th pose (0: about 50 per robot)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--sigma", opt->sigma, "Ellipses at this many standard deviations")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--anchor-sigma", opt->anchor_sigma,
                  "Sigma of the prior that anchors the first pose (metres and radians)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--isam-noise", opt->isam_noise,
                  "How iSAM-format noise columns are read: sqrt-information or covariance")
      ->check(CLI::IsMember({"sqrt-information", "covariance"}))
      ->capture_default_str();
  cmd->add_option("--title", opt->title, "Title (default: dataset name and counts)");
  CLI::Option* max_iterations =
      cmd->add_option("--max-iterations", opt->batch.max_iterations, "--optimize: iteration limit")
          ->capture_default_str();
  cmd->add_option("--snapshot", opt->snapshot,
                  "Plot a slamd snapshot file (DATA_DIR/snapshot-*.snp) instead of datasets: one "
                  "robot per robot in it, at the snapshot's linearisation point")
      ->check(CLI::ExistingFile);
  CLI::Option* live = cmd->add_flag(
      "--live", opt->live,
      "Plot the running slamd's map instead of datasets: every robot's poses and "
      "landmarks as the server estimates them now (with --covariances, its marginals). "
      "Loop closures are not drawn (map_t does not carry them); 3D maps are "
      "projected top-down");
  cmd->add_option("--timeout", opt->timeout_s, "--live: longest wait for the whole map [s]")
      ->check(CLI::PositiveNumber)
      ->capture_default_str()
      ->needs(live);
  AddConnectionOptions(cmd, &opt->connection);
  cmd->get_option("--lcm-url")->needs(live);
  cmd->get_option("--channel-prefix")->needs(live);
  for (const char* offline : {"--optimize", "--anchor-sigma", "--isam-noise"}) {
    live->excludes(cmd->get_option(offline));
  }
  live->excludes(max_iterations);
  live->excludes(ba);
  cmd->callback([opt] { RunPlot(*opt); });
}

}  // namespace slamd::clients
