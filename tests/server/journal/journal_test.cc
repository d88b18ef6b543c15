#include "server/journal/journal.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "server/journal/read_journal.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {
namespace {

class JournalTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ::testing::TempDir() + "/journal_XXXXXX";
    ASSERT_NE(::mkdtemp(dir_.data()), nullptr);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::unique_ptr<Journal> Open(SyncPolicy policy) {
    return Journal::Open(dir_, {.writer = {.sync_policy = policy}}, {}, 0).value();
  }
  static std::int64_t AppendOne(Journal* journal) {
    const std::vector<std::uint8_t> payload(64, 7);
    const core::Result<std::int64_t> seq =
        journal->AppendMessage("SLAMD_ODOMETRY", "odometry_t", payload, 1);
    EXPECT_TRUE(seq.ok());
    return seq.ok() ? seq.value() : -1;
  }

  std::string dir_;
};

TEST_F(JournalTest, CommitFollowsThePolicy) {
  auto never = Open(SyncPolicy::kNever);
  AppendOne(never.get());
  ASSERT_TRUE(never->Commit().ok());
  EXPECT_LT(never->durable_offset(), never->offset());
  ASSERT_TRUE(never->Sync().ok());
  EXPECT_EQ(never->durable_offset(), never->offset());
  never.reset();
  std::filesystem::remove(JournalSegmentPath(dir_, 0));

  auto always = Open(SyncPolicy::kAlways);
  AppendOne(always.get());
  EXPECT_LT(always->durable_offset(), always->offset());
  ASSERT_TRUE(always->Commit().ok());
  EXPECT_EQ(always->durable_offset(), always->offset());
}

// The daemon's threads: intake appends while the estimator commits. Each commit makes durable at
// least what was appended before it; the sequence numbers have no gap and the file reads back
// whole.
TEST_F(JournalTest, CommitWhileAnotherThreadAppendsCoversWhatCameBefore) {
  auto journal = Open(SyncPolicy::kAlways);
  std::atomic<bool> stop{false};
  std::atomic<std::int64_t> appended{0};
  std::thread intake([&] {
    while (!stop) appended = AppendOne(journal.get());
  });
  while (appended == 0) std::this_thread::yield();
  const std::int64_t appended_first = appended;
  for (int i = 0; i < 300; ++i) {
    const std::int64_t before = journal->offset();
    ASSERT_TRUE(journal->Commit().ok());
    ASSERT_GE(journal->durable_offset(), before) << "commit " << i;
    std::this_thread::sleep_for(std::chrono::microseconds(50));  // the estimator's update
  }
  EXPECT_GT(appended - appended_first, 30) << "the appends did not overlap the commits";
  stop = true;
  intake.join();
  ASSERT_TRUE(journal->Sync().ok());
  EXPECT_EQ(journal->durable_offset(), journal->offset());
  EXPECT_EQ(journal->last_sequence(), appended.load());
  const JournalContents contents = ReadJournal(dir_).value();
  EXPECT_EQ(contents.end, JournalReadState::kCleanEnd);
  ASSERT_EQ(static_cast<std::int64_t>(contents.records.size()), appended.load());
  for (size_t i = 0; i < contents.records.size(); ++i) {
    ASSERT_EQ(contents.records[i].message().sequence(), static_cast<std::int64_t>(i) + 1);
  }
}

}  // namespace
}  // namespace slamd::server
