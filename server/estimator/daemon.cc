#include "server/estimator/daemon.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>

#include "server/ingest/conversion.h"
#include "server/publish/wire_values.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/estimate_t.hpp"
#include "slamd/landmark_observation_t.hpp"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/reject_t.hpp"
#include "slamd/remove_factor_t.hpp"
#include "slamd/status_t.hpp"

namespace slamd::server {
namespace {

constexpr size_t kLatencyWindow = 1024;

const std::string& RobotOf(const slamd::odometry_t& m) { return m.robot; }
const std::string& RobotOf(const slamd::landmark_observation_t& m) { return m.robot; }
const std::string& RobotOf(const slamd::loop_closure_t& m) { return m.robot_a; }
const std::string& RobotOf(const slamd::prior_t& m) { return m.robot; }

}  // namespace

std::string Daemon::InboundChannel(const Inbound& in) const {
  switch (in.measurement.index()) {
    case 0:
      return channels_.Odometry();
    case 1:
      return channels_.Landmark();
    case 2:
      return channels_.LoopClosure();
    default:
      return channels_.Prior();
  }
}

namespace {

std::int64_t Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return static_cast<std::int64_t>(v[k]);
}

}  // namespace

std::int64_t SteadyMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

std::int64_t WallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

core::Result<std::unique_ptr<Daemon>> Daemon::Create(const ServerParams& params, Bus* bus) {
  SLAMD_RETURN_IF_ERROR(params.Validate());
  if (bus == nullptr) return core::InvalidArgument("Daemon::Create: null bus");
  core::Result<std::unique_ptr<Estimator>> estimator =
      Estimator::Create(params.estimator, params.isam2);
  if (!estimator.ok()) return estimator.status();
  std::unique_ptr<Daemon> daemon(new Daemon(params, bus, std::move(estimator).value()));
  SLAMD_RETURN_IF_ERROR(daemon->Subscribe());
  return daemon;
}

Daemon::Daemon(const ServerParams& params, Bus* bus, std::unique_ptr<Estimator> estimator)
    : params_(params),
      bus_(bus),
      channels_{params.channel_prefix},
      estimator_(std::move(estimator)),
      queue_(params.queue.depth),
      snapshot_(estimator_->snapshot()) {
  log_ = spdlog::get("slamd");
  if (!log_) log_ = spdlog::default_logger();
}

Daemon::~Daemon() { Stop(); }

template <typename Msg>
core::Status Daemon::SubscribeInbound(const std::string& channel) {
  core::Result<Subscription> sub = server::Subscribe<Msg>(
      *bus_, channel, [this](std::string_view ch, const Msg& msg) { OnInbound(ch, msg); },
      [this](std::string_view ch, const core::Status& error) { OnDecodeError(ch, error); });
  if (!sub.ok()) return sub.status();
  subscriptions_.push_back(std::move(sub).value());
  return core::Status::Ok();
}

core::Status Daemon::Subscribe() {
  SLAMD_RETURN_IF_ERROR(SubscribeInbound<slamd::odometry_t>(channels_.Odometry()));
  SLAMD_RETURN_IF_ERROR(SubscribeInbound<slamd::landmark_observation_t>(channels_.Landmark()));
  SLAMD_RETURN_IF_ERROR(SubscribeInbound<slamd::loop_closure_t>(channels_.LoopClosure()));
  SLAMD_RETURN_IF_ERROR(SubscribeInbound<slamd::prior_t>(channels_.Prior()));
  SLAMD_RETURN_IF_ERROR(SubscribeInbound<slamd::remove_factor_t>(channels_.RemoveFactor()));
  return core::Status::Ok();
}

template <typename Msg>
void Daemon::OnInbound(std::string_view channel, const Msg& msg) {
  ++received_;
  const char* type = Msg::getTypeName();
  if constexpr (std::is_same_v<Msg, slamd::remove_factor_t>) {
    PublishReject({RejectReason::kUnknownFactor, "remove_factor_t: not implemented yet"}, channel,
                  type, msg.robot_a, msg.utime);
  } else {
    auto checked = Convert(msg, Limits{});
    if (!checked.ok()) {
      PublishReject(checked.verdict(), channel, type, RobotOf(msg), msg.utime);
      return;
    }
    if (queue_.Push(Inbound{std::move(checked).value(), SteadyMicros()},
                    params_.queue.block_timeout_s)) {
      ++queued_;
      return;
    }
    PublishReject(
        {RejectReason::kQueueFull, std::string(type) + ": ingest queue full (queue.depth = " +
                                       std::to_string(params_.queue.depth) + ")"},
        channel, type, RobotOf(msg), msg.utime);
  }
}

