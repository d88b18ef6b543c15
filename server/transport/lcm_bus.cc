#include "server/transport/lcm_bus.h"

#include <lcm/lcm.h>
#include <poll.h>

#include <cerrno>
#include <ctime>
#include <exception>
#include <map>
#include <mutex>
#include <string>

namespace slamd::server {

struct LcmBus::Impl {
  struct Entry {
    Impl* impl = nullptr;
    MessageCallback callback;
    lcm_subscription_t* subscription = nullptr;
  };

  std::string url;
  int queue_capacity = 0;
  lcm_t* lcm = nullptr;
  std::mutex mutex;  // guards entries (Subscribe/Unsubscribe may come from several threads)
  std::map<std::uint64_t, std::unique_ptr<Entry>> entries;
  std::uint64_t next_id = 1;
  // Exceptions caught in callbacks during the current HandleOnce (only its thread touches these).
  int errors = 0;
  std::string first_error;

  ~Impl() {
    if (lcm != nullptr) lcm_destroy(lcm);  // frees LCM's subscriptions too
  }

  // LCM calls this under C frames: nothing may propagate out of it.
  static void OnMessage(const lcm_recv_buf_t* rbuf, const char* channel, void* user) {
    auto* entry = static_cast<Entry*>(user);
    Impl* impl = entry->impl;
    try {
      entry->callback(channel, std::span<const std::uint8_t>(
                                   static_cast<const std::uint8_t*>(rbuf->data), rbuf->data_size));
    } catch (const std::exception& e) {
      impl->Record(channel, e.what());
    } catch (...) {
      impl->Record(channel, "a non-std exception");
    }
  }

  void Record(const char* channel, const char* what) noexcept {
    try {
      if (errors++ == 0)
        first_error = std::string("callback on channel '") + channel + "' threw: " + what;
    } catch (...) {  // out of memory while formatting: keep the count
    }
  }

