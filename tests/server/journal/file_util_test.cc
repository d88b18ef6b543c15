#include "server/journal/file_util.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <string>

namespace slamd::server::internal {
namespace {

TEST(FileUtilTest, ErrnoDescriptionNamesTheErrno) {
  EXPECT_NE(ErrnoDescription(ENOSPC).find("(ENOSPC)"), std::string::npos);
  EXPECT_NE(ErrnoDescription(EFBIG).find("File too large (EFBIG)"), std::string::npos);
  EXPECT_NE(ErrnoDescription(EPIPE).find("(errno "), std::string::npos);
}

TEST(FileUtilTest, DirName) {
  EXPECT_EQ(DirName("/a/b/c.jnl"), "/a/b");
  EXPECT_EQ(DirName("c.jnl"), ".");
  EXPECT_EQ(DirName("/c.jnl"), "/");
}

TEST(FileUtilTest, PwriteAllAndPreadUpToRoundTrip) {
  std::string dir = ::testing::TempDir() + "/file_util_XXXXXX";
  ASSERT_NE(::mkdtemp(dir.data()), nullptr);
  const std::string path = dir + "/f";
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC, 0644);
  ASSERT_GE(fd, 0);
  std::size_t written = 0;
  ASSERT_TRUE(PwriteAll(fd, "hello world", 11, 5, path, "test", &written).ok());
  EXPECT_EQ(written, 11u);
  char buf[32] = {};
  EXPECT_EQ(PreadUpTo(fd, buf, sizeof(buf), 5), 11);
  EXPECT_EQ(std::string(buf, 11), "hello world");
  EXPECT_EQ(PreadUpTo(fd, buf, 4, 100), 0);  // past the end
  ::close(fd);
  EXPECT_TRUE(SyncDirectory(dir).ok());
  const core::Status s = SyncDirectory(dir + "/missing");
  EXPECT_EQ(s.code(), core::StatusCode::kIoError);
  EXPECT_NE(s.message().find("missing"), std::string::npos);
  ::unlink(path.c_str());
  ::rmdir(dir.c_str());
}

TEST(FileUtilTest, PwriteAllOnAReadOnlyFdNamesPathOffsetAndCause) {
  const int fd = ::open("/dev/null", O_RDONLY);
  ASSERT_GE(fd, 0);
  std::size_t written = 99;
  const core::Status s = PwriteAll(fd, "x", 1, 42, "/dev/null", "thing", &written);
  ::close(fd);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(written, 0u);
  EXPECT_NE(s.message().find("thing to /dev/null at offset 42"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("Bad file descriptor"), std::string::npos) << s.message();
}

TEST(FileUtilTest, CreateDataDirectoryMakesOwnerOnlyDirectoriesAndReportsLooseOnes) {
  std::string root = ::testing::TempDir() + "/data_dir_XXXXXX";
  ASSERT_NE(::mkdtemp(root.data()), nullptr);
  ASSERT_EQ(::chmod(root.c_str(), 0755), 0);
  const std::string nested = root + "/a/b";
  const mode_t old = ::umask(0);
  bool loose = true;
  const core::Status made = CreateDataDirectory(nested, &loose);
  ::umask(old);
  ASSERT_TRUE(made.ok()) << made.ToString();
  EXPECT_FALSE(loose);
  struct stat st {};
  for (const std::string& d : {root + "/a", nested}) {
    ASSERT_EQ(::stat(d.c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0700u) << d;
  }
  // An existing directory is left as it is, and said to be open to others.
  ASSERT_TRUE(CreateDataDirectory(root, &loose).ok());
  EXPECT_TRUE(loose);
  ASSERT_EQ(::stat(root.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0755u);
  // A file in the way.
  const std::string file = root + "/file";
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT, 0600);
  ASSERT_GE(fd, 0);
  ::close(fd);
  const core::Status refused = CreateDataDirectory(file, nullptr);
  EXPECT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("not a directory"), std::string::npos) << refused.ToString();
  ::rmdir(nested.c_str());
  ::rmdir((root + "/a").c_str());
  ::unlink(file.c_str());
  ::rmdir(root.c_str());
}

}  // namespace
}  // namespace slamd::server::internal
