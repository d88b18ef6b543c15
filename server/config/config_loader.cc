#include "server/config/config_loader.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/io/tokenizer.h>
#include <google/protobuf/text_format.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "slamd_proto/config.pb.h"

namespace slamd::server {
namespace {

namespace pb = google::protobuf;

// Keeps the first parse error with its position (protobuf reports 0-based lines and columns).
class FirstError : public pb::io::ErrorCollector {
 public:
  void AddError(int line, pb::io::ColumnNumber column, const std::string& message) override {
    if (message_.empty()) {
      message_ = std::to_string(line + 1) + ":" + std::to_string(column + 1) + ": " + message;
    }
  }
  const std::string& message() const { return message_; }

 private:
  std::string message_;
};

// "line:col: " of the field at dotted `path` ("queue.depth") in the parsed text, or "" when the
// text did not set it (then its value came from the defaults).
std::string LocationOf(const std::string& path, const pb::TextFormat::ParseInfoTree* tree) {
  const pb::Descriptor* message = proto::ServerConfig::descriptor();
  std::stringstream parts(path);
  std::string part;
  std::vector<std::string> names;
  while (std::getline(parts, part, '.')) names.push_back(part);
  for (size_t i = 0; i < names.size() && tree != nullptr && message != nullptr; ++i) {
    const pb::FieldDescriptor* field = message->FindFieldByName(names[i]);
    if (field == nullptr) return "";
    if (i + 1 == names.size()) {
      const pb::TextFormat::ParseLocation loc = tree->GetLocation(field, -1);
      if (loc.line < 0) return "";
      return std::to_string(loc.line + 1) + ":" + std::to_string(loc.column + 1) + ": ";
    }
    tree = tree->GetTreeForNested(field, -1);
    message = field->message_type();
  }
  return "";
}

// Copies every set field of `config` over the defaults in *p.
void Apply(const proto::ServerConfig& config, ServerParams* p) {
  if (config.has_lcm_url()) p->lcm_url = config.lcm_url();
  if (config.has_channel_prefix()) p->channel_prefix = config.channel_prefix();
  if (config.has_data_dir()) p->data_dir = config.data_dir();
  if (config.has_log_level()) p->log_level = config.log_level();
  if (config.has_log_file()) p->log_file = config.log_file();
  const proto::QueueConfig& q = config.queue();
  if (q.has_depth()) p->queue.depth = q.depth();
  if (q.has_block_timeout_s()) p->queue.block_timeout_s = q.block_timeout_s();
  if (q.has_coalesce_s()) p->queue.coalesce_s = q.coalesce_s();
  if (q.has_max_per_update()) p->queue.max_per_update = q.max_per_update();
  const proto::PublishConfig& pub = config.publish();
  if (pub.has_status_rate_hz()) p->publish.status_rate_hz = pub.status_rate_hz();
  if (pub.has_map_rate_hz()) p->publish.map_rate_hz = pub.map_rate_hz();
  if (pub.has_map_covariance()) p->publish.map_covariance = pub.map_covariance();
  if (pub.has_estimate_covariance()) p->publish.estimate_covariance = pub.estimate_covariance();
  if (pub.has_query_budget_s()) p->publish.query_budget_s = pub.query_budget_s();
  if (pub.has_latency_window()) p->publish.latency_window = pub.latency_window();
  const proto::RefineConfig& r = config.refine();
  if (r.has_enabled()) p->refine.enabled = r.enabled();
  if (r.has_budget_s()) p->refine.budget_s = r.budget_s();
  if (r.has_idle_s()) p->refine.idle_s = r.idle_s();
  const proto::Isam2Config& i = config.isam2();
  const proto::Isam2Config::Relinearization& rl = i.relinearization();
  if (rl.has_rotation_threshold())
    p->isam2.relinearization.rotation_threshold = rl.rotation_threshold();
  if (rl.has_translation_threshold())
    p->isam2.relinearization.translation_threshold = rl.translation_threshold();
  if (rl.has_skip()) p->isam2.relinearization.skip = rl.skip();
  if (rl.has_max_variables()) p->isam2.relinearization.max_variables = rl.max_variables();
  if (rl.has_error_threshold()) {
    p->isam2.relinearization.error_threshold = rl.error_threshold();
  }
  if (rl.has_calibration_threshold()) {
    p->isam2.relinearization.calibration_threshold = rl.calibration_threshold();
  }
  if (rl.has_other_threshold()) p->isam2.relinearization.other_threshold = rl.other_threshold();
  for (const proto::Isam2Config::Relinearization::TypeThreshold& t : rl.per_type()) {
    using Kind = proto::Isam2Config::Relinearization::TypeThreshold;
    const core::EntryKind kind = t.kind() == Kind::TRANSLATION   ? core::EntryKind::kTranslation
                                 : t.kind() == Kind::ROTATION    ? core::EntryKind::kRotation
                                 : t.kind() == Kind::CALIBRATION ? core::EntryKind::kCalibration
                                                                 : core::EntryKind::kOther;
    core::Isam2Params::Relinearization::TypeThreshold threshold{.type = t.type(), .kind = kind};
    if (t.has_threshold()) threshold.threshold = t.threshold();
    p->isam2.relinearization.per_type.push_back(threshold);
  }
  if (i.has_wildfire_threshold()) p->isam2.wildfire_threshold = i.wildfire_threshold();
  if (i.has_refine_threshold()) p->isam2.refine_threshold = i.refine_threshold();
  if (i.has_refine_max_variables()) p->isam2.refine_max_variables = i.refine_max_variables();
  if (i.has_batch_every()) p->isam2.batch_every = i.batch_every();
  if (i.has_threads()) p->isam2.threads = i.threads();
  if (i.has_trust_region()) p->isam2.trust_region.enabled = i.trust_region();
  if (i.has_max_landmarks_last()) p->isam2.max_landmarks_last = i.max_landmarks_last();
  const proto::JournalConfig& j = config.journal();
  if (j.has_sync()) {
    p->journal.sync = j.sync() == proto::JournalConfig::ALWAYS     ? SyncPolicy::kAlways
                      : j.sync() == proto::JournalConfig::INTERVAL ? SyncPolicy::kInterval
                                                                   : SyncPolicy::kNever;
  }
  if (j.has_sync_interval_ms()) p->journal.sync_interval_ms = j.sync_interval_ms();
  if (j.has_snapshot_every_updates()) {
    p->journal.snapshot_every_updates = j.snapshot_every_updates();
  }
  if (j.has_snapshot_every_s()) p->journal.snapshot_every_s = j.snapshot_every_s();
  if (j.has_snapshot_every_bytes()) p->journal.snapshot_every_bytes = j.snapshot_every_bytes();
  if (j.has_keep_snapshots()) p->journal.keep_snapshots = j.keep_snapshots();
  if (j.has_segment_bytes()) p->journal.segment_bytes = j.segment_bytes();
  if (j.has_delete_covered_segments()) {
    p->journal.delete_covered_segments = j.delete_covered_segments();
  }
  const proto::ReplicationConfig& rep = config.replication();
  if (rep.has_servers()) p->replication.servers = rep.servers();
  if (rep.has_stream()) p->replication.stream = rep.stream();
  if (rep.has_subject()) p->replication.subject = rep.subject();
  if (rep.has_replicas()) p->replication.replicas = rep.replicas();
  if (rep.has_ack_timeout_ms()) p->replication.ack_timeout_ms = rep.ack_timeout_ms();
  if (rep.has_lease_ttl_ms()) p->replication.lease_ttl_ms = rep.lease_ttl_ms();
  if (rep.has_lease_bucket()) p->replication.lease_bucket = rep.lease_bucket();
  if (rep.has_standby_keep_s()) p->replication.standby_keep_s = rep.standby_keep_s();
  if (rep.has_keep_snapshots()) p->replication.keep_snapshots = rep.keep_snapshots();
  const proto::ShardsConfig& sh = config.shards();
  if (sh.has_self()) p->estimator.shards.self = sh.self();
  for (const proto::ShardsConfig::Shard& shard : sh.shard()) {
    p->estimator.shards.shards.push_back(
        {.name = shard.name(), .robots = {shard.robots().begin(), shard.robots().end()}});
  }
  if (sh.has_servers()) p->shards.servers = sh.servers();
  if (sh.has_subject()) p->shards.subject = sh.subject();
  if (sh.has_summary_every_ms()) p->shards.summary_every_ms = sh.summary_every_ms();
  if (sh.has_forward_queries()) p->shards.forward_queries = sh.forward_queries();
  const proto::EstimatorConfig& e = config.estimator();
  if (e.has_new_robot_anchor()) {
    p->estimator.new_robot_anchor = static_cast<AnchorPolicy>(e.new_robot_anchor());
  }
  if (e.has_anchor_sigma()) p->estimator.anchor_sigma = e.anchor_sigma();
  if (e.has_max_held_messages()) p->estimator.max_held_messages = e.max_held_messages();
  if (e.has_max_hold_updates()) p->estimator.max_hold_updates = e.max_hold_updates();
  if (e.has_chi2_interval_s()) p->estimator.chi2_interval_s = e.chi2_interval_s();
  if (e.has_loop_closure_kernel()) p->estimator.loop_closure_kernel = e.loop_closure_kernel();
  if (e.has_loop_closure_kernel_parameter()) {
    p->estimator.loop_closure_kernel_parameter = e.loop_closure_kernel_parameter();
  }
  if (e.has_background_relinearization_above()) {
    p->estimator.background_relinearization_above = e.background_relinearization_above();
  }
  if (e.has_rebuild_catch_up_rounds()) {
    p->estimator.rebuild_catch_up_rounds = e.rebuild_catch_up_rounds();
  }
  if (e.has_landmark_min_views()) p->estimator.landmark_min_views = e.landmark_min_views();
  if (e.has_landmark_min_parallax_deg()) {
    p->estimator.landmark_min_parallax_deg = e.landmark_min_parallax_deg();
  }
  if (e.has_landmark_min_disparity_px()) {
    p->estimator.landmark_min_disparity_px = e.landmark_min_disparity_px();
  }
  if (e.has_landmark_max_reprojection_px()) {
    p->estimator.landmark_max_reprojection_px = e.landmark_max_reprojection_px();
  }
  if (e.has_landmark_max_wait_updates()) {
    p->estimator.landmark_max_wait_updates = e.landmark_max_wait_updates();
  }
  if (e.has_max_track_observations()) {
    p->estimator.max_track_observations = e.max_track_observations();
  }
  if (e.has_max_landmark_error_px()) p->estimator.max_landmark_error_px = e.max_landmark_error_px();
  if (e.has_window()) {
    const auto& w = e.window();
    if (w.has_keep_poses()) p->estimator.window.keep_poses = w.keep_poses();
    if (w.has_keyframe_spacing_m()) p->estimator.window.keyframe_spacing_m = w.keyframe_spacing_m();
    if (w.has_every_updates()) p->estimator.window.every_updates = w.every_updates();
    if (w.has_sparse_summaries()) p->estimator.window.sparse_summaries = w.sparse_summaries();
    if (w.has_summary_parents()) p->estimator.window.summary_parents = w.summary_parents();
    if (w.has_keep_aliases()) p->estimator.window.keep_aliases = w.keep_aliases();
  }
  const auto read_reduced = [](const auto& in, EstimatorParams::ReducedGraph* out) {
    if (in.has_distance_m()) out->distance_m = in.distance_m();
    if (in.has_angle_deg()) out->angle_deg = in.angle_deg();
    if (in.has_keep_aliases()) out->keep_aliases = in.keep_aliases();
    if (in.has_link_mapped_landmarks()) out->link_mapped_landmarks = in.link_mapped_landmarks();
  };
  if (e.has_reduced()) read_reduced(e.reduced(), &p->estimator.reduced);
  for (const auto& r : e.robot_reduced()) {
    EstimatorParams::RobotReduced robot{.robot = r.robot(), .reduced = p->estimator.reduced};
    read_reduced(r.reduced(), &robot.reduced);
    p->estimator.robot_reduced.push_back(std::move(robot));
  }
  for (const auto& r : e.robot_window()) {
    EstimatorParams::RobotWindow robot{.robot = r.robot(), .window = p->estimator.window};
    if (r.has_keep_poses()) robot.window.keep_poses = r.keep_poses();
    if (r.has_keyframe_spacing_m()) robot.window.keyframe_spacing_m = r.keyframe_spacing_m();
    p->estimator.robot_windows.push_back(std::move(robot));
  }
}

std::string Quote(const std::string& s) { return "\"" + s + "\""; }

std::string Num(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

}  // namespace

core::Result<ServerParams> ParseConfigText(const std::string& text, const std::string& source) {
  proto::ServerConfig config;
  FirstError errors;
  pb::TextFormat::ParseInfoTree tree;
  pb::TextFormat::Parser parser;
  parser.RecordErrorsTo(&errors);
  parser.WriteLocationsTo(&tree);
  if (!parser.ParseFromString(text, &config)) {
    return core::InvalidArgument(source + ":" + errors.message());
  }
  ServerParams params;
  Apply(config, &params);
  const core::Status valid = params.Validate();
  if (!valid.ok()) {
    const std::string& m = valid.message();
    const std::string location = LocationOf(m.substr(0, m.find_first_of(" ")), &tree);
    return core::InvalidArgument(source + ":" + location + m);
  }
  return params;
}

core::Result<ServerParams> LoadConfigFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return core::NotFound("cannot open config file " + path);
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return core::IoError("cannot read config file " + path);
  return ParseConfigText(text.str(), path);
}

std::string DefaultConfigText() {
  const ServerParams d;
  const core::Isam2Params::Relinearization& rl = d.isam2.relinearization;
  std::ostringstream out;
  out << "# slamd configuration (protobuf text format, schema msgs/proto/config.proto).\n"
      << "# Every value below is the default; delete a line to keep the default.\n"
      << "# Flags override: --lcm-url, --data-dir, --channel-prefix, --log-level.\n\n"
      << "lcm_url: " << Quote(d.lcm_url) << "  # LCM URL; \"memq://\" = in-process\n"
      << "channel_prefix: " << Quote(d.channel_prefix) << "  # 1..40 chars of [A-Za-z0-9_]\n"
      << "data_dir: " << Quote(d.data_dir) << "  # journal and snapshots; \"\" = memory only\n"
      << "log_level: " << Quote(d.log_level) << "  # trace debug info warn error critical off\n"
      << "log_file: " << Quote(d.log_file) << "  # \"\" = console only\n\n"
      << "queue {\n"
      << "  depth: " << d.queue.depth << "  # ingest queue bound [messages], 1..1e7\n"
      << "  block_timeout_s: " << Num(d.queue.block_timeout_s)
      << "  # a full queue blocks intake this long, then rejects [s], 0..10\n"
      << "  coalesce_s: " << Num(d.queue.coalesce_s)
      << "  # a camera robot's messages this close make one update [s], 0..0.01\n"
      << "  max_per_update: " << d.queue.max_per_update
      << "  # queued messages one update takes at most, 1..1e7\n"
      << "}\n\n"
      << "publish {\n"
      << "  status_rate_hz: " << Num(d.publish.status_rate_hz) << "  # status_t [Hz], 0 = never\n"
      << "  map_rate_hz: " << Num(d.publish.map_rate_hz)
      << "  # periodic map_t of every robot [Hz], 0 = on request only\n"
      << "  map_covariance: " << (d.publish.map_covariance ? "true" : "false")
      << "  # periodic maps carry marginal covariances\n"
      << "  estimate_covariance: " << (d.publish.estimate_covariance ? "true" : "false")
      << "  # estimate_t carries the newest pose's covariance\n"
      << "  query_budget_s: " << Num(d.publish.query_budget_s)
      << "  # time for a query's marginals, then STATUS_PARTIAL [s], (0, 10]\n"
      << "  latency_window: " << d.publish.latency_window
      << "  # status_t latency percentiles over the last N samples, 16..1048576\n"
      << "}\n\n"
      << "refine {\n"
      << "  enabled: " << (d.refine.enabled ? "true" : "false")
      << "  # Isam2::Refine while no message is queued\n"
      << "  budget_s: " << Num(d.refine.budget_s) << "  # per call [s], (0, 10]\n"
      << "  idle_s: " << Num(d.refine.idle_s)
      << "  # after this long without a message, or in a stream's gaps it fits [s], 0..10\n"
      << "}\n\n"
      << "isam2 {\n"
      << "  relinearization {\n"
      << "    rotation_threshold: " << Num(rl.rotation_threshold) << "  # [rad], > 0\n"
      << "    translation_threshold: " << Num(rl.translation_threshold) << "  # [m], > 0\n"
      << "    skip: " << rl.skip << "  # updates between relinearisation checks, >= 1\n"
      << "    max_variables: " << rl.max_variables << "  # per update, 0 = no limit\n"
      << "    error_threshold: " << Num(rl.error_threshold)
      << "  # or a factor's linearisation error exceeds this [sigmas], 0 = off, >= 0\n"
      << "    calibration_threshold: " << Num(rl.calibration_threshold)
      << "  # calibration entries [px; none for distortion], > 0\n"
      << "    other_threshold: " << Num(rl.other_threshold) << "  # any other entry, > 0\n"
      << "    # per_type { type: \"Point3\" kind: TRANSLATION threshold: 0.01 }  # one kind of "
         "entry "
         "of one\n"
      << "    # variable type at its own threshold (kind: TRANSLATION ROTATION CALIBRATION OTHER)\n"
      << "  }\n"
      << "  wildfire_threshold: " << Num(d.isam2.wildfire_threshold)
      << "  # partial back-substitution\n"
      << "  refine_threshold: " << Num(d.isam2.refine_threshold)
      << "  # Refine converged below this |delta|\n"
      << "  refine_max_variables: " << d.isam2.refine_max_variables
      << "  # relinearised per Refine round (a bound on its time), 0 = no limit\n"
      << "  batch_every: " << d.isam2.batch_every
      << "  # periodic full relinearisation, 0 = never\n"
      << "  threads: " << d.isam2.threads
      << "  # for the large steps (relinearising, eliminating subtrees), >= 1\n"
      << "  trust_region: " << (d.isam2.trust_region.enabled ? "true" : "false")
      << "  # dog-leg steps: no divergence on weakly seen landmarks, O(map) per update\n"
      << "  max_landmarks_last: " << d.isam2.max_landmarks_last
      << "  # an update's landmarks ordered at the root up to this many (a frame's hundreds not)\n"
      << "}\n\n"
      << "estimator {\n"
      << "  new_robot_anchor: "
      << (d.estimator.new_robot_anchor == AnchorPolicy::kAnchorAtOrigin ? "ANCHOR_AT_ORIGIN"
                                                                        : "HOLD_UNTIL_CONNECTED")
      << "  # or ANCHOR_AT_ORIGIN / HOLD_UNTIL_CONNECTED\n"
      << "  anchor_sigma: " << Num(d.estimator.anchor_sigma)
      << "  # origin anchor prior std. dev. [m, rad]\n"
      << "  max_held_messages: " << d.estimator.max_held_messages
      << "  # waiting for a pose (out of order, unanchored)\n"
      << "  max_hold_updates: " << d.estimator.max_hold_updates
      << "  # updates a held message may wait, >= 1\n"
      << "  chi2_interval_s: " << Num(d.estimator.chi2_interval_s)
      << "  # status chi2 at most this often while updating, and when settled [s]\n"
      << "  loop_closure_kernel: " << Quote(d.estimator.loop_closure_kernel)
      << "  # default for loop closures naming none: none huber cauchy gemanmcclure dcs\n"
      << "  loop_closure_kernel_parameter: " << Num(d.estimator.loop_closure_kernel_parameter)
      << "  # its parameter, > 0\n"
      << "  background_relinearization_above: " << d.estimator.background_relinearization_above
      << "  # larger relinearisations rebuild the solver on a helper thread, 0 = never\n"
      << "  rebuild_catch_up_rounds: " << d.estimator.rebuild_catch_up_rounds
      << "  # at most this many catch-up rounds on its thread, 0..64\n"
      << "  landmark_min_views: " << d.estimator.landmark_min_views
      << "  # camera landmarks enter once this many views (>= 2) ...\n"
      << "  landmark_min_parallax_deg: " << Num(d.estimator.landmark_min_parallax_deg)
      << "  # ... see them with this parallax [deg]\n"
      << "  landmark_min_disparity_px: " << Num(d.estimator.landmark_min_disparity_px)
      << "  # or one stereo view with this disparity [px]\n"
      << "  landmark_max_reprojection_px: " << Num(d.estimator.landmark_max_reprojection_px)
      << "  # and they reproject within this RMS [px]\n"
      << "  landmark_max_wait_updates: " << d.estimator.landmark_max_wait_updates
      << "  # updates an undetermined landmark waits before it is dropped, >= 1\n"
      << "  max_track_observations: " << d.estimator.max_track_observations
      << "  # observations of undetermined landmarks held in all\n"
      << "  max_landmark_error_px: " << Num(d.estimator.max_landmark_error_px)
      << "  # a feature this far from its landmark's projection is rejected [px]\n"
      << "  window {  # lifelong: old poses removed by node removal, keyframes kept\n"
      << "    keep_poses: " << d.estimator.window.keep_poses
      << "  # poses kept behind each robot's newest; 0 = off (keep everything)\n"
      << "    keyframe_spacing_m: " << Num(d.estimator.window.keyframe_spacing_m)
      << "  # old poses kept one per place this size [m]; 0 = none\n"
      << "    every_updates: " << d.estimator.window.every_updates << "  # how often, >= 1\n"
      << "    sparse_summaries: " << (d.estimator.window.sparse_summaries ? "true" : "false")
      << "  # Chow-Liu trees; false: exact dense summaries, which grow with the area\n"
      << "    summary_parents: " << d.estimator.window.summary_parents
      << "  # sparse: a variable conditioned on 1 (a tree) or 2 others (closer, denser)\n"
      << "    keep_aliases: " << d.estimator.window.keep_aliases
      << "  # removed poses this far behind held for closures naming them; 0 = none\n"
      << "  }\n"
      << "  # robot_window { robot: \"car\" keep_poses: 500 keyframe_spacing_m: 2 }  # one "
         "robot's\n"
      << "  reduced {  # reduced pose graph: revisiting a mapped area adds no nodes\n"
      << "    distance_m: " << Num(d.estimator.reduced.distance_m)
      << "  # a new pose this close to a pose node [m] is not added as a node; 0 = off\n"
      << "    angle_deg: " << Num(d.estimator.reduced.angle_deg)
      << "  # ... and turned this little [deg]\n"
      << "    keep_aliases: " << d.estimator.reduced.keep_aliases
      << "  # each robot's newest such poses that later messages may name\n"
      << "    link_mapped_landmarks: "
      << (d.estimator.reduced.link_mapped_landmarks ? "true" : "false")
      << "  # false: revisits add no factors to mapped landmarks\n"
      << "  }\n"
      << "  # robot_reduced { robot: \"car\" reduced { distance_m: 2 } }  # one robot's\n"
      << "}\n\n"
      << "journal {\n"
      << "  sync: "
      << (d.journal.sync == SyncPolicy::kAlways     ? "ALWAYS"
          : d.journal.sync == SyncPolicy::kInterval ? "INTERVAL"
                                                    : "NEVER")
      << "  # ALWAYS (per update) / INTERVAL / NEVER\n"
      << "  sync_interval_ms: " << d.journal.sync_interval_ms << "  # for INTERVAL [ms]\n"
      << "  snapshot_every_updates: " << d.journal.snapshot_every_updates
      << "  # 0 = not by count\n"
      << "  snapshot_every_s: " << Num(d.journal.snapshot_every_s) << "  # [s], 0 = not by time\n"
      << "  snapshot_every_bytes: " << d.journal.snapshot_every_bytes
      << "  # journal bytes since the last [bytes], 0 = not by size\n"
      << "  keep_snapshots: " << d.journal.keep_snapshots << "  # >= 1\n"
      << "  segment_bytes: " << d.journal.segment_bytes
      << "  # a new journal segment after this many [bytes]\n"
      << "  delete_covered_segments: " << (d.journal.delete_covered_segments ? "true" : "false")
      << "  # delete segments the oldest kept snapshot covers\n"
      << "}\n\n"
      << "replication {  # a copy of the journal in a NATS JetStream stream (needs data_dir)\n"
      << "  servers: " << Quote(d.replication.servers)
      << "  # \"nats://host:4222,...\"; \"\" = off\n"
      << "  stream: " << Quote(d.replication.stream) << "\n"
      << "  subject: " << Quote(d.replication.subject) << "\n"
      << "  replicas: " << d.replication.replicas << "  # copies of each record, 1..5\n"
      << "  ack_timeout_ms: " << d.replication.ack_timeout_ms
      << "  # unacknowledged this long: intake held [ms]\n"
      << "  lease_ttl_ms: " << d.replication.lease_ttl_ms
      << "  # > 0: a replicated pair, the lease holder leads, the other is a standby [ms]\n"
      << "  lease_bucket: " << Quote(d.replication.lease_bucket) << "\n"
      << "  standby_keep_s: " << Num(d.replication.standby_keep_s)
      << "  # a standby journals what it heard this long before it took over [s]\n"
      << "  keep_snapshots: " << d.replication.keep_snapshots
      << "  # in the stream, which is truncated before the oldest; 0 = never truncated\n"
      << "}\n\n"
      << "shards {  # map shards: this slamd owns some robots, neighbours exchange summaries\n"
      << "  self: \"\"  # this slamd's shard; \"\" = not sharded\n"
      << "  # shard { name: \"east\" robots: \"robot0\" robots: \"robot1\" }  # every shard, "
         "this one too\n"
      << "  servers: " << Quote(d.shards.servers) << "  # NATS URLs; \"\" = the LCM bus\n"
      << "  subject: " << Quote(d.shards.subject) << "  # summaries for shard s on <subject>.<s>\n"
      << "  summary_every_ms: " << d.shards.summary_every_ms
      << "  # each neighbour's summary at most this often [ms]\n"
      << "  forward_queries: " << (d.shards.forward_queries ? "true" : "false")
      << "  # shards on different LCM buses: queries for another shard's robot go to it\n"
      << "}\n";
  return out.str();
}

}  // namespace slamd::server
