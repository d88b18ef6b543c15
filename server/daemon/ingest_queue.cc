#include "server/daemon/ingest_queue.h"

#include <algorithm>
#include <chrono>

#include "core/base/check.h"

namespace slamd::server {
namespace {

std::chrono::nanoseconds ToDuration(double seconds) {
  return std::chrono::nanoseconds(static_cast<std::int64_t>(std::max(0.0, seconds) * 1e9));
}

}  // namespace

IngestQueue::IngestQueue(int capacity) : capacity_(capacity) {
  SLAMD_CHECK(capacity >= 1) << "IngestQueue capacity " << capacity;
}

template <typename HasRoom>
bool IngestQueue::WaitLocked(std::unique_lock<std::mutex>& lock, double timeout_s,
                             HasRoom has_room) {
  const bool wait = timeout_s > 0.0 && !saturated_;
  const bool room = not_full_.wait_for(lock, ToDuration(wait ? timeout_s : 0.0),
                                       [&] { return closed_ || has_room(); });
  if (!room && wait) saturated_ = true;
  return room && !closed_;
}

bool IngestQueue::Push(Inbound in, double timeout_s) {
  std::unique_lock lock(mutex_);
  if (!WaitLocked(lock, timeout_s,
                  [&] { return static_cast<int>(queue_.size()) < capacity_; })) {
    return false;
  }
  queue_.push_back(std::move(in));
  peak_ = std::max(peak_, static_cast<int>(queue_.size()));
  lock.unlock();
  not_empty_.notify_one();
  return true;
}

bool IngestQueue::WaitForRoom(double timeout_s, int count) {
  SLAMD_CHECK(count >= 1) << "IngestQueue::WaitForRoom count " << count;
  std::unique_lock lock(mutex_);
  return WaitLocked(lock, timeout_s,
                    [&] { return static_cast<int>(queue_.size()) + count <= capacity_; });
}

int IngestQueue::TakeLocked(std::vector<Inbound>* out, int max) {
  const int n = std::min(static_cast<int>(queue_.size()), std::max(max, 0));
  for (int i = 0; i < n; ++i) {
    out->push_back(std::move(queue_.front()));
    queue_.pop_front();
  }
  if (n > 0) {
    saturated_ = false;
    not_full_.notify_all();
  }
  return n;
}

int IngestQueue::Pop(std::vector<Inbound>* out, double timeout_s, int max) {
  SLAMD_CHECK(max >= 1) << "IngestQueue::Pop max " << max;
  std::unique_lock lock(mutex_);
  not_empty_.wait_for(lock, ToDuration(timeout_s), [&] { return closed_ || !queue_.empty(); });
  return TakeLocked(out, max);
}

int IngestQueue::PopRestOfBurst(std::vector<Inbound>* out, double quiet_s, double max_wait_s,
                                int max) {
  using Clock = std::chrono::steady_clock;
  std::int64_t newest_us = 0;
  for (const Inbound& in : *out) newest_us = std::max(newest_us, in.received_us);
  const Clock::time_point until = Clock::now() + ToDuration(max_wait_s);
  int added = 0;
  std::unique_lock lock(mutex_);
  while (static_cast<int>(out->size()) < max) {
    const Clock::time_point quiet_end = std::min(
        Clock::time_point(std::chrono::microseconds(newest_us)) + ToDuration(quiet_s), until);
    const bool more =
        not_empty_.wait_until(lock, quiet_end, [&] { return closed_ || !queue_.empty(); });
    if (!more || queue_.empty()) break;  // quiet (or closed)
    for (const Inbound& in : queue_) newest_us = std::max(newest_us, in.received_us);
    added += TakeLocked(out, max - static_cast<int>(out->size()));
  }
  return added;
}

void IngestQueue::Close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  not_empty_.notify_all();
  not_full_.notify_all();
}

int IngestQueue::size() const {
  std::lock_guard lock(mutex_);
  return static_cast<int>(queue_.size());
}

int IngestQueue::peak() const {
  std::lock_guard lock(mutex_);
  return peak_;
}

bool IngestQueue::closed() const {
  std::lock_guard lock(mutex_);
  return closed_;
}

bool IngestQueue::saturated() const {
  std::lock_guard lock(mutex_);
  return saturated_;
}

}  // namespace slamd::server
