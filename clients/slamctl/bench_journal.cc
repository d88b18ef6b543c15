#include "clients/slamctl/bench_journal.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "clients/slamctl/client_common.h"
#include "clients/slamctl/commands.h"
#include "clients/slamctl/dataset_messages.h"
#include "core/io/dataset.h"
#include "server/daemon/daemon.h"
#include "server/estimator/recovery.h"
#include "server/journal/journal.h"
#include "server/journal/read_journal.h"
#include "server/journal/snapshot_file.h"
#include "server/snapshot/estimator_state.h"
#include "server/snapshot/state_codec.h"
#include "server/transport/in_process_bus.h"

namespace slamd::clients {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
constexpr const char* kJournalBenchCommand = "journal bench";

struct JournalBenchOptions {
  std::string dataset;
  std::string dir;
  int tail = 200;             // steps after the hand-made snapshot
  int max_sync_steps = 1000;  // steps appended under `always` (one fdatasync each)
  bool keep = false;
};

struct WireMessage {
  std::string channel, type;
  std::vector<std::uint8_t> bytes;
};
using Step = std::vector<WireMessage>;

double Since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

void Check(const core::Status& s) {
  if (!s.ok()) CommandFail(kJournalBenchCommand, kExitFailure, s.ToString());
}
template <typename T>
T Take(core::Result<T> r) {
  Check(r.status());
  return std::move(r).value();
}

const char* TypeName(const RobotMessage& m) {
  return std::visit([](const auto& msg) { return server::SpecOfLcm<decltype(msg)>::kType; }, m);
}

// 1. One boundary + Commit per step, as the daemon journals a lock-step client.
void BenchAppend(const std::vector<Step>& steps, const std::string& dir, server::SyncPolicy policy,
                 int max_steps) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  auto journal = Take(
      server::Journal::Open(dir, {.writer = {.sync_policy = policy, .interval_ms = 50}}, {}, 0));
  const int n = std::min<int>(max_steps, static_cast<int>(steps.size()));
  std::int64_t messages = 0;
  const auto t0 = Clock::now();
  for (int k = 0; k < n; ++k) {
    std::int64_t last = 0;
    for (const WireMessage& m : steps[k]) {
      last = Take(journal->AppendMessage(m.channel, m.type, m.bytes, server::WallMicros()));
      ++messages;
    }
    Check(journal->AppendBoundary(k + 1, last, static_cast<int>(steps[k].size())));
    Check(journal->Commit());
  }
  const double s = Since(t0);
  std::printf(
      "append  sync=%-8s %6d updates %7lld messages %9lld bytes  %8.2f us/message  "
      "%8.2f us/update\n",
      server::SyncPolicyName(policy), n, static_cast<long long>(messages),
      static_cast<long long>(journal->offset()), 1e6 * s / messages, 1e6 * s / n);
  fs::remove_all(dir);
}

struct Timed {
  double seconds;
  server::RecoveryResult result;
};

Timed TimeRecover(const std::string& dir, const server::ServerParams& p) {
  const auto t0 = Clock::now();
  server::RecoveryResult r = Take(server::Recover(dir, p.estimator, p.isam2, false));
  return {Since(t0), std::move(r)};
}

// Writes a snapshot of the daemon's estimator at the journal's current end, as the daemon's
// snapshot thread would; prints and returns its timing.
std::string Snapshot(const server::Daemon& d, const std::string& journal_path,
                     const std::string& dir, const char* label) {
  const server::JournalContents j = Take(server::ReadJournal(journal_path));
  std::int64_t last = 0;
  for (const journal::JournalRecord& r : j.records) {
    if (r.has_message()) last = r.message().sequence();
  }
  const auto t0 = Clock::now();
  const server::EstimatorState state = d.estimator_for_tests().ExportState();
  const double export_s = Since(t0);
  const auto t1 = Clock::now();
  const std::string bytes = server::EncodeState(
      state, {.last_message_sequence = last, .journal_offset = j.valid_end_offset});
  const double encode_s = Since(t1);
  const auto t2 = Clock::now();
  const std::string path = Take(server::WriteSnapshotFile(dir, j.valid_end_offset, bytes));
  const double write_s = Since(t2);
  std::printf(
      "snapshot %-6s %zu factors %zu variables: %lld bytes; export %.3f s, encode %.3f s, "
      "write+fsync %.3f s, total %.3f s\n",
      label, state.factors.size(), state.linearization_point.size(),
      static_cast<long long>(bytes.size()), export_s, encode_s, write_s,
      export_s + encode_s + write_s);
  return path;
}

