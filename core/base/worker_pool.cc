#include "core/base/worker_pool.h"

#include <algorithm>
#include <system_error>

#include "core/base/check.h"
#include "core/base/thread_name.h"

namespace slamd::core {

WorkerPool::WorkerPool(int helpers) : helpers_(helpers) {
  SLAMD_CHECK(helpers >= 0) << "WorkerPool: helpers = " << helpers << "; must be >= 0";
}

WorkerPool::~WorkerPool() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (std::thread& t : threads_) t.join();
}

void WorkerPool::Run(int n, std::function<void(int)> task) {
  SLAMD_CHECK(pending_ == 0 && total_ == 0) << "WorkerPool::Run before the last Wait";
  while (static_cast<int>(threads_.size()) < std::min(n, helpers_)) {
    const int index = static_cast<int>(threads_.size());
    try {
      threads_.emplace_back([this, index] {
        NameThisThread("slamd-worker");
        Loop(index);
      });
    } catch (const std::system_error&) {
      break;  // no thread to be had: its tasks run in Wait()
    }
  }
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    task_ = std::move(task);
    total_ = n;
    on_helpers_ = std::min(n, static_cast<int>(threads_.size()));
    pending_ = on_helpers_;
    ++round_;
  }
  wake_.notify_all();
}

void WorkerPool::Wait() {
  for (int i = on_helpers_; i < total_; ++i) task_(i);
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [this] { return pending_ == 0; });
  total_ = on_helpers_ = 0;
  task_ = nullptr;
}

void WorkerPool::Loop(int index) {
  std::uint64_t seen = 0;
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return stop_ || round_ != seen; });
    if (stop_) return;
    seen = round_;
    if (index >= on_helpers_) continue;
    lock.unlock();
    task_(index);  // task_ does not change before Wait() has seen every helper task finish
    lock.lock();
    if (--pending_ == 0) done_.notify_one();
  }
}

}  // namespace slamd::core