void Daemon::OnDecodeError(std::string_view channel, const core::Status& error) {
  ++received_;
  ++decode_errors_;
  PublishReject({RejectReason::kDecodeError, error.message()}, channel, "", "", 0);
}

void Daemon::PublishReject(const Verdict& verdict, std::string_view channel, std::string_view type,
                           std::string_view robot, std::int64_t utime) {
  ++intake_rejected_;
  ++intake_rejects_by_reason_[static_cast<int>(verdict.reason)];
  slamd::reject_t out;
  FillReject(verdict, channel, type, robot, utime, WallMicros(), &out);
  log_->debug("reject {} from '{}': {}", type, robot, verdict.message);
  const core::Status s = server::Publish(*bus_, channels_.Reject(), out);
  if (!s.ok()) log_->warn("cannot publish reject_t: {}", s.ToString());
}

core::Result<int> Daemon::PumpIntake(int timeout_ms) { return bus_->HandleOnce(timeout_ms); }

int Daemon::StepEstimator(double timeout_s) {
  std::vector<Inbound> batch;
  const int n = queue_.PopAll(&batch, timeout_s);
  std::shared_ptr<const EstimateSnapshot> snap;
  if (n > 0) {
    const ProcessResult r = estimator_->Process(std::move(batch));
    if (r.updated) {
      const double us = r.update.seconds.total * 1e6;
      if (update_us_.size() < kLatencyWindow) {
        update_us_.push_back(us);
      } else {
        update_us_[update_us_next_++ % kLatencyWindow] = us;
      }
      log_->debug("update: {}", r.update.Brief());
      if (!r.status.ok()) log_->warn("solver update failed: {}", r.status.ToString());
    }
    for (const Rejection& rej : r.rejections) {
      // Stateful rejects are counted by the estimator; publish them through the same helper
      // but without double counting.
      slamd::reject_t out;
      FillReject(rej.verdict, InboundChannel(rej.message), MessageTypeName(rej.message),
                 MessageRobot(rej.message), MessageUtime(rej.message), WallMicros(), &out);
      log_->debug("reject {}: {}", MessageTypeName(rej.message), rej.verdict.message);
      const core::Status s = server::Publish(*bus_, channels_.Reject(), out);
      if (!s.ok()) log_->warn("cannot publish reject_t: {}", s.ToString());
    }
  } else if (params_.refine.enabled && !estimator_->snapshot()->settled) {
    const core::Isam2::RefineResult r = estimator_->Refine(params_.refine.budget_s);
    if (!r.status.ok()) log_->warn("refine failed: {}", r.status.ToString());
  }
  snap = estimator_->snapshot();
  {
    std::lock_guard lock(snapshot_mutex_);
    snapshot_ = snap;
  }
  PublishEstimates(*snap);
  MaybePublishStatus(*snap);
  return n;
}

void Daemon::PublishEstimates(const EstimateSnapshot& snap) {
  if (snap.update_sequence <= published_sequence_) return;
  const std::int64_t now_steady = SteadyMicros();
  const std::int64_t now = WallMicros();
  for (const RobotEstimate& r : snap.robots) {
    if (r.moved_sequence <= published_sequence_) continue;
    slamd::estimate_t out;
    out.utime = now;
    out.robot = r.name;
    out.update_sequence = snap.update_sequence;
    out.pose_index = static_cast<std::int64_t>(r.pose_index);
    if (const core::Pose2* p2 = std::get_if<core::Pose2>(&r.pose)) {
      out.dimension = slamd::estimate_t::DIMENSION_2D;
      out.values = ToValues(*p2);
    } else {
      out.dimension = slamd::estimate_t::DIMENSION_3D;
      out.values = ToValues(std::get<core::Pose3>(r.pose));
    }
    out.num_values = static_cast<std::int32_t>(out.values.size());
    out.num_covariance = 0;
    out.measurement_utime = r.measurement_utime;
    out.latency_us = r.received_us > 0 ? now_steady - r.received_us : 0;
    const core::Status s = server::Publish(*bus_, channels_.Estimate(), out);
    if (!s.ok()) log_->warn("cannot publish estimate_t: {}", s.ToString());
  }
  published_sequence_ = snap.update_sequence;
}

