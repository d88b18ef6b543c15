// slamctl replay: the sending loop, the wait for the server to settle, and the summary.
//
// 1. Subscribe to ESTIMATE, REJECT and STATUS; wait up to --wait-server for a first status_t
//    (its messages_received is the baseline: the server may have had traffic before).
// 2. Send the items in order. Before an item that gives the server a new pose, pace:
//    --lockstep waits until every pose sent so far is acknowledged by an estimate_t;
//    --fast waits until fewer than --window poses of that robot are unacknowledged (UDP loses
//    what a busy server cannot read in time, so the client must not run ahead unboundedly);
//    --rate waits for the pose's time slot; logs (--speed) wait for the scaled log time.
//    Incoming messages are handled while waiting, and drained between sends. A message the
//    server refuses as queue_full goes again after a back-off (replay_resend.h), in any wait.
// 3. Wait until nothing refused waits to go again (and 50 ms more for late rejects), then until
//    a status_t shows everything received, nothing queued, every pose acknowledged and the
//    estimate settled (or --settle-timeout); print the summary.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include "clients/slamctl/replay.h"
#include "clients/slamctl/replay_resend.h"
#include "clients/slamctl/replay_tracker.h"
#include "slamd/estimate_t.hpp"

namespace slamd::clients::replay {
namespace {

constexpr const char* kReplayRunCommand = "replay";

double Now() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

// Progress on stderr: a bar redrawn in place on a terminal, a plain line every few seconds
// otherwise.
class Progress {
 public:
  Progress(bool enabled, std::size_t total)
      : enabled_(enabled), tty_(StderrIsTty()), total_(total) {}

  void Update(std::size_t sent, const ReplayTracker& tracker, double elapsed_s,
              bool force = false) {
    if (!enabled_) return;
    const double period = tty_ ? 0.1 : 2.0;
    if (!force && elapsed_s - last_s_ < period) return;
    last_s_ = elapsed_s;
    const double fraction =
        total_ == 0 ? 1.0 : static_cast<double>(sent) / static_cast<double>(total_);
    const long long rejected = tracker.rejected();
    if (tty_) {
      constexpr int kWidth = 30;
      const int filled = static_cast<int>(fraction * kWidth);
      std::string bar(static_cast<size_t>(filled), '#');
      bar.resize(kWidth, ' ');
      std::fprintf(stderr, "\r[%s] %3.0f%% %zu/%zu msgs  %lld rejected  %.1f s ", bar.c_str(),
                   fraction * 100.0, sent, total_, rejected, elapsed_s);
      drawn_ = true;
    } else {
      std::fprintf(stderr,
                   "slamctl replay: %zu/%zu messages sent (%.0f%%), %lld rejected, %.1f s\n", sent,
                   total_, fraction * 100.0, rejected, elapsed_s);
    }
    std::fflush(stderr);
  }
  void Finish() {
    if (enabled_ && tty_ && drawn_) std::fputc('\n', stderr);
  }

