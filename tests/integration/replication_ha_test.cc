// The replicated journal with the real `slamd` and a real three-server NATS JetStream cluster,
// inside this test's own network namespace (scripts/netns-run; ctest labels ha and netns).
//
// A robot streams manhattan in lock-step (it re-sends a step until slamd publishes the step's
// pose: what a robot does with unacknowledged messages). A follower of the stream killed and
// restarted changes nothing (two of three are a quorum: no hold); its leader killed holds intake
// while the others elect a new one. Two killed: the stream cannot
// acknowledge, so slamd holds intake (REASON_REPLICATION_UNAVAILABLE, status_t.replication_held)
// and publishes no estimate of what the stream lacks; once they are back the robot's re-sends go
// through and the stream has everything. At the end the stream holds exactly the local journal's
// records, in order, and a data directory rebuilt from the stream alone recovers to the same
// estimator as slamd's own (every factor once, estimates within 1e-9).
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "core/io/dataset_stream.h"
#include "server/journal/journal_segments.h"
#include "server/journal/journal_writer.h"
#include "server/journal/read_journal.h"
#include "server/replication/stream_reader.h"
#include "slamd_proto/journal.pb.h"
#include "tests/testing/datasets.h"
#include "tests/testing/estimator_compare.h"
#include "tests/testing/nats_cluster.h"
#include "tests/testing/processes.h"
#include "tests/testing/slamd_processes.h"
#include "tests/testing/wire_steps.h"

