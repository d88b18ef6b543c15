#include "core/base/worker_pool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <set>
#include <thread>
#include <vector>

namespace slamd::core {
namespace {

// Each task records which thread ran it; every task runs exactly once per round.
TEST(WorkerPoolTest, EveryTaskRunsOnceEveryRound) {
  WorkerPool pool(3);
  for (int round = 0; round < 50; ++round) {
    const int n = round % 6;  // 0..5: fewer, as many and more tasks than helpers
    std::vector<std::atomic<int>> runs(n);
    std::vector<std::thread::id> ran_on(n);
    pool.Run(n, [&](int i) {
      runs[i].fetch_add(1);
      ran_on[i] = std::this_thread::get_id();
    });
    pool.Wait();
    for (int i = 0; i < n; ++i) EXPECT_EQ(runs[i].load(), 1) << "round " << round << " task " << i;
    // Tasks beyond the helpers run on the caller, inside Wait().
    for (int i = 3; i < n; ++i) EXPECT_EQ(ran_on[i], std::this_thread::get_id());
    for (int i = 0; i < std::min(n, 3); ++i) EXPECT_NE(ran_on[i], std::this_thread::get_id());
  }
}

TEST(WorkerPoolTest, TheCallerWorksWhileHelpersRun) {
  WorkerPool pool(1);
  std::atomic<bool> caller_done{false};
  std::atomic<bool> helper_saw_caller{false};
  pool.Run(1, [&](int) {
    while (!caller_done.load())
      std::this_thread::yield();  // returns only once the caller has gone on
    helper_saw_caller = true;
  });
  caller_done = true;  // Run did not wait for the task
  pool.Wait();
  EXPECT_TRUE(helper_saw_caller.load());
}

TEST(WorkerPoolTest, NoHelpersRunsEverythingInWait) {
  WorkerPool pool(0);
  std::set<int> done;
  pool.Run(4, [&](int i) { done.insert(i); });  // no concurrency: a plain set is safe
  EXPECT_TRUE(done.empty());
  pool.Wait();
  EXPECT_EQ(done, (std::set<int>{0, 1, 2, 3}));
}

TEST(WorkerPoolTest, DestroyedUnusedOrAfterUse) {
  { WorkerPool unused(4); }
  WorkerPool used(2);
  std::atomic<int> sum{0};
  used.Run(2, [&](int i) { sum += i + 1; });
  used.Wait();
  EXPECT_EQ(sum.load(), 3);
}

TEST(WorkerPoolDeathTest, RunTwiceWithoutWaitAborts) {
  WorkerPool pool(1);
  EXPECT_DEATH(
      {
        pool.Run(1, [](int) {});
        pool.Run(1, [](int) {});
      },
      "before the last Wait");
}

}  // namespace
}  // namespace slamd::core
