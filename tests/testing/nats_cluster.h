// NatsCluster: real nats-server processes with JetStream for the replication tests (label ha),
// a cluster of n on loopback ports (client 14222 + i, routes 16222 + i), each with its store in
// a directory of the test's own. Only inside a private network namespace (OnlyLoopback()), so
// ports and traffic never meet anything else. Kill(i) (SIGKILL), Stop(i) (SIGTERM), Start(i)
// (again, on the same store). Tests skip when nats-server is not installed (HaveNatsServer).
// SharedNatsClusterTest: a fixture whose suite shares one cluster.
#pragma once

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <nats/nats.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "server/replication/nats_client.h"
#include "server/replication/stream_reader.h"
#include "slamd_proto/journal.pb.h"
#include "tests/testing/processes.h"

namespace slamd::testing {

inline bool HaveNatsServer() { return std::system("command -v nats-server >/dev/null 2>&1") == 0; }

// Every record of a replicated journal's stream from its beginning, in order (until none comes
// for 2 s). Opening the reader is retried for 30 s (a cluster that just lost or regained servers
// may take a while to place the consumer).
// *repeated_messages: the messages that held only bytes already read (batches sent again).
inline std::vector<journal::JournalRecord> ReadWholeStream(
    const server::StreamJournalOptions& options, std::int64_t* repeated_messages = nullptr) {
  std::vector<journal::JournalRecord> out;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  auto reader = server::StreamReader::Open(options, {.sequence = 1});
  while (!reader.ok() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    reader = server::StreamReader::Open(options, {.sequence = 1});
  }
  EXPECT_TRUE(reader.ok()) << reader.status().ToString();
  if (!reader.ok()) return out;
  journal::JournalRecord r;
  while (true) {
    core::Result<bool> got = reader.value()->Next(&r, 2000);
    EXPECT_TRUE(got.ok()) << got.status().ToString();
    if (!got.ok() || !got.value()) break;
    out.push_back(r);
  }
  EXPECT_EQ(reader.value()->buffered_bytes(), 0) << "the stream ends inside a record";
  if (repeated_messages) *repeated_messages = reader.value()->repeated_messages();
  return out;
}

class NatsCluster {
 public:
  static constexpr int kClientPort = 14222;
  static constexpr int kRoutePort = 16222;

  NatsCluster(const std::string& dir, int n) : dir_(dir), pids_(static_cast<size_t>(n), -1) {
    std::filesystem::create_directories(dir_);
    for (int i = 0; i < n; ++i) WriteConfig(i);
  }
  ~NatsCluster() {
    for (int i = 0; i < size(); ++i) Kill(i);
  }
  NatsCluster(const NatsCluster&) = delete;
  NatsCluster& operator=(const NatsCluster&) = delete;

  int size() const { return static_cast<int>(pids_.size()); }
  static std::string Url(int i) { return "nats://127.0.0.1:" + std::to_string(kClientPort + i); }
  // Every server's URL, comma-separated (replication.servers).
  std::string Urls() const {
    std::string all;
    for (int i = 0; i < size(); ++i) all += (i ? "," : "") + Url(i);
    return all;
  }
  // The same through another address of this machine (`host`).
  std::string UrlsVia(const std::string& host) const {
    std::string all;
    for (int i = 0; i < size(); ++i) {
      all += (i ? ",nats://" : "nats://") + host + ":" + std::to_string(kClientPort + i);
    }
    return all;
  }
  std::vector<std::string> UrlList() const {
    std::vector<std::string> all;
    for (int i = 0; i < size(); ++i) all.push_back(Url(i));
    return all;
  }