namespace slamd::server {
namespace {

using testing::Client;
using testing::NatsCluster;
using testing::Server;
using testing::StepMessages;

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=2097152";
constexpr const char* kRobot = "manhattan";
constexpr int kSteps = 400;

constexpr const char* kConfig =
    "refine { enabled: true budget_s: 0.002 }\n"
    "isam2 { refine_threshold: 1e-10 }\n"
    "publish { status_rate_hz: 20 estimate_covariance: false }\n"
    "journal { sync: ALWAYS }\n"
    "queue { block_timeout_s: 0.05 }\n"
    "log_level: \"info\"\n";

TEST(ReplicationHaTest, ReplicatedJournalRidesOutNatsFailuresAndLosesNothing) {
  ASSERT_TRUE(testing::OnlyLoopback()) << testing::kNotInNetns;
  if (!testing::HaveNatsServer()) GTEST_SKIP() << "nats-server is not installed";
  testing::WireDataset data;
  testing::LoadWireDataset("manhattan.g2o", kSteps, kRobot, &data);
  if (::testing::Test::IsSkipped()) return;
  const std::vector<core::DatasetStep>& steps = data.steps;
  const std::vector<StepMessages>& messages = data.messages;
  const int expected_factors = data.factors;

  testing::TempDir tmp("ha_journal");
  NatsCluster nats(tmp.str() + "/nats", 3);
  ASSERT_NO_FATAL_FAILURE(nats.StartAll());
  ASSERT_TRUE(nats.WaitForJetStream(30.0));
  const std::string config = tmp.str() + "/slamd.textproto";
  // keep_snapshots: 0: the stream keeps the whole history, from which a data directory is
  // rebuilt at the end (with snapshots in NATS it would start where the oldest one is followed).
  std::ofstream(config) << kConfig << "replication { keep_snapshots: 0 servers: \"" << nats.Urls()
                        << "\" ack_timeout_ms: 1000 }\n";
  Server s{.prefix = "R_", .data_dir = tmp.str() + "/data", .log = tmp.str() + "/slamd.log"};
  std::filesystem::create_directories(s.data_dir);
  Client client(kUrl, kRobot);
  client.Attach(&s);
  const testing::KillOnExit cleanup({&s});
  ASSERT_NO_FATAL_FAILURE(testing::Start(config, client, &s));

  auto stream_steps = [&](int from, int to) {
    for (int k = from; k < to; ++k) {
      ASSERT_GT(testing::SendUntilEstimated(client, &s, messages[k], core::KeyIndex(steps[k].pose),
                                            30.0, 1.0),
                0)
          << "step " << k << " never acknowledged (log " << s.log << ")";
    }
  };
  ASSERT_NO_FATAL_FAILURE(stream_steps(0, 100));
  // A follower of the stream down: the other two are a quorum. Nothing waits unless slamd's own
  // connection was to that server: then its client reconnects to another and re-sends, which on
  // a loaded machine can outlast ack_timeout_ms once (one hold, over by the next commit).
  const int leader = nats.StreamLeader("SLAMD");
  ASSERT_GE(leader, 0);
  const int follower = (leader + 1) % 3;
  nats.Kill(follower);
  ASSERT_NO_FATAL_FAILURE(stream_steps(100, 150));
  ASSERT_NO_FATAL_FAILURE(nats.Start(follower));
  const std::int64_t t_follower = testing::WallUs();
  ASSERT_TRUE(client.PumpUntil([&] { return s.status_utime > t_follower; }, 10.0));
  EXPECT_LE(s.status.replication_holds, 1) << "a follower down held intake";
  EXPECT_FALSE(s.status.replication_held) << "intake still held with a quorum up";
  const std::int64_t holds_before_leader = s.status.replication_holds;
  ASSERT_TRUE(nats.WaitForReplicasCurrent("SLAMD", 30.0))
      << "the restarted follower never caught up";
  // The stream's leader down: intake waits while the other two elect one (counted as a hold);
  // the robot's re-sends go through after it.
  nats.Kill(leader);
  ASSERT_NO_FATAL_FAILURE(stream_steps(150, 200));
  ASSERT_NO_FATAL_FAILURE(nats.Start(leader));
  ASSERT_NO_FATAL_FAILURE(stream_steps(200, 250));

  // The quorum lost: intake held, no estimate of step 250 while it lasts.
  nats.Kill(1);
  nats.Kill(2);
  client.Send(s, messages[250]);
  const std::uint64_t pose250 = core::KeyIndex(steps[250].pose);
  EXPECT_TRUE(client.PumpUntil([&] { return s.status.replication_held != 0; }, 10.0));
  client.Send(s, messages[250]);  // re-sent while held: refused as such
  EXPECT_TRUE(client.PumpUntil(
      [&] { return s.rejects[slamd::reject_t::REASON_REPLICATION_UNAVAILABLE] > 0; }, 10.0));
  client.Drain(500);
  EXPECT_EQ(s.estimated.count(pose250), 0u) << "an estimate went out that the stream lacks";
  ASSERT_NO_FATAL_FAILURE(nats.Start(1));
  ASSERT_NO_FATAL_FAILURE(nats.Start(2));
  ASSERT_NO_FATAL_FAILURE(stream_steps(250, kSteps));

  ASSERT_TRUE(client.Barrier(&s));
  const std::int64_t t_end = testing::WallUs();
  ASSERT_TRUE(client.PumpUntil(
      [&] {
        return s.status_utime > t_end && !s.status.replication_held &&
               s.status.replication_pending_bytes == 0;
      },
      20.0));
  EXPECT_GT(s.status.replication_holds, holds_before_leader);  // the quorum loss held intake
  EXPECT_EQ(s.status.messages_rejected, s.rejects[slamd::reject_t::REASON_REPLICATION_UNAVAILABLE] +
                                            s.rejects[slamd::reject_t::REASON_DUPLICATE])
      << "rejections other than the hold's";
  ASSERT_NO_FATAL_FAILURE(testing::Kill(&s, SIGTERM));

  // The stream is the local journal, record for record.
  const StreamJournalOptions stream_options{.nats = {.servers = nats.UrlList()},
                                            .source = "reader"};
  const std::vector<journal::JournalRecord> streamed = testing::ReadWholeStream(stream_options);
  const core::Result<JournalContents> local = ReadJournal(s.data_dir);
  ASSERT_TRUE(local.ok()) << local.status().ToString();
  ASSERT_EQ(streamed.size(), local.value().records.size());
  for (size_t i = 0; i < streamed.size(); ++i) {
    ASSERT_EQ(streamed[i].SerializeAsString(), local.value().records[i].SerializeAsString())
        << "record " << i;
  }
  // A data directory made from the stream alone recovers to slamd's state.
  const std::string rebuilt = tmp.str() + "/from_stream";
  std::filesystem::create_directories(rebuilt);
  {
    auto writer = JournalWriter::Open(JournalSegmentPath(rebuilt, 0), {}).value();
    for (const journal::JournalRecord& r : streamed) ASSERT_TRUE(writer->Append(r).ok());
    ASSERT_TRUE(writer->Close().ok());
  }
  const ServerParams params = testing::ConfigParams(config);
  const testing::Recovered own = testing::RecoverAndConverge(s.data_dir, params);
  const testing::Recovered from_stream = testing::RecoverAndConverge(rebuilt, params);
  testing::ExpectSameEstimators(own, from_stream, expected_factors, 1e-9);
}

}  // namespace
}  // namespace slamd::server
