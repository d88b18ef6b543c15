#include "server/estimator/background_priority.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cerrno>
#include <thread>

namespace slamd::server {
namespace {

int ThisThreadsNice() {
  errno = 0;
  const int nice = ::getpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()));
  EXPECT_EQ(errno, 0);
  return nice;
}

// The background threads' priority drops to nice 19 and nobody else's: the estimator thread
// that started them keeps its own.
TEST(BackgroundPriorityTest, LowersOnlyTheCallingThread) {
  const int before = ThisThreadsNice();
  int background = before;
  std::thread t([&] {
    LowerThisThreadsPriority();
    background = ThisThreadsNice();
  });
  t.join();
  EXPECT_EQ(background, 19);
  EXPECT_EQ(ThisThreadsNice(), before);
}

}  // namespace
}  // namespace slamd::server
