#include "server/journal/journal_writer.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "server/journal/journal_format.h"
#include "server/journal/read_journal.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {
namespace {

using journal::JournalRecord;
using std::chrono::milliseconds;

class JournalWriterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ::testing::TempDir() + "/journal_writer_XXXXXX";
    ASSERT_NE(::mkdtemp(dir_.data()), nullptr);
    path_ = dir_ + "/journal.jnl";
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  int64_t FileSize() const {
    struct stat st {};
    return ::stat(path_.c_str(), &st) == 0 ? st.st_size : -1;
  }

  std::string dir_, path_;
};

JournalRecord OdometryMessage(int64_t seq, std::size_t payload_bytes, std::mt19937* rng) {
  JournalRecord r;
  auto* m = r.mutable_message();
  m->set_sequence(seq);
  m->set_channel("SLAMD_ODOMETRY");
  m->set_message_type("odometry_t");
  std::string bytes(payload_bytes, '\0');
  for (auto& c : bytes) c = static_cast<char>((*rng)());
  m->set_lcm_payload(bytes);
  m->set_received_wall_us(1'700'000'000'000'000 + seq);
  return r;
}

JournalRecord Boundary(int64_t update, int64_t last_message, int count) {
  JournalRecord r;
  auto* b = r.mutable_boundary();
  b->set_update_sequence(update);
  b->set_last_message_sequence(last_message);
  b->set_message_count(count);
  return r;
}

std::unique_ptr<JournalWriter> MustOpen(const std::string& path, JournalWriterOptions o = {}) {
  auto w = JournalWriter::Open(path, o);
  EXPECT_TRUE(w.ok()) << w.status().ToString();
  return w.ok() ? std::move(w).value() : nullptr;
}

TEST_F(JournalWriterTest, WritesRecordsThatReadBackEqualWithTheirOffsets) {
  std::mt19937 rng(11);
  auto w = MustOpen(path_);
  ASSERT_TRUE(w);
  EXPECT_EQ(w->offset(), kJournalHeaderSize);
  std::vector<JournalRecord> written;
  std::vector<int64_t> starts;
  int64_t seq = 0;
  for (int i = 0; i < 60; ++i) {
    // Mostly small messages, one large one, a boundary every 5.
    written.push_back(i % 5 == 4 ? Boundary(i / 5 + 1, seq, 4)
                                 : OdometryMessage(++seq, i == 17 ? 300'000 : rng() % 3000, &rng));
    starts.push_back(w->offset());
    auto end = w->Append(written.back());
    ASSERT_TRUE(end.ok()) << end.status().ToString();
    EXPECT_EQ(*end, w->offset());
    EXPECT_EQ(*end - starts.back(), 8 + static_cast<int64_t>(written.back().ByteSizeLong()));
  }
  EXPECT_EQ(w->records(), 60);
  ASSERT_TRUE(w->Close().ok());
  EXPECT_EQ(FileSize(), w->offset());

  auto c = ReadJournal(path_);
  ASSERT_TRUE(c.ok()) << c.status().ToString();
  EXPECT_EQ(c->end, JournalReadState::kCleanEnd);
  ASSERT_EQ(c->records.size(), written.size());
  for (std::size_t i = 0; i < written.size(); ++i) {
    EXPECT_EQ(c->records[i].SerializeAsString(), written[i].SerializeAsString()) << i;
    EXPECT_EQ(c->offsets[i], starts[i]) << i;
  }
  EXPECT_EQ(c->records[17].message().lcm_payload(), written[17].message().lcm_payload());
  EXPECT_EQ(c->valid_end_offset, FileSize());
}

TEST_F(JournalWriterTest, ReopenAppendsAtTheEnd) {
  std::mt19937 rng(1);
  int64_t end = 0;
  {
    auto w = MustOpen(path_);
    ASSERT_TRUE(w);
    ASSERT_TRUE(w->Append(OdometryMessage(1, 100, &rng)).ok());
    end = w->offset();
  }  // destroyed without Close: the bytes are in the file anyway
  auto w = MustOpen(path_);
  ASSERT_TRUE(w);
  EXPECT_EQ(w->offset(), end);
  EXPECT_EQ(w->durable_offset(), end);  // Open syncs what it found
  EXPECT_EQ(w->records(), 0);
  ASSERT_TRUE(w->Append(OdometryMessage(2, 100, &rng)).ok());
  auto c = ReadJournal(path_);
  ASSERT_TRUE(c.ok());
  ASSERT_EQ(c->records.size(), 2u);
  EXPECT_EQ(c->offsets[1], end);
  EXPECT_EQ(c->records[1].message().sequence(), 2);
}

TEST_F(JournalWriterTest, RejectsRecordsWithoutKindOrTooLargeAndWritesNothing) {
  std::mt19937 rng(2);
  auto w = MustOpen(path_);
  ASSERT_TRUE(w);
  auto r = w->Append(JournalRecord());
  EXPECT_EQ(r.status().code(), core::StatusCode::kInvalidArgument);
  r = w->Append(OdometryMessage(1, kJournalMaxRecordPayload, &rng));
  EXPECT_EQ(r.status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("exceeds the maximum"), std::string::npos);
  EXPECT_EQ(w->offset(), kJournalHeaderSize);
  EXPECT_EQ(FileSize(), kJournalHeaderSize);
}

TEST_F(JournalWriterTest, OptionsValidationNamesTheField) {
  auto w = JournalWriter::Open(path_, {.sync_policy = SyncPolicy::kInterval, .interval_ms = 0});
  ASSERT_FALSE(w.ok());
  EXPECT_EQ(w.status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_NE(w.status().message().find("JournalWriterOptions::interval_ms = 0; violates >= 1"),
            std::string::npos)
      << w.status().message();
  EXPECT_EQ(FileSize(), -1);  // nothing created
}

TEST_F(JournalWriterTest, OpenRefusesShortOrForeignFiles) {
  {
    std::FILE* f = std::fopen(path_.c_str(), "wb");
    std::fwrite("SLAMD", 1, 5, f);
    std::fclose(f);
  }
  auto w = JournalWriter::Open(path_, {});
  EXPECT_EQ(w.status().code(), core::StatusCode::kFailedPrecondition);
  {
    std::FILE* f = std::fopen(path_.c_str(), "wb");
    std::fwrite("NOTAJOURNAL.....", 1, 16, f);
    std::fclose(f);
  }
  w = JournalWriter::Open(path_, {});
  EXPECT_EQ(w.status().code(), core::StatusCode::kDataLoss);
  EXPECT_NE(w.status().message().find("bad magic"), std::string::npos);
  w = JournalWriter::Open(dir_ + "/no/such/dir/j.jnl", {});
  EXPECT_EQ(w.status().code(), core::StatusCode::kIoError);
  EXPECT_NE(w.status().message().find("ENOENT"), std::string::npos);
}

TEST_F(JournalWriterTest, NeverPolicySyncsOnlyWhenAsked) {
  std::mt19937 rng(3);
  auto w = MustOpen(path_, {.sync_policy = SyncPolicy::kNever});
  ASSERT_TRUE(w);
  EXPECT_EQ(w->durable_offset(), kJournalHeaderSize);
  for (int i = 1; i <= 10; ++i) ASSERT_TRUE(w->Append(OdometryMessage(i, 50, &rng)).ok());
  const auto now = JournalWriter::Clock::now();
  ASSERT_TRUE(w->MaybeSync(now + std::chrono::hours(1)).ok());
  EXPECT_EQ(w->durable_offset(), kJournalHeaderSize);
  EXPECT_TRUE(w->sync_pending());
  EXPECT_EQ(w->sync_count(), 0);
  ASSERT_TRUE(w->Sync().ok());
  EXPECT_EQ(w->durable_offset(), w->offset());
  EXPECT_EQ(w->sync_count(), 1);
  ASSERT_TRUE(w->Sync().ok());  // nothing pending: no second fdatasync
  EXPECT_EQ(w->sync_count(), 1);
}

// kAlways = group commit: Append never syncs; each MaybeSync (one per solver update) does.
TEST_F(JournalWriterTest, AlwaysPolicySyncsOncePerCommitNotPerRecord) {
  std::mt19937 rng(4);
  auto w = MustOpen(path_, {.sync_policy = SyncPolicy::kAlways});
  ASSERT_TRUE(w);
  int64_t seq = 0;
  for (int update = 1; update <= 5; ++update) {
    for (int i = 0; i < 7; ++i) ASSERT_TRUE(w->Append(OdometryMessage(++seq, 80, &rng)).ok());
    ASSERT_TRUE(w->Append(Boundary(update, seq, 7)).ok());
    EXPECT_EQ(w->durable_offset() < w->offset(), true);
    ASSERT_TRUE(w->MaybeSync(JournalWriter::Clock::now()).ok());
    EXPECT_EQ(w->durable_offset(), w->offset());
    EXPECT_EQ(w->sync_count(), update);
  }
  ASSERT_TRUE(w->MaybeSync(JournalWriter::Clock::now()).ok());  // nothing pending
  EXPECT_EQ(w->sync_count(), 5);
}

TEST_F(JournalWriterTest, IntervalPolicySyncsWhenTheIntervalHasPassed) {
  std::mt19937 rng(5);
  auto w = MustOpen(path_, {.sync_policy = SyncPolicy::kInterval, .interval_ms = 100});
  ASSERT_TRUE(w);
  const auto t0 = JournalWriter::Clock::now();  // Open's sync time is <= t0
  ASSERT_TRUE(w->Append(OdometryMessage(1, 10, &rng)).ok());
  ASSERT_TRUE(w->MaybeSync(t0 + milliseconds(200)).ok());
  EXPECT_EQ(w->sync_count(), 1);
  EXPECT_EQ(w->durable_offset(), w->offset());

  ASSERT_TRUE(w->Append(OdometryMessage(2, 10, &rng)).ok());
  ASSERT_TRUE(w->MaybeSync(t0 + milliseconds(250)).ok());  // 50 ms since the last sync
  EXPECT_EQ(w->sync_count(), 1);
  EXPECT_LT(w->durable_offset(), w->offset());
  ASSERT_TRUE(w->MaybeSync(t0 + milliseconds(299)).ok());
  EXPECT_EQ(w->sync_count(), 1);
  ASSERT_TRUE(w->MaybeSync(t0 + milliseconds(300)).ok());  // 100 ms: due
  EXPECT_EQ(w->sync_count(), 2);
  EXPECT_EQ(w->durable_offset(), w->offset());
  ASSERT_TRUE(w->MaybeSync(t0 + milliseconds(900)).ok());  // due, but nothing pending
  EXPECT_EQ(w->sync_count(), 2);
}

TEST_F(JournalWriterTest, ClosedWriterRefusesWork) {
  auto w = MustOpen(path_);
  ASSERT_TRUE(w);
  ASSERT_TRUE(w->Close().ok());
  EXPECT_EQ(w->Append(Boundary(1, 0, 0)).status().code(), core::StatusCode::kFailedPrecondition);
  EXPECT_EQ(w->Sync().code(), core::StatusCode::kFailedPrecondition);
}

// Lowers the soft RLIMIT_FSIZE (SIGXFSZ ignored, so writes fail with EFBIG) and restores both
// on destruction.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    old_handler_ = ::signal(SIGXFSZ, SIG_IGN);
    ::getrlimit(RLIMIT_FSIZE, &old_);
    rlimit lim = old_;
    lim.rlim_cur = bytes;
    ok_ = ::setrlimit(RLIMIT_FSIZE, &lim) == 0;
  }
  ~FileSizeLimit() {
    ::setrlimit(RLIMIT_FSIZE, &old_);
    ::signal(SIGXFSZ, old_handler_);
  }
  bool ok() const { return ok_; }

 private:
  rlimit old_{};
  sighandler_t old_handler_{};
  bool ok_ = false;
};

TEST_F(JournalWriterTest, DiskFullFailsCleanlyAndIntakeResumesWhenSpaceReturns) {
  std::mt19937 rng(6);
  auto w = MustOpen(path_, {.sync_policy = SyncPolicy::kAlways});
  ASSERT_TRUE(w);
  std::vector<JournalRecord> accepted;
  for (int i = 1; i <= 5; ++i) {
    accepted.push_back(OdometryMessage(i, 200, &rng));
    ASSERT_TRUE(w->Append(accepted.back()).ok());
  }
  ASSERT_TRUE(w->MaybeSync(JournalWriter::Clock::now()).ok());
  const int64_t full_at = w->offset();
  {
    // Room for 100 more bytes: a 1000-byte record is written partly (a short write), then the
    // next write fails with EFBIG; the writer must cut the partial record off.
    FileSizeLimit limit(static_cast<rlim_t>(full_at + 100));
    ASSERT_TRUE(limit.ok());
    for (int attempt = 0; attempt < 3; ++attempt) {
      auto r = w->Append(OdometryMessage(6, 1000, &rng));
      ASSERT_FALSE(r.ok());
      const std::string& m = r.status().message();
      EXPECT_EQ(r.status().code(), core::StatusCode::kIoError);
      EXPECT_NE(m.find("EFBIG"), std::string::npos) << m;
      EXPECT_NE(m.find(path_), std::string::npos) << m;
      EXPECT_NE(m.find("offset " + std::to_string(full_at)), std::string::npos) << m;
      EXPECT_EQ(w->offset(), full_at);
      EXPECT_EQ(FileSize(), full_at);  // no partial record left behind
    }
    // A record that fits still goes in: the writer keeps working while the disk is "full".
    accepted.push_back(Boundary(1, 5, 5));
    auto r = w->Append(accepted.back());
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    ASSERT_TRUE(w->Sync().ok());
    auto c = ReadJournal(path_);
    ASSERT_TRUE(c.ok());
    EXPECT_EQ(c->end, JournalReadState::kCleanEnd);
    EXPECT_EQ(c->records.size(), accepted.size());
  }
  // Space is back: the retried message goes in and the journal reads back clean.
  accepted.push_back(OdometryMessage(6, 1000, &rng));
  auto r = w->Append(accepted.back());
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  ASSERT_TRUE(w->Close().ok());
  auto c = ReadJournal(path_);
  ASSERT_TRUE(c.ok()) << c.status().ToString();
  EXPECT_EQ(c->end, JournalReadState::kCleanEnd);
  ASSERT_EQ(c->records.size(), accepted.size());
  for (std::size_t i = 0; i < accepted.size(); ++i) {
    EXPECT_EQ(c->records[i].SerializeAsString(), accepted[i].SerializeAsString()) << i;
  }
}

TEST_F(JournalWriterTest, DiskFullWhileCreatingLeavesNoHalfHeader) {
  FileSizeLimit limit(10);
  ASSERT_TRUE(limit.ok());
  auto w = JournalWriter::Open(path_, {});
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.status().message().find("EFBIG"), std::string::npos) << w.status().message();
  EXPECT_EQ(FileSize(), 0);
}

TEST_F(JournalWriterTest, TheJournalIsOwnerOnlyWhateverTheUmask) {
  const mode_t old = ::umask(0);
  auto w = MustOpen(path_);
  ::umask(old);
  ASSERT_NE(w, nullptr);
  struct stat st {};
  ASSERT_EQ(::stat(path_.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
}

}  // namespace
}  // namespace slamd::server
