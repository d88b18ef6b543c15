#include "server/journal/snapshot_file.h"

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>

#include "tests/testing/files.h"

namespace slamd::server {
namespace {

namespace fs = std::filesystem;

std::string RandomBytes(std::size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::string s(n, '\0');
  for (auto& c : s) c = static_cast<char>(rng());
  return s;
}

class SnapshotFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ::testing::TempDir() + "/snapshot_file_XXXXXX";
    ASSERT_NE(::mkdtemp(dir_.data()), nullptr);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::vector<int64_t> Sequences() {
    auto list = ListSnapshots(dir_);
    EXPECT_TRUE(list.ok());
    std::vector<int64_t> out;
    for (const auto& s : *list) out.push_back(s.sequence);
    return out;
  }

  std::string dir_;
};

TEST_F(SnapshotFileTest, NameSortsBySequence) {
  EXPECT_EQ(SnapshotFileName(42), "snapshot-00000000000000000042.snp");
}

TEST_F(SnapshotFileTest, WriteThenReadReturnsTheBytes) {
  // Sizes around the writer's 1 MiB chunks.
  for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{1} << 20,
                              (std::size_t{1} << 20) + 1, (std::size_t{3} << 20) + 12345}) {
    const std::string bytes = RandomBytes(n, static_cast<uint32_t>(n));
    auto path = WriteSnapshotFile(dir_, static_cast<int64_t>(n), bytes, {.keep = 5});
    ASSERT_TRUE(path.ok()) << path.status().ToString();
    EXPECT_EQ(*path, dir_ + "/" + SnapshotFileName(static_cast<int64_t>(n)));
    int64_t seq = -1;
    auto back = ReadSnapshotFile(*path, &seq);
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    EXPECT_EQ(*back, bytes);
    EXPECT_EQ(seq, static_cast<int64_t>(n));
    EXPECT_EQ(fs::file_size(*path), 32 + n);
  }
}

TEST_F(SnapshotFileTest, KeepsTheNewestAndListsNewestFirst) {
  for (int64_t seq = 1; seq <= 5; ++seq) {
    ASSERT_TRUE(
        WriteSnapshotFile(dir_, seq * 10, "state " + std::to_string(seq), {.keep = 2}).ok());
  }
  EXPECT_EQ(Sequences(), (std::vector<int64_t>{50, 40}));
  ASSERT_TRUE(WriteSnapshotFile(dir_, 60, "six", {.keep = 1}).ok());
  EXPECT_EQ(Sequences(), (std::vector<int64_t>{60}));
  auto bad = WriteSnapshotFile(dir_, 70, "x", {.keep = 0});
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("SnapshotFileOptions::keep = 0; violates >= 1"),
            std::string::npos);
  EXPECT_EQ(Sequences(), (std::vector<int64_t>{60}));
}

// PruneSnapshots keeps the newest `keep` and removes temporaries; keep 0 is refused (it would
// leave nothing to recover from).
TEST_F(SnapshotFileTest, PruneKeepsTheNewest) {
  for (int64_t seq = 1; seq <= 3; ++seq) {
    ASSERT_TRUE(WriteSnapshotFile(dir_, seq, "state", {.keep = 3}).ok());
  }
  const std::string temp = dir_ + "/." + SnapshotFileName(4) + ".tmp";
  testing::WriteFileBytes(temp, "SLAMDSNP");
  const core::Status zero = PruneSnapshots(dir_, 0);
  EXPECT_EQ(zero.code(), core::StatusCode::kInvalidArgument);
  EXPECT_NE(zero.message().find("keep = 0"), std::string::npos) << zero.ToString();
  EXPECT_EQ(Sequences(), (std::vector<int64_t>{3, 2, 1}));
  ASSERT_TRUE(PruneSnapshots(dir_, 2).ok());
  EXPECT_EQ(Sequences(), (std::vector<int64_t>{3, 2}));
  EXPECT_FALSE(fs::exists(temp));
  ASSERT_TRUE(PruneSnapshots(dir_, 5).ok());
  EXPECT_EQ(Sequences(), (std::vector<int64_t>{3, 2}));
}

// A pruned snapshot larger than the 8 MiB truncation step is removed whole, leaving neither the
// file nor the temporary it is renamed to; the kept one reads back.
TEST_F(SnapshotFileTest, LargeSnapshotsArePrunedCompletely) {
  const std::string big = RandomBytes((std::size_t{20} << 20) + 3, 1);
  ASSERT_TRUE(WriteSnapshotFile(dir_, 1, big, {.keep = 1}).ok());
  ASSERT_TRUE(WriteSnapshotFile(dir_, 2, "two", {.keep = 1}).ok());
  EXPECT_EQ(Sequences(), (std::vector<int64_t>{2}));
  std::vector<std::string> left;
  for (const auto& entry : fs::directory_iterator(dir_)) {
    left.push_back(entry.path().filename().string());
  }
  EXPECT_EQ(left, (std::vector<std::string>{SnapshotFileName(2)}));
  int64_t seq = -1;
  EXPECT_EQ(ReadSnapshotFile(dir_ + "/" + SnapshotFileName(2), &seq).value(), "two");
}

