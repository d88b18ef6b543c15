// IngestQueue: the bounded queue between the transport thread (producer) and the estimator
// thread (consumer). Never drops silently: Push on a full queue waits up to a timeout and then
// reports failure, so the caller rejects the message (reject_t REASON_QUEUE_FULL) and counts it.
// Once such a wait has timed out, later ones do not wait until the consumer takes the queue: a
// burst is waited out once, but a sustained overload is answered with rejects at once, since a
// producer blocked again and again cannot read its transport, which then loses messages
// unanswered (UDP multicast has no back-pressure).
// Pop hands the consumer what is queued, up to a bound, at once (the estimator coalesces it
// into one update). Thread-safe: any number of producers, one consumer.
#pragma once

#include <condition_variable>
#include <deque>
#include <mutex>
#include <vector>

#include "server/estimator/estimator.h"

namespace slamd::server {

class IngestQueue {
 public:
  explicit IngestQueue(int capacity);  // capacity >= 1 (checked)

  // Appends `in`, waiting up to timeout_s while the queue is full (not at all while
  // saturated()). False (and `in` untouched in effect: it is dropped by the caller with a
  // reject) when still full or Close()d.
  bool Push(Inbound in, double timeout_s);

  // Waits up to timeout_s (not at all while saturated()) until there is room for `count` more
  // messages (or the queue is closed: false). With a single producer, that many Pushes right
  // after a true result cannot fail for lack of room. count >= 1 (checked).
  bool WaitForRoom(double timeout_s, int count = 1);

  // Waits up to timeout_s for a message, then moves the queued messages (in arrival order), at
  // most `max` (>= 1, checked), to the end of *out. Returns how many; 0 on timeout or when
  // closed and empty.
  int Pop(std::vector<Inbound>* out, double timeout_s, int max);

  // After Pop: while the newest message in *out was received (Inbound::received_us, steady
  // clock) less than quiet_s ago, waits for more and moves them to *out too, for at most
  // max_wait_s in all and until *out holds `max`, so that messages sent back to back come out
  // together. Returns how many it added.
  int PopRestOfBurst(std::vector<Inbound>* out, double quiet_s, double max_wait_s, int max);

  // Refuses further pushes and wakes every waiter; queued messages can still be popped.
  void Close();

  int size() const;
  int peak() const;  // the largest size() has been since construction
  int capacity() const { return capacity_; }
  bool closed() const;
  // A wait for room timed out and the consumer has taken nothing since.
  bool saturated() const;

 private:
  // Moves the oldest queued messages, at most `max`, to the end of *out and wakes blocked
  // pushers; mutex_ held.
  int TakeLocked(std::vector<Inbound>* out, int max);
  // Waits until `has_room` or the queue is closed, up to timeout_s unless saturated_, and sets
  // saturated_ when a wait of timeout_s > 0 ends without room; mutex_ held by `lock`. Whether
  // there is room and the queue is open.
  template <typename HasRoom>
  bool WaitLocked(std::unique_lock<std::mutex>& lock, double timeout_s, HasRoom has_room);

  const int capacity_;
  mutable std::mutex mutex_;
  std::condition_variable not_empty_, not_full_;
  std::deque<Inbound> queue_;
  int peak_ = 0;
  bool closed_ = false;
  bool saturated_ = false;
};

}  // namespace slamd::server