  void Remove(std::uint64_t id) {
    std::lock_guard lock(mutex);
    auto it = entries.find(id);
    if (it == entries.end()) return;
    lcm_unsubscribe(lcm, it->second->subscription);
    entries.erase(it);
  }
};

core::Status LcmBusParams::Validate() const {
  if (url.empty()) {
    return core::InvalidArgument(
        "LcmBusParams::url is empty; give one explicitly (e.g. memq:// or "
        "udpm://239.255.76.67:7667?ttl=0)");
  }
  if (udpm_receive_buffer_bytes < 0) {
    return core::InvalidArgument("LcmBusParams::udpm_receive_buffer_bytes = " +
                                 std::to_string(udpm_receive_buffer_bytes) + "; violates >= 0");
  }
  if (queue_capacity < 1) {
    return core::InvalidArgument(
        "LcmBusParams::queue_capacity = " + std::to_string(queue_capacity) + "; violates >= 1");
  }
  return core::Status::Ok();
}

core::Result<std::unique_ptr<LcmBus>> LcmBus::Create(const LcmBusParams& params) {
  SLAMD_RETURN_IF_ERROR(params.Validate());
  auto impl = std::make_shared<Impl>();
  impl->url = params.url;
  if (params.url.rfind("udpm://", 0) == 0 && params.udpm_receive_buffer_bytes > 0 &&
      params.url.find("recv_buf_size=") == std::string::npos) {
    impl->url += (params.url.find('?') == std::string::npos ? "?" : "&");
    impl->url += "recv_buf_size=" + std::to_string(params.udpm_receive_buffer_bytes);
  }
  impl->queue_capacity = params.queue_capacity;
  impl->lcm = lcm_create(impl->url.c_str());
  if (impl->lcm == nullptr) {
    std::string message =
        "LCM could not start on '" + params.url + "' (LCM's own message is on stderr).";
    if (params.url.rfind("udpm://", 0) == 0) {
      message +=
          " udpm:// needs a multicast route: as root run `ip route add 224.0.0.0/4 dev lo` (one "
          "host) or `ip route add 224.0.0.0/4 dev <interface>` (a LAN); check with `ip route "
          "get 239.255.76.67`. Tests run udpm only inside scripts/netns-run.";
    }
    return core::IoError(message);
  }
  return std::unique_ptr<LcmBus>(new LcmBus(std::move(impl)));
}

LcmBus::LcmBus(std::shared_ptr<Impl> impl) : impl_(std::move(impl)) {}
LcmBus::~LcmBus() = default;

const std::string& LcmBus::url() const { return impl_->url; }

core::Status LcmBus::Publish(std::string_view channel, std::span<const std::uint8_t> bytes) {
  SLAMD_RETURN_IF_ERROR(CheckChannelName(channel));
  const std::string name(channel);  // LCM wants a NUL-terminated name
  if (lcm_publish(impl_->lcm, name.c_str(), bytes.data(), static_cast<unsigned>(bytes.size())) !=
      0) {
    return core::IoError("LCM publish on '" + name + "' (" + std::to_string(bytes.size()) +
                         " bytes) failed on " + impl_->url);
  }
  return core::Status::Ok();
}

core::Result<Subscription> LcmBus::Subscribe(std::string_view channel_regex,
                                             MessageCallback callback) {
  if (channel_regex.empty()) return core::InvalidArgument("empty channel pattern");
  if (!callback)
    return core::InvalidArgument("null callback for channel '" + std::string(channel_regex) + "'");
  const std::string pattern(channel_regex);
  auto entry = std::make_unique<Impl::Entry>();
  entry->impl = impl_.get();
  entry->callback = std::move(callback);
  std::uint64_t id;
  {
    std::lock_guard lock(impl_->mutex);
    entry->subscription = lcm_subscribe(impl_->lcm, pattern.c_str(), &Impl::OnMessage, entry.get());
    if (entry->subscription == nullptr) {
      return core::InvalidArgument("LCM refused the channel pattern '" + pattern + "'");
    }
    // Raise LCM's default of 30 queued messages, beyond which it drops silently.
    lcm_subscription_set_queue_capacity(entry->subscription, impl_->queue_capacity);
    id = impl_->next_id++;
    impl_->entries.emplace(id, std::move(entry));
  }
  std::weak_ptr<Impl> weak = impl_;
  return Subscription([weak, id] {
    if (auto impl = weak.lock()) impl->Remove(id);
  });
}

core::Result<int> LcmBus::HandleFor(std::chrono::microseconds timeout) {
  if (timeout.count() < 0) return core::InvalidArgument("HandleFor: timeout must be >= 0");
  // lcm_handle_timeout waits in whole milliseconds: the wait is poll(2) on LCM's descriptor,
  // which becomes readable when a message is ready to dispatch.
  pollfd fd{.fd = lcm_get_fileno(impl_->lcm), .events = POLLIN, .revents = 0};
  const auto seconds = std::chrono::duration_cast<std::chrono::seconds>(timeout);
  const timespec wait{.tv_sec = static_cast<time_t>(seconds.count()),
                      .tv_nsec = static_cast<long>((timeout - seconds).count() * 1000)};
  const int ready = ppoll(&fd, 1, &wait, nullptr);
  if (ready < 0 && errno == EINTR) return 0;  // a signal: an early timeout
  if (ready < 0) return core::IoError("poll on LCM's descriptor failed on " + impl_->url);
  if (ready == 0) return 0;
  impl_->errors = 0;
  impl_->first_error.clear();
  const int rc = lcm_handle_timeout(impl_->lcm, 0);
  if (rc < 0) return core::IoError("LCM failed while receiving on " + impl_->url);
  if (impl_->errors > 0) {
    std::string message = impl_->first_error;
    if (impl_->errors > 1) message += " (and " + std::to_string(impl_->errors - 1) + " more)";
    return core::FailedPrecondition(message + "; callbacks must not throw");
  }
  return rc > 0 ? 1 : 0;
}

}  // namespace slamd::server
