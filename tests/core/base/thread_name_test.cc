#include "core/base/thread_name.h"

#include <gtest/gtest.h>

#include <string>
#include <thread>

#include "core/base/worker_pool.h"

namespace slamd::core {
namespace {

TEST(ThreadNameTest, NamesOnlyTheCallingThreadAndCutsAtFifteen) {
  const std::string before = ThisThreadName();
  std::string inside, cut;
  std::thread t([&] {
    NameThisThread("slamd-test");
    inside = ThisThreadName();
    NameThisThread("a-name-longer-than-fifteen");
    cut = ThisThreadName();
  });
  t.join();
  EXPECT_EQ(inside, "slamd-test");
  EXPECT_EQ(cut, "a-name-longer-t");
  EXPECT_EQ(ThisThreadName(), before);
}

TEST(ThreadNameTest, WorkerPoolHelpersAreNamed) {
  WorkerPool pool(1);
  std::string name;
  pool.Run(1, [&](int) { name = ThisThreadName(); });
  pool.Wait();
  EXPECT_EQ(name, "slamd-worker");
}

}  // namespace
}  // namespace slamd::core
