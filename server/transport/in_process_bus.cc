#include "server/transport/in_process_bus.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <regex>
#include <string>
#include <vector>

namespace slamd::server {
namespace {

bool IsLiteral(std::string_view pattern) {
  for (char c : pattern) {
    const bool plain = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                       c == '_' || c == '-' || c == '/' || c == ':' || c == '#' || c == '@';
    if (!plain) return false;
  }
  return true;
}

}  // namespace

struct InProcessBus::State {
  struct Entry {
    std::uint64_t id = 0;
    std::string pattern;
    bool literal = false;  // the pattern has no regex syntax: compare strings, skip std::regex
    std::regex regex;
    MessageCallback callback;
    std::atomic<bool> active{true};

    bool Matches(const std::string& channel) const {
      return literal ? channel == pattern : std::regex_match(channel, regex);
    }
  };

  struct Message {
    std::string channel;
    std::vector<std::uint8_t> bytes;
  };

  mutable std::mutex mutex;
  std::condition_variable arrived;
  std::deque<Message> queue;
  std::vector<std::shared_ptr<Entry>> entries;
  std::uint64_t next_id = 1;

  void Remove(std::uint64_t id) {
    std::lock_guard lock(mutex);
    for (auto it = entries.begin(); it != entries.end(); ++it) {
      if ((*it)->id == id) {
        (*it)->active = false;  // a dispatch holding a snapshot skips it from now on
        entries.erase(it);
        return;
      }
    }
  }
};

InProcessBus::InProcessBus() : state_(std::make_shared<State>()) {}
InProcessBus::~InProcessBus() = default;

core::Status InProcessBus::Publish(std::string_view channel, std::span<const std::uint8_t> bytes) {
  SLAMD_RETURN_IF_ERROR(CheckChannelName(channel));
  {
    std::lock_guard lock(state_->mutex);
    state_->queue.push_back(State::Message{std::string(channel), {bytes.begin(), bytes.end()}});
  }
  state_->arrived.notify_one();
  return core::Status::Ok();
}

core::Result<Subscription> InProcessBus::Subscribe(std::string_view channel_regex,
                                                   MessageCallback callback) {
  if (channel_regex.empty()) return core::InvalidArgument("empty channel pattern");
  if (!callback)
    return core::InvalidArgument("null callback for channel '" + std::string(channel_regex) + "'");
  auto entry = std::make_shared<State::Entry>();
  entry->pattern = std::string(channel_regex);
  entry->literal = IsLiteral(channel_regex);
  if (!entry->literal) {
    try {
      entry->regex = std::regex(entry->pattern, std::regex::ECMAScript);
    } catch (const std::regex_error& e) {
      return core::InvalidArgument("channel pattern '" + entry->pattern +
                                   "' is not a valid regex: " + e.what());
    }
  }
  entry->callback = std::move(callback);
  std::uint64_t id;
  {
    std::lock_guard lock(state_->mutex);
    id = entry->id = state_->next_id++;
    state_->entries.push_back(std::move(entry));
  }
  std::weak_ptr<State> weak = state_;
  return Subscription([weak, id] {
    if (auto state = weak.lock()) state->Remove(id);
  });
}

core::Result<int> InProcessBus::HandleFor(std::chrono::microseconds timeout) {
  if (timeout.count() < 0) return core::InvalidArgument("HandleFor: timeout must be >= 0");
  std::deque<State::Message> batch;
  std::vector<std::shared_ptr<State::Entry>> entries;
  {
    std::unique_lock lock(state_->mutex);
    state_->arrived.wait_for(lock, timeout, [&] { return !state_->queue.empty(); });
    batch.swap(state_->queue);
    entries = state_->entries;  // snapshot: callbacks may publish without deadlocking
  }
  // A throwing callback must not stop the others: catch, count, report the first one.
  std::string first_error;
  int errors = 0;
  auto record = [&](const std::string& channel, const char* what) {
    if (errors++ == 0) first_error = "callback on channel '" + channel + "' threw: " + what;
  };
  for (const State::Message& message : batch) {
    for (const auto& entry : entries) {
      if (!entry->active || !entry->Matches(message.channel)) continue;
      try {
        entry->callback(message.channel, message.bytes);
      } catch (const std::exception& e) {
        record(message.channel, e.what());
      } catch (...) {
        record(message.channel, "a non-std exception");
      }
    }
  }
  if (errors > 0) {
    if (errors > 1) first_error += " (and " + std::to_string(errors - 1) + " more)";
    return core::FailedPrecondition(first_error + "; callbacks must not throw");
  }
  return static_cast<int>(batch.size());
}

int InProcessBus::pending() const {
  std::lock_guard lock(state_->mutex);
  return static_cast<int>(state_->queue.size());
}

}  // namespace slamd::server