TEST_F(SnapshotFileTest, InterruptedTemporaryIsIgnoredThenRemoved) {
  ASSERT_TRUE(WriteSnapshotFile(dir_, 5, "five").ok());
  // What a crash during WriteSnapshotFile(6) leaves: a half-written hidden temporary.
  const std::string temp = dir_ + "/." + SnapshotFileName(6) + ".tmp";
  testing::WriteFileBytes(temp, "SLAMDSNP\x01");
  testing::WriteFileBytes(dir_ + "/notes.txt", "unrelated");
  testing::WriteFileBytes(dir_ + "/snapshot-12.snp", "wrong name pattern");
  EXPECT_EQ(Sequences(), (std::vector<int64_t>{5}));
  auto loaded = LoadNewestSnapshot(dir_);
  ASSERT_TRUE(loaded.ok());
  EXPECT_EQ(loaded->info.sequence, 5);
  EXPECT_EQ(loaded->bytes, "five");
  ASSERT_TRUE(WriteSnapshotFile(dir_, 7, "seven").ok());
  EXPECT_FALSE(fs::exists(temp));
  EXPECT_TRUE(fs::exists(dir_ + "/notes.txt"));
  EXPECT_EQ(Sequences(), (std::vector<int64_t>{7, 5}));
}

TEST_F(SnapshotFileTest, CorruptOrTornFilesAreReportedWithPathAndReason) {
  const std::string bytes = RandomBytes(5000, 9);
  auto path = WriteSnapshotFile(dir_, 1, bytes);
  ASSERT_TRUE(path.ok());
  const std::string good = testing::ReadFileBytes(*path);
  std::mt19937 rng(10);
  for (int trial = 0; trial < 50; ++trial) {  // any single bit flip after the magic is caught
    std::string b = good;
    const std::size_t at = 8 + rng() % (b.size() - 8);
    b[at] = static_cast<char>(b[at] ^ (1 << (rng() % 8)));
    testing::WriteFileBytes(*path, b);
    auto r = ReadSnapshotFile(*path);
    ASSERT_FALSE(r.ok()) << "flip at " << at;
    EXPECT_EQ(r.status().code(), core::StatusCode::kDataLoss);
    EXPECT_NE(r.status().message().find(*path), std::string::npos);
  }
  std::string b = good;
  b[100] ^= 1;
  testing::WriteFileBytes(*path, b);
  EXPECT_NE(ReadSnapshotFile(*path).status().message().find("checksum mismatch"),
            std::string::npos);
  testing::WriteFileBytes(*path, good.substr(0, good.size() - 10));
  EXPECT_NE(ReadSnapshotFile(*path).status().message().find("(torn)"), std::string::npos);
  testing::WriteFileBytes(*path, good.substr(0, 20));
  EXPECT_NE(ReadSnapshotFile(*path).status().message().find("less than the 32-byte header"),
            std::string::npos);
  b = good;
  b[0] = 'X';
  testing::WriteFileBytes(*path, b);
  EXPECT_NE(ReadSnapshotFile(*path).status().message().find("bad magic"), std::string::npos);
  b = good;
  b[8] = 9;
  testing::WriteFileBytes(*path, b);
  EXPECT_NE(ReadSnapshotFile(*path).status().message().find("unsupported version 9"),
            std::string::npos);
  EXPECT_EQ(ReadSnapshotFile(dir_ + "/missing.snp").status().code(), core::StatusCode::kNotFound);
}

TEST_F(SnapshotFileTest, LoadNewestSkipsCorruptNewerSnapshots) {
  EXPECT_EQ(LoadNewestSnapshot(dir_).status().code(), core::StatusCode::kNotFound);
  ASSERT_TRUE(WriteSnapshotFile(dir_, 1, "one", {.keep = 3}).ok());
  auto two = WriteSnapshotFile(dir_, 2, "two", {.keep = 3});
  ASSERT_TRUE(two.ok());
  testing::WriteFileBytes(*two, testing::ReadFileBytes(*two).substr(0, 33));  // torn
  auto loaded = LoadNewestSnapshot(dir_);
  ASSERT_TRUE(loaded.ok());
  EXPECT_EQ(loaded->info.sequence, 1);
  EXPECT_EQ(loaded->bytes, "one");
  ASSERT_EQ(loaded->skipped.size(), 1u);
  EXPECT_NE(loaded->skipped[0].find(*two), std::string::npos);
}

TEST_F(SnapshotFileTest, FailedWriteLeavesExistingSnapshotsAndNoTemporary) {
  ASSERT_TRUE(WriteSnapshotFile(dir_, 1, "one").ok());
  auto r = WriteSnapshotFile(dir_ + "/missing", 2, "two");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), core::StatusCode::kIoError);
  EXPECT_NE(r.status().message().find("missing"), std::string::npos);
  EXPECT_EQ(Sequences(), (std::vector<int64_t>{1}));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
}

TEST_F(SnapshotFileTest, SnapshotsAreOwnerOnlyWhateverTheUmask) {
  const mode_t old = ::umask(0);
  auto path = WriteSnapshotFile(dir_, 1, "state", {.keep = 2});
  ::umask(old);
  ASSERT_TRUE(path.ok()) << path.status().ToString();
  EXPECT_EQ(fs::status(*path).permissions(), fs::perms::owner_read | fs::perms::owner_write);
}

}  // namespace
}  // namespace slamd::server