void Daemon::MaybePublishStatus(const EstimateSnapshot& snap) {
  if (params_.publish.status_rate_hz <= 0.0) return;
  const std::int64_t now = SteadyMicros();
  const auto period = static_cast<std::int64_t>(1e6 / params_.publish.status_rate_hz);
  if (last_status_us_ != 0 && now - last_status_us_ < period) return;
  last_status_us_ = now;
  PublishStatus(snap);
}

void Daemon::PublishStatus(const EstimateSnapshot& snap) {
  slamd::status_t out;
  out.utime = WallMicros();
  out.update_sequence = snap.update_sequence;
  out.num_robots = static_cast<std::int32_t>(snap.robots.size());
  out.num_variables = snap.num_variables;
  out.num_factors = snap.num_factors;
  out.messages_received = received_;
  out.messages_accepted = queued_;
  out.messages_rejected = intake_rejected_ + snap.counters.rejected;
  out.decode_errors = decode_errors_;
  out.num_rejects_by_reason = kNumRejectReasonCodes;
  out.rejects_by_reason.resize(kNumRejectReasonCodes);
  for (int i = 0; i < kNumRejectReasonCodes; ++i) {
    out.rejects_by_reason[i] = intake_rejects_by_reason_[i] + snap.counters.rejects_by_reason[i];
  }
  out.queue_depth = queue_.size();
  out.queue_capacity = queue_.capacity();
  out.update_latency_p50_us = Percentile(update_us_, 0.5);
  out.update_latency_p90_us = Percentile(update_us_, 0.9);
  out.update_latency_p99_us = Percentile(update_us_, 0.99);
  out.update_latency_max_us = Percentile(update_us_, 1.0);
  out.publish_latency_p50_us = 0;  // not measured yet
  out.publish_latency_p99_us = 0;
  out.journal_records = 0;  // no journal yet (issue 7)
  out.journal_bytes = 0;
  out.chi2 = snap.chi2;
  out.residual_dimension = snap.residual_dimension;
  out.settled = snap.settled;
  const core::Status s = server::Publish(*bus_, channels_.Status(), out);
  if (!s.ok()) log_->warn("cannot publish status_t: {}", s.ToString());
}

std::shared_ptr<const EstimateSnapshot> Daemon::snapshot() const {
  std::lock_guard lock(snapshot_mutex_);
  return snapshot_;
}

void Daemon::IntakeLoop() {
  while (!stop_intake_) {
    const core::Result<int> r = bus_->HandleOnce(50);
    if (!r.ok()) log_->error("transport: {}", r.status().ToString());
  }
}

void Daemon::EstimatorLoop() {
  // Waits at most 50 ms for messages so status keeps going when idle; not at all while a
  // refinement is still due, so the map converges between messages.
  while (!stop_estimator_) {
    const bool refine_due = params_.refine.enabled && !estimator_->snapshot()->settled;
    StepEstimator(refine_due ? 0.0 : 0.05);
  }
  // Intake has stopped and the queue is closed: finish what is queued.
  while (StepEstimator(0.0) > 0) {
  }
}

void Daemon::Start() {
  if (intake_thread_.joinable() || stopped_) return;
  estimator_thread_ = std::thread([this] { EstimatorLoop(); });
  intake_thread_ = std::thread([this] { IntakeLoop(); });
  log_->info("slamd running: prefix '{}', queue {}, refine {}", params_.channel_prefix,
             params_.queue.depth, params_.refine.enabled ? "on" : "off");
}

void Daemon::Stop() {
  if (stopped_) return;
  stopped_ = true;
  stop_intake_ = true;
  if (intake_thread_.joinable()) intake_thread_.join();
  subscriptions_.clear();
  queue_.Close();
  stop_estimator_ = true;
  if (estimator_thread_.joinable()) estimator_thread_.join();
  const std::shared_ptr<const EstimateSnapshot> snap = snapshot();
  PublishStatus(*snap);
  log_->info("slamd stopped after {} updates; {} messages received", snap->counters.updates,
             received_.load());
  log_->flush();
}

}  // namespace slamd::server