  // Starts server i and waits (up to 10 s) until its client port accepts connections.
  void Start(int i) {
    ASSERT_LT(pids_[i], 0) << "nats server " << i << " already running";
    pids_[i] = Spawn({"nats-server", "-c", ConfigPath(i)}, dir_ + "/n" + std::to_string(i) + ".log",
                     Streams::kStdoutAndStderr);
    ASSERT_GT(pids_[i], 0);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (!Accepts(kClientPort + i)) {
      int status = 0;
      if (waitpid(pids_[i], &status, WNOHANG) == pids_[i]) {
        pids_[i] = -1;
        FAIL() << "nats server " << i << " exited: " << Log(i);
      }
      ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "nats server " << i << " not up";
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  void StartAll() {
    for (int i = 0; i < size(); ++i) Start(i);
  }
  // Waits (up to timeout_s) until the cluster can place a stream on all its servers (its meta
  // leader elected and every peer known: answering JetStream requests comes earlier, and a
  // replicated stream or bucket made then fails with "no suitable peers for placement"): true
  // when it can. Tried with a probe stream, deleted again.
  bool WaitForJetStream(double timeout_s) const {
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::milliseconds(static_cast<int>(timeout_s * 1e3));
    while (std::chrono::steady_clock::now() < deadline) {
      auto client = server::NatsClient::Connect({.servers = UrlList()});
      if (client.ok()) {
        jsStreamConfig cfg;
        jsStreamConfig_Init(&cfg);
        const char* subjects[] = {"test.ready_probe"};
        cfg.Name = "READY_PROBE";
        cfg.Subjects = subjects;
        cfg.SubjectsLen = 1;
        cfg.Storage = js_MemoryStorage;
        cfg.Replicas = size();
        jsStreamInfo* si = nullptr;
        jsErrCode jerr = static_cast<jsErrCode>(0);
        jsCtx* js = client.value()->jetstream();
        if (js_AddStream(&si, js, &cfg, nullptr, &jerr) == NATS_OK) {
          jsStreamInfo_Destroy(si);
          return js_DeleteStream(js, "READY_PROBE", nullptr, &jerr) == NATS_OK;
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    return false;
  }
  // The index of the server leading `stream`'s RAFT group (-1 when none or unknown).
  int StreamLeader(const std::string& stream) const {
    auto client = server::NatsClient::Connect({.servers = UrlList()});
    if (!client.ok()) return -1;
    jsStreamInfo* si = nullptr;
    jsErrCode jerr = static_cast<jsErrCode>(0);
    if (js_GetStreamInfo(&si, client.value()->jetstream(), stream.c_str(), nullptr, &jerr) !=
        NATS_OK) {
      return -1;
    }
    int leader = -1;
    if (si->Cluster != nullptr && si->Cluster->Leader != nullptr) {
      const std::string name = si->Cluster->Leader;  // "n<i>"
      if (name.size() > 1 && name[0] == 'n') leader = std::atoi(name.c_str() + 1);
    }
    jsStreamInfo_Destroy(si);
    return leader;
  }
  // Waits until every other replica of `stream` is current with its leader (a replica restarted
  // a moment ago is still catching up: killing the leader then leaves no quorum that can elect
  // one, which is two failures, not one).
  bool WaitForReplicasCurrent(const std::string& stream, double timeout_s) const {
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::milliseconds(static_cast<int>(timeout_s * 1e3));
    while (std::chrono::steady_clock::now() < deadline) {
      auto client = server::NatsClient::Connect({.servers = UrlList()});
      jsStreamInfo* si = nullptr;
      jsErrCode jerr = static_cast<jsErrCode>(0);
      if (client.ok() && js_GetStreamInfo(&si, client.value()->jetstream(), stream.c_str(), nullptr,
                                          &jerr) == NATS_OK) {
        bool current = si->Cluster != nullptr && si->Cluster->ReplicasLen == size() - 1;
        for (int r = 0; current && r < si->Cluster->ReplicasLen; ++r) {
          const jsPeerInfo* peer = si->Cluster->Replicas[r];
          current = peer->Current && !peer->Offline && peer->Lag == 0;
        }
        jsStreamInfo_Destroy(si);
        if (current) return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return false;
  }
  void Kill(int i) { Signal(i, SIGKILL); }
  void Stop(int i) { Signal(i, SIGTERM); }
  bool running(int i) const { return pids_[i] > 0; }
  std::string Log(int i) const {
    std::ifstream in(dir_ + "/n" + std::to_string(i) + ".log");
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }

 private:
  std::string ConfigPath(int i) const { return dir_ + "/n" + std::to_string(i) + ".conf"; }
  void WriteConfig(int i) const {
    std::ofstream out(ConfigPath(i));
    // Every address of the test's namespace (a test may reach it through a second one).
    out << "server_name: n" << i << "\nlisten: 0.0.0.0:" << kClientPort + i
        << "\njetstream { store_dir: \"" << dir_ << "/store" << i << "\" }\n";
    if (size() == 1) return;
    out << "cluster {\n  name: slamd_test\n  listen: 127.0.0.1:" << kRoutePort + i
        << "\n  routes: [";
    for (int j = 0; j < size(); ++j) {
      if (j != i) out << "\n    nats-route://127.0.0.1:" << kRoutePort + j;
    }
    out << "\n  ]\n}\n";
  }
  void Signal(int i, int sig) {
    if (pids_[i] <= 0) return;
    kill(pids_[i], sig);
    WaitExit(pids_[i]);
    pids_[i] = -1;
  }
  static bool Accepts(int port) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    const bool ok = connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) == 0;
    close(fd);
    return ok;
  }

  std::string dir_;
  std::vector<pid_t> pids_;
};

// A fixture whose suite shares one cluster of three (starting one takes seconds): started once
// JetStream answers, stopped with the suite; each test is skipped outside a private network
// namespace or without nats-server, and finds every server running (a test that stopped some
// and failed half-way leaves them to be restarted). test_name() names a test's own stream or
// bucket.
class SharedNatsClusterTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!OnlyLoopback() || !HaveNatsServer()) return;
    dir_ = ::testing::TempDir() + "/nats_cluster_XXXXXX";
    ASSERT_NE(::mkdtemp(dir_.data()), nullptr);
    cluster_ = std::make_unique<NatsCluster>(dir_ + "/nats", 3);
    cluster_->StartAll();
    ASSERT_TRUE(cluster_->WaitForJetStream(30.0));
  }
  static void TearDownTestSuite() {
    cluster_.reset();
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }
  void SetUp() override {
    if (!OnlyLoopback()) GTEST_SKIP() << kNotInNetns;
    if (!HaveNatsServer()) GTEST_SKIP() << "nats-server is not installed";
    ASSERT_NE(cluster_, nullptr);
    for (int i = 0; i < cluster_->size(); ++i) {
      if (!cluster_->running(i)) cluster_->Start(i);
    }
  }
  static std::string test_name() {
    return ::testing::UnitTest::GetInstance()->current_test_info()->name();
  }

  static inline std::string dir_;
  static inline std::unique_ptr<NatsCluster> cluster_;
};

}  // namespace slamd::testing
