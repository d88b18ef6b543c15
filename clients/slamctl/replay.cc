// slamctl replay SOURCE...: streams datasets (one robot each) or an LCM event log into a running
// slamd over LCM, paced, and reports what the server made of it. This file holds the options and
// turns the sources into ReplayItems; replay_run.cc sends them.
#include "clients/slamctl/replay.h"

#include <filesystem>
#include <map>
#include <memory>
#include <set>

#include "clients/slamctl/commands.h"
#include "clients/slamctl/plot_reconstruction.h"
#include "clients/slamctl/reconstruction_messages.h"
#include "clients/slamctl/sim_camera_world.h"
#include "core/io/dataset.h"
#include "core/io/sfm_io.h"

namespace slamd::clients {
namespace replay {
namespace {

constexpr const char* kReplayCommand = "replay";

[[noreturn]] void Usage(const std::string& message) { CommandFail(kReplayCommand, kExitUsage, message); }
[[noreturn]] void Failure(const std::string& message) {
  CommandFail(kReplayCommand, kExitFailure, message);
}

// The file stem with characters a robot name cannot hold replaced by '_'.
std::string RobotNameFromPath(const std::string& path) {
  std::string stem = std::filesystem::path(path).stem().string();
  for (char& c : stem) {
    if (!IsValidRobotName(std::string(1, c))) c = '_';
  }
  if (stem.empty()) stem = "robot";
  if (stem.size() > 64) stem.resize(64);
  return stem;
}

// Checks the combination of options (exit 2 with a message naming the conflict).
void CheckOptions(ReplayOptions* opt, bool is_log) {
  const int modes = (opt->rate_hz > 0) + opt->fast + opt->lockstep;
  if (modes > 1) Usage("choose one of --rate, --fast and --lockstep");
  if (opt->window < 1) Usage("--window must be >= 1");
  if (!opt->stereo.empty() &&
      (opt->sources.size() != 1 || !plot::IsReconstructionPath(opt->sources[0]))) {
    Usage("--stereo goes with one reconstruction (a BAL file or a COLMAP model's directory)");
  }
  if (const core::Status ok = CheckChannelPrefix(opt->connection.channel_prefix); !ok.ok()) {
    Usage(ok.message());
  }
  if (is_log) {
    if (opt->sources.size() != 1) Usage("an LCM log is replayed alone: give one SOURCE");
    if (!opt->robots.empty()) Usage("--robot names dataset robots; an LCM log carries its own");
    if (!opt->inter_robot.empty()) Usage("--inter-robot goes with datasets, not an LCM log");
  } else {
    if (!opt->channels_regex.empty()) Usage("--channels selects channels of an LCM log");
    if (opt->speed_given) Usage("--speed scales LCM log time; use --rate for datasets");
    if (!opt->robots.empty() && opt->robots.size() != opt->sources.size()) {
      Usage("--robot given " + std::to_string(opt->robots.size()) + " times for " +
            std::to_string(opt->sources.size()) + " datasets: name every dataset or none");
    }
  }
  if (opt->lockstep) {
    opt->pacing = Pacing::kLockstep;
  } else if (opt->fast) {
    opt->pacing = Pacing::kFast;
  } else if (opt->rate_hz > 0) {
    opt->pacing = Pacing::kRate;
  } else {
    opt->pacing = is_log ? Pacing::kSpeed : Pacing::kFast;
  }
}

std::vector<ReplayItem> DatasetItems(const ReplayOptions& opt, std::set<std::string>* robots) {
  std::vector<RobotDataset> datasets;
  for (size_t i = 0; i < opt.sources.size(); ++i) {
    const std::string name = opt.robots.empty() ? RobotNameFromPath(opt.sources[i]) : opt.robots[i];
    if (!IsValidRobotName(name))
      Usage("robot name '" + name + "': needs 1..64 chars of [A-Za-z0-9_.-]");
    if (!robots->insert(name).second) {
      Usage("two datasets are both robot '" + name + "': name them with --robot");
    }
    if (plot::IsReconstructionPath(opt.sources[i])) {  // BAL or COLMAP: camera by camera
      core::Result<core::Reconstruction> r = core::ReadReconstruction(opt.sources[i]);
      if (!r.ok()) Failure(r.status().ToString());
      ReconstructionMessageOptions options{
          .robot = name, .anchor_sigma = opt.anchor_sigma > 0 ? opt.anchor_sigma : 1e-3};
      if (!opt.stereo.empty()) {
        core::Result<sim::StereoFile> stereo = sim::ReadStereoFile(opt.stereo);
        if (!stereo.ok()) Failure(stereo.status().message());
        options.baseline = stereo->baseline;
        for (const sim::StereoObservation& s : stereo->stereo) {
          options.stereo.push_back({s.observation, s.uuv});
        }
      }
      core::Result<std::vector<StepMessages>> steps = MakeReconstructionMessages(*r, options);
      if (!steps.ok()) Failure(opt.sources[i] + ": " + steps.status().message());
      datasets.push_back(RobotDataset{name, std::move(steps).value()});
      continue;
    }
    core::ReadOptions read;
    read.isam_noise = opt.isam_noise == "covariance"
                          ? core::ReadOptions::IsamNoise::kCovariance
                          : core::ReadOptions::IsamNoise::kSqrtInformation;
    core::Result<core::Dataset> dataset = core::ReadDataset(opt.sources[i], read);
    if (!dataset.ok()) Failure(dataset.status().ToString());
    core::Result<std::vector<StepMessages>> steps = MakeDatasetMessages(
        *dataset, DatasetMessageOptions{.robot = name,
                                        .anchor_sigma = opt.anchor_sigma,
                                        .shared_landmarks = opt.shared_landmarks});
    if (!steps.ok()) Failure(opt.sources[i] + ": " + steps.status().message());
    datasets.push_back(RobotDataset{name, std::move(steps).value()});
  }
  std::vector<InterRobotClosure> closures;
  if (!opt.inter_robot.empty()) {
    core::Result<std::vector<InterRobotClosure>> read = ReadInterRobotFile(opt.inter_robot);
    if (!read.ok()) Failure(read.status().message());
    closures = std::move(read).value();
  }
  core::Result<std::vector<ReplayItem>> items =
      InterleaveRobots(datasets, closures, server::ChannelNames{opt.connection.channel_prefix});
  if (!items.ok()) Failure(items.status().message());
  return std::move(items).value();
}

std::vector<ReplayItem> LogItems(const ReplayOptions& opt, std::set<std::string>* robots) {
  core::Result<std::vector<ReplayItem>> items = ReadLcmLog(
      opt.sources[0], server::ChannelNames{opt.connection.channel_prefix}, opt.channels_regex);
  if (!items.ok()) {
    if (items.status().code() == core::StatusCode::kInvalidArgument)
      Usage(items.status().message());
    Failure(items.status().message());
  }
  for (const ReplayItem& item : *items) {
    if (!item.robot.empty()) robots->insert(item.robot);
  }
  return std::move(items).value();
}

}  // namespace
}  // namespace replay

void RegisterReplay(CLI::App& app) {
  using replay::ReplayOptions;
  auto opt = std::make_shared<ReplayOptions>();
  CLI::App* cmd = app.add_subcommand(
      "replay",
      "Stream datasets (one robot each) or an LCM event log into a running slamd, paced, and "
      "report what it made of them (sent, rejected, final chi2, latency)");
  cmd->add_option("source", opt->sources,
                  "Datasets (g2o 2D/3D, TORO .graph, iSAM .txt), reconstructions (a BAL file or a "
                  "COLMAP text model's directory: camera by camera, as camera_info_t, odometry_t "
                  "and frame_observations_t), or one LCM event log (detected by its magic "
                  "number)")
      ->required()
      ->check(CLI::ExistingPath);
  cmd->add_option("--robot", opt->robots,
                  "Robot name of each dataset, in order (repeat; default: the file stems)");
  cmd->add_option("--inter-robot", opt->inter_robot,
                  "Inter-robot loop closures: lines 'INTER_SE2 robotA idxA robotB idxB dx dy dθ "
                  "+6 info' or 'INTER_SE3 ... x y z qx qy qz qw +21 info'; each is sent once both "
                  "poses were")
      ->check(CLI::ExistingFile);
  cmd->add_option("--stereo", opt->stereo,
                  "Reconstruction: its stereo measurements (stereo.txt of `slamctl sim --stereo`), "
                  "sent as stereo features of a stereo camera")
      ->check(CLI::ExistingFile);
  cmd->add_option("--channels", opt->channels_regex,
                  "LCM log: also re-publish events whose channel fully matches this regex "
                  "(slamd's inbound channels always are)");
  cmd->add_option("--rate", opt->rate_hz, "Poses per second (datasets and logs)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--speed", opt->speed, "LCM log: scale the log's time by this factor")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_flag("--fast", opt->fast,
                "As fast as the server accepts without loss: at most --window poses per robot "
                "ahead of the server's estimate (the default for datasets)");
  cmd->add_flag("--lockstep", opt->lockstep,
                "Wait for the estimate of each pose before sending the next one");
  cmd->add_option("--window", opt->window, "--fast: poses per robot sent ahead of the estimate")
      ->capture_default_str();
  cmd->add_option("--ack-timeout", opt->ack_timeout_s,
                  "--lockstep / --fast: longest wait for an estimate [s] before giving up")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--settle-timeout", opt->settle_timeout_s,
                  "After the last message, longest wait for the server to settle [s]")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--wait-server", opt->wait_server_s,
                  "Before sending, wait this long for a first status_t [s] (its counters are the "
                  "baseline)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--resend-for", opt->resend_for_s,
                  "A message the server refuses because its queue is full (queue_full) is sent "
                  "again, after 20 ms, then twice as long each time up to 1 s, while it is "
                  "refused, for at most this long [s]; nothing new is sent meanwhile. 0: never")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--anchor-sigma", opt->anchor_sigma,
                  "Sigma of the prior anchoring each dataset's first pose [m, rad]; 0: no prior")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--isam-noise", opt->isam_noise,
                  "How iSAM-format noise columns are read: sqrt-information or covariance")
      ->check(CLI::IsMember({"sqrt-information", "covariance"}))
      ->capture_default_str();
  cmd->add_flag("--shared-landmarks", opt->shared_landmarks,
                "Datasets: their landmark ids name the landmarks of one map all robots share "
                "(as `slamctl sim --robots N` numbers them), sent in the map namespace; default: "
                "each robot's own");
  cmd->add_flag("--json", opt->json, "Print the summary as one JSON object on stdout");
  cmd->add_flag("-q,--quiet", opt->quiet, "No progress output");
  AddConnectionOptions(cmd, &opt->connection);
  cmd->callback([opt, cmd] {
    opt->speed_given = cmd->count("--speed") > 0;
    const bool is_log = IsLcmLog(opt->sources.front());
    for (size_t i = 1; i < opt->sources.size(); ++i) {
      if (IsLcmLog(opt->sources[i]) != is_log) {
        replay::Usage("mix of LCM logs and datasets: replay one log, or datasets only");
      }
    }
    replay::CheckOptions(opt.get(), is_log);
    std::set<std::string> robots;
    const std::vector<ReplayItem> items =
        is_log ? replay::LogItems(*opt, &robots) : replay::DatasetItems(*opt, &robots);
    const int code = replay::Run(*opt, items, robots);
    if (code != kExitOk) throw CommandExit{code};
  });
}

}  // namespace slamd::clients