void RunBench(const JournalBenchOptions& opt) {
  core::Dataset data = Take(core::ReadDataset(opt.dataset));
  const std::vector<StepMessages> groups = Take(MakeDatasetMessages(data, {.robot = "bench"}));
  const server::ChannelNames channels;
  std::vector<Step> steps;
  std::int64_t total = 0;
  for (const StepMessages& g : groups) {
    Step step;
    for (const RobotMessage& m : g.messages) {
      WireMessage w{ChannelOf(m, channels), TypeName(m), {}};
      Check(EncodeMessage(m, &w.bytes));
      step.push_back(std::move(w));
    }
    total += static_cast<std::int64_t>(step.size());
    steps.push_back(std::move(step));
  }
  const bool temp = opt.dir.empty();
  const std::string root =
      temp ? (fs::temp_directory_path() / ("slamctl_bench_journal_" + std::to_string(::getpid())))
                 .string()
           : opt.dir;
  fs::create_directories(root);
  std::printf("dataset %s: %zu steps, %lld messages\n", opt.dataset.c_str(), steps.size(),
              static_cast<long long>(total));

  // 1. Append overhead per policy.
  BenchAppend(steps, root + "/append", server::SyncPolicy::kNever, 1 << 30);
  BenchAppend(steps, root + "/append", server::SyncPolicy::kInterval, 1 << 30);
  BenchAppend(steps, root + "/append", server::SyncPolicy::kAlways, opt.max_sync_steps);

  // 2. The session.
  server::ServerParams p;
  p.data_dir = root + "/session";
  p.refine.enabled = false;
  p.publish.status_rate_hz = 0.0;
  p.publish.estimate_covariance = false;
  p.journal.sync = server::SyncPolicy::kNever;
  p.journal.snapshot_every_updates = 0;
  p.journal.snapshot_every_s = 0.0;
  p.log_level = "warn";
  fs::remove_all(p.data_dir);
  fs::create_directories(p.data_dir);
  // The session's journal is one segment (far below journal.segment_bytes).
  const std::string journal_path = server::JournalSegmentPath(p.data_dir, 0);
  const int snapshot_at = std::max<int>(0, static_cast<int>(steps.size()) - opt.tail);
  {
    server::InProcessBus bus;
    auto d = Take(server::Daemon::Create(p, &bus));
    const auto t0 = Clock::now();
    for (int k = 0; k < static_cast<int>(steps.size()); ++k) {
      if (k == snapshot_at) Snapshot(*d, journal_path, p.data_dir, "(tail)");
      for (const WireMessage& m : steps[k]) Check(bus.Publish(m.channel, m.bytes));
      Take(d->PumpIntake(0));
      d->StepEstimator(0.0);
    }
    std::printf("session: %zu updates in %.2f s (live, refinement off)\n", steps.size(), Since(t0));
    fs::create_directories(root + "/final");
    Snapshot(*d, journal_path, root + "/final", "(full)");
    d->Stop();
  }

  // 3. Recovery against journal length (prefixes cut after a boundary, no snapshot).
  const server::JournalContents j = Take(server::ReadJournal(journal_path));
  std::vector<std::int64_t> lengths;
  for (std::int64_t n : {1000, 2000, 5000, 10000, 20000, 50000}) {
    if (n < total) lengths.push_back(n);
  }
  lengths.push_back(total);
  std::int64_t messages = 0;
  size_t next = 0;
  for (size_t i = 0; i < j.records.size() && next < lengths.size(); ++i) {
    if (j.records[i].has_message()) ++messages;
    if (!j.records[i].has_boundary() || messages < lengths[next]) continue;
    const std::int64_t end = i + 1 < j.offsets.size() ? j.offsets[i + 1] : j.valid_end_offset;
    const std::string dir = root + "/prefix";
    fs::remove_all(dir);
    fs::create_directories(dir);
    {
      std::ifstream in(journal_path, std::ios::binary);
      std::string bytes(static_cast<size_t>(end), '\0');
      in.read(bytes.data(), end);
      std::ofstream(server::JournalSegmentPath(dir, 0), std::ios::binary) << bytes;
    }
    const Timed t = TimeRecover(dir, p);
    std::printf("recover journal only: %7lld messages %6lld updates %9lld bytes: %.3f s\n",
                static_cast<long long>(t.result.replayed_messages),
                static_cast<long long>(t.result.replayed_updates), static_cast<long long>(end),
                t.seconds);
    while (next < lengths.size() && lengths[next] <= messages) ++next;
  }
  const Timed t = TimeRecover(p.data_dir, p);
  std::printf(
      "recover snapshot + tail: snapshot at message %lld, then %lld messages in %lld "
      "updates: %.3f s\n",
      static_cast<long long>(t.result.snapshot_sequence),
      static_cast<long long>(t.result.replayed_messages),
      static_cast<long long>(t.result.replayed_updates), t.seconds);
  if (temp && !opt.keep) fs::remove_all(root);
}

}  // namespace

void RegisterJournalBench(CLI::App* journal) {
  auto opt = std::make_shared<JournalBenchOptions>();
  CLI::App* cmd = journal->add_subcommand(
      "bench", "Journal append cost per sync policy, snapshot time and size, recovery time");
  cmd->add_option("DATASET", opt->dataset, "dataset file (g2o, TORO, iSAM)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--dir", opt->dir, "work directory (default: a temporary one)");
  cmd->add_option("--tail", opt->tail, "steps after the snapshot of the snapshot+tail recovery")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--max-sync-steps", opt->max_sync_steps,
                  "steps appended under sync=always (one fdatasync each)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_flag("--keep", opt->keep, "keep the temporary directory");
  cmd->callback([opt] { RunBench(*opt); });
}

}  // namespace slamd::clients