 private:
  bool enabled_;
  bool tty_;
  std::size_t total_;
  double last_s_ = -1e9;
  bool drawn_ = false;
};

void PrintSummary(const ReplayOptions& opt, const ReplayTracker& tracker,
                  const ReplayResender& resender, double wall_s, bool settled, bool answered) {
  const LatencySummary lat = tracker.Latency();
  const double chi2 = tracker.last_status() ? tracker.last_status()->chi2 : NAN;
  if (opt.json) {
    JsonWriter reasons;
    for (const auto& [name, count] : tracker.rejected_by_reason()) {
      reasons.Add(name, static_cast<long long>(count));
    }
    JsonWriter latency;
    latency.Add("p50", lat.p50_ms)
        .Add("p90", lat.p90_ms)
        .Add("p99", lat.p99_ms)
        .Add("max", lat.max_ms);
    // A field of the latest status_t; -1 when none came.
    auto FromStatus = [&](auto slamd::status_t::*field) {
      return tracker.last_status() ? static_cast<long long>(*tracker.last_status().*field) : -1LL;
    };
    JsonWriter j;
    j.Add("sent", static_cast<long long>(tracker.sent()))
        .Add("resent", static_cast<long long>(resender.resent()))
        .Add("rejected", static_cast<long long>(tracker.rejected()))
        .Add("rejected_by_reason", reasons)
        .Add("already_held", static_cast<long long>(tracker.already_held()))
        .Add("final_chi2", chi2)
        .Add("wall_s", wall_s)
        .Add("latency_ms", latency)
        .Add("settled", settled)
        .Add("answered", answered)
        .Add("poses_acknowledged", lat.count)
        .Add("server_received", FromStatus(&slamd::status_t::messages_received))
        .Add("update_sequence", FromStatus(&slamd::status_t::update_sequence))
        // Camera landmarks the server holds undetermined, and has dropped (its totals).
        .Add("landmark_tracks", FromStatus(&slamd::status_t::landmark_tracks))
        .Add("track_observations", FromStatus(&slamd::status_t::track_observations))
        .Add("landmarks_dropped", FromStatus(&slamd::status_t::landmarks_dropped));
    std::printf("%s\n", j.str().c_str());
    std::fflush(stdout);
    return;
  }
  std::printf("sent        %lld messages in %.3f s (%lld of them again after queue_full)\n",
              static_cast<long long>(tracker.sent()), wall_s,
              static_cast<long long>(resender.resent()));
  std::printf("rejected    %lld\n", static_cast<long long>(tracker.rejected()));
  for (const auto& [name, count] : tracker.rejected_by_reason()) {
    std::printf("  %-28s %lld\n", name.c_str(), static_cast<long long>(count));
  }
  for (const std::string& d : tracker.reject_details()) std::printf("  e.g. %s\n", d.c_str());
  std::printf("held        %lld already (re-sent measurements the server had)\n",
              static_cast<long long>(tracker.already_held()));
  if (tracker.last_status()) {
    const slamd::status_t& s = *tracker.last_status();
    std::printf("final chi2  %.6f  (residual dimension %lld, %lld variables, %lld factors)\n",
                s.chi2, static_cast<long long>(s.residual_dimension),
                static_cast<long long>(s.num_variables), static_cast<long long>(s.num_factors));
  } else {
    std::printf("final chi2  (no status_t from the server)\n");
  }
  if (tracker.last_status() && (tracker.last_status()->landmark_tracks > 0 ||
                                tracker.last_status()->landmarks_dropped > 0)) {
    const slamd::status_t& s = *tracker.last_status();
    std::printf("landmarks   %d waiting to be determined (%d observations), %lld dropped\n",
                s.landmark_tracks, s.track_observations,
                static_cast<long long>(s.landmarks_dropped));
  }
  std::printf("settled     %s\n", settled ? "yes" : "no (settle timeout)");
  std::printf(
      "latency     send -> estimate_t over %zu poses: p50 %.2f ms  p90 %.2f ms  p99 %.2f ms  "
      "max %.2f ms\n",
      lat.count, lat.p50_ms, lat.p90_ms, lat.p99_ms, lat.max_ms);
  std::fflush(stdout);
}

}  // namespace

int Run(const ReplayOptions& opt, const std::vector<ReplayItem>& items,
        const std::set<std::string>& robots) {
  server::ChannelNames channels;
  std::unique_ptr<LcmClient> client = ConnectOrFail(kReplayRunCommand, opt.connection, &channels);
  ReplayTracker tracker(robots);
  const ResendParams resend{.give_up_after_s = opt.resend_for_s};
  ReplayResender resender(resend);
  auto check = [&](const core::Status& s) {
    if (!s.ok()) CommandFail(kReplayRunCommand, kExitFailure, s.ToString());
  };
  check(client->Subscribe<slamd::estimate_t>(channels.Estimate(), [&](const slamd::estimate_t& e) {
    tracker.OnEstimate(e.robot, e.pose_index, Now());
  }));
  check(client->Subscribe<slamd::reject_t>(channels.Reject(), [&](const slamd::reject_t& r) {
    if (!resender.OnReject(r, Now())) tracker.OnReject(r);
  }));
  check(client->Subscribe<slamd::status_t>(channels.Status(),
                                           [&](const slamd::status_t& s) { tracker.OnStatus(s); }));
  double last_send_s = Now();
  auto send = [&](std::size_t i) {
    last_send_s = Now();
    check(client->PublishBytes(items[i].channel, items[i].bytes));
    resender.OnSent(i, items[i], last_send_s);
  };
  // What was refused and is due again goes first, in every wait.
  auto send_due = [&] {
    for (std::size_t i : resender.TakeDue(Now())) {
      send(i);
      tracker.OnResent();
    }
  };
  auto handle_until = [&](const std::function<bool()>& done, double timeout_s) {
    core::Result<bool> r = client->HandleUntil(
        [&] {
          send_due();
          return done();
        },
        timeout_s);
    if (!r.ok()) CommandFail(kReplayRunCommand, kExitFailure, r.status().ToString());
    return *r;
  };

  // 1. Baseline.
  if (opt.wait_server_s > 0 &&
      handle_until([&] { return tracker.status_count() > 0; }, opt.wait_server_s)) {
    tracker.SetBaseline(*tracker.last_status());
  } else if (!opt.quiet) {
    std::fprintf(stderr,
                 "slamctl replay: no status_t on %s within %.1f s (is slamd running on %s?); "
                 "sending anyway\n",
                 channels.Status().c_str(), opt.wait_server_s, client->url().c_str());
  }

  // 2. Send.
  Progress progress(!opt.quiet, items.size());
  const double t0 = Now();
  const std::int64_t log_t0 = items.empty() ? 0 : items.front().log_utime;
  std::size_t poses_sent = 0;
  double slip_s = 0;  // time the schedule (--rate, --speed) slipped by waiting for re-sends
  const double longest_resend_s = resend.give_up_after_s + resend.max_delay_s + 1.0;
  for (std::size_t i = 0; i < items.size(); ++i) {
    const ReplayItem& item = items[i];
    const bool pose = item.new_pose >= 0;
    // While a refused message waits to go again the server is saturated: nothing new goes out
    // until it went (flow control: a --rate above what the server takes is then its rate), and
    // the schedule slips by the wait rather than catching up in a burst.
    if (!resender.idle()) {
      const double paused = Now();
      handle_until([&] { return resender.idle(); }, longest_resend_s);
      slip_s += Now() - paused;
    }
    if (pose && opt.pacing == Pacing::kLockstep &&
        !handle_until([&] { return tracker.AllAcked(); }, opt.ack_timeout_s)) {
      CommandFail(kReplayRunCommand, kExitFailure,
                  "--lockstep: no estimate_t acknowledged the previous pose within " +
                      std::to_string(opt.ack_timeout_s) + " s (before " + item.robot + ":x" +
                      std::to_string(item.new_pose) + "; " + std::to_string(tracker.rejected()) +
                      " rejected so far)");
    }
    if (pose && opt.pacing == Pacing::kFast &&
        !handle_until([&] { return tracker.Unacked(item.robot) < static_cast<size_t>(opt.window); },
                      opt.ack_timeout_s)) {
      CommandFail(kReplayRunCommand, kExitFailure,
                  "--fast: the server acknowledged no pose of robot '" + item.robot + "' within " +
                      std::to_string(opt.ack_timeout_s) + " s (" +
                      std::to_string(tracker.Unacked(item.robot)) + " waiting; newest estimate x" +
                      std::to_string(tracker.Acked(item.robot)) +
                      "); a message was probably lost: UDP drops what a busy server cannot read "
                      "in time. Lower --window, or give slamd a larger socket buffer "
                      "(&recv_buf_size=4194304 in its --lcm-url)");
    }
    double target = -1;
    if (pose && opt.pacing == Pacing::kRate)
      target = t0 + slip_s + static_cast<double>(poses_sent) / opt.rate_hz;
    if (opt.pacing == Pacing::kSpeed)
      target = t0 + slip_s + static_cast<double>(item.log_utime - log_t0) * 1e-6 / opt.speed;
    // Until the send time itself: incoming messages are handled meanwhile, but do not decide
    // when it ends (a later deadline made the wait end only with the next message to arrive,
    // so poses went out in bursts).
    if (target > 0 && Now() < target) handle_until([&] { return Now() >= target; }, target - Now());
    send(i);
    tracker.OnSent(item, Now());
    if (pose) ++poses_sent;
    if (!client->Drain().ok()) CommandFail(kReplayRunCommand, kExitFailure, "LCM handle failed");
    progress.Update(i + 1, tracker, Now() - t0);
  }
  progress.Update(items.size(), tracker, Now() - t0, true);
  progress.Finish();

  // 3. The refused messages sent again, then settle.
  handle_until([&] { return resender.idle() && Now() >= last_send_s + 0.05; }, longest_resend_s);
  const std::int64_t statuses_before = tracker.status_count();
  const bool settled =
      handle_until([&] { return tracker.Settled() && resender.idle(); }, opt.settle_timeout_s);
  handle_until([] { return false; }, 0.05);  // late reject_t
  const double wall_s = Now() - t0;
  const bool answered = settled || tracker.status_count() > statuses_before;
  if (!settled && !opt.quiet) {
    if (!answered) {
      std::fprintf(stderr, "slamctl replay: no status_t from the server after the last message\n");
    } else if (!tracker.ReceivedAll()) {
      std::fprintf(stderr, "slamctl replay: the server received %lld of %lld messages\n",
                   static_cast<long long>(tracker.last_status()->messages_received),
                   static_cast<long long>(tracker.sent()));
    } else {
      std::fprintf(stderr, "slamctl replay: not settled within %.1f s\n", opt.settle_timeout_s);
    }
  }
  PrintSummary(opt, tracker, resender, wall_s, settled, answered);
  const bool ok = tracker.rejected() == 0 && answered && tracker.ReceivedAll();
  return ok ? kExitOk : kExitFailure;
}

}  // namespace slamd::clients::replay
