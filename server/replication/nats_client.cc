#include "server/replication/nats_client.h"

#include <nats/nats.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <sstream>

#include "core/base/param_check.h"

namespace slamd::server {
namespace {

std::string JoinServers(const std::vector<std::string>& servers) {
  std::string all;
  for (const std::string& u : servers) all += (all.empty() ? "" : ",") + u;
  return all;
}

}  // namespace

jsOptions NatsWait(int wait_ms) {
  jsOptions jo;
  jsOptions_Init(&jo);
  jo.Wait = wait_ms;
  return jo;
}

core::Result<StreamRange> OpenStream(jsCtx* js, const StreamSpec& spec) {
  jsOptions jo = NatsWait(spec.wait_ms);
  jsStreamInfo* si = nullptr;
  jsErrCode jerr = static_cast<jsErrCode>(0);
  natsStatus s = js_GetStreamInfo(&si, js, spec.name.c_str(), &jo, &jerr);
  if (s == NATS_NOT_FOUND) {
    jsStreamConfig cfg;
    jsStreamConfig_Init(&cfg);
    const char* subjects[] = {spec.subject.c_str()};
    cfg.Name = spec.name.c_str();
    cfg.Subjects = subjects;
    cfg.SubjectsLen = 1;
    cfg.Storage = js_FileStorage;
    cfg.Replicas = spec.replicas;
    cfg.Duplicates = std::int64_t{spec.duplicate_window_s} * 1000 * 1000 * 1000;
    jerr = static_cast<jsErrCode>(0);
    s = js_AddStream(&si, js, &cfg, &jo, &jerr);
    if (s != NATS_OK) return NatsStatus(("cannot create stream " + spec.name).c_str(), s, jerr);
  } else if (s != NATS_OK) {
    return NatsStatus(("cannot read stream " + spec.name).c_str(), s, jerr);
  }
  const bool same_subject = si->Config->SubjectsLen == 1 && spec.subject == si->Config->Subjects[0];
  const StreamRange range{.first = static_cast<std::int64_t>(si->State.FirstSeq),
                          .last = static_cast<std::int64_t>(si->State.LastSeq),
                          .bytes = static_cast<std::int64_t>(si->State.Bytes)};
  jsStreamInfo_Destroy(si);
  if (!same_subject) {
    return core::FailedPrecondition(
        "stream " + spec.name + " exists and does not capture exactly the subject " + spec.subject);
  }
  return range;
}

core::Result<std::int64_t> PublishToStream(jsCtx* js, const StreamMessage& message, int wait_ms,
                                           const std::string& what, int* js_error) {
  natsMsg* m = nullptr;
  natsStatus s = natsMsg_Create(&m, message.subject.c_str(), nullptr, message.payload.data(),
                                static_cast<int>(message.payload.size()));
  for (const auto& [key, value] : message.headers) {
    if (s == NATS_OK) s = natsMsgHeader_Set(m, key, value.c_str());
  }
  jsPubOptions po;
  jsPubOptions_Init(&po);
  po.MaxWait = wait_ms;
  jsPubAck* ack = nullptr;
  jsErrCode jerr = static_cast<jsErrCode>(0);
  if (s == NATS_OK) s = js_PublishMsg(&ack, js, m, &po, &jerr);
  natsMsg_Destroy(m);
  *js_error = static_cast<int>(jerr);
  if (s != NATS_OK) return NatsStatus(what.c_str(), s, jerr);
  const auto sequence = static_cast<std::int64_t>(ack->Sequence);
  jsPubAck_Destroy(ack);
  return sequence;
}

core::Status PurgeStreamBefore(jsCtx* js, const std::string& name, std::int64_t sequence,
                               int wait_ms) {
  // Nothing is before the first message (and the server reads a purge to 1 as one of all).
  if (sequence <= 1) return core::Status::Ok();
  jsOptions jo = NatsWait(wait_ms);
  jo.Stream.Purge.Sequence = static_cast<std::uint64_t>(sequence);
  jsErrCode jerr = static_cast<jsErrCode>(0);
  const natsStatus s = js_PurgeStream(js, name.c_str(), &jo, &jerr);
  if (s != NATS_OK) {
    return NatsStatus(
        ("cannot truncate stream " + name + " before message " + std::to_string(sequence)).c_str(),
        s, jerr);
  }
  return core::Status::Ok();
}

core::Status NatsOptions::Validate() const {
  if (servers.empty()) return core::InvalidArgument("NatsOptions::servers: empty");
  for (const std::string& s : servers) {
    if (s.rfind("nats://", 0) != 0) {
      return core::InvalidArgument("NatsOptions::servers: '" + s + "' is not a nats:// URL");
    }
  }
  SLAMD_PARAM_CHECK(NatsOptions, connect_timeout_ms, >=, 1);
  SLAMD_PARAM_CHECK(NatsOptions, reconnect_wait_ms, >=, 1);
  return core::Status::Ok();
}

bool IsNatsName(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
  });
}

bool IsNatsSubject(const std::string& subject) {
  if (subject.empty()) return false;
  std::stringstream in(subject);
  std::string token;
  while (std::getline(in, token, '.')) {
    if (!IsNatsName(token)) return false;
  }
  return subject.back() != '.';
}

std::vector<std::string> SplitServers(const std::string& comma_separated) {
  std::vector<std::string> out;
  std::stringstream in(comma_separated);
  std::string item;
  while (std::getline(in, item, ',')) {
    const size_t b = item.find_first_not_of(' ');
    const size_t e = item.find_last_not_of(' ');
    if (b != std::string::npos) out.push_back(item.substr(b, e - b + 1));
  }
  return out;
}

core::Status NatsStatus(const char* what, int nats_status, int js_error) {
  const auto s = static_cast<natsStatus>(nats_status);
  if (s == NATS_OK) return core::Status::Ok();
  std::string m = std::string(what) + ": " + natsStatus_GetText(s);
  if (js_error != 0) m += " (JetStream error " + std::to_string(js_error) + ")";
  const char* detail = nats_GetLastError(nullptr);  // this thread's last libnats error
  if (detail != nullptr && *detail != '\0' && std::strcmp(detail, natsStatus_GetText(s)) != 0) {
    m += std::string(": ") + detail;
  }
  switch (s) {
    case NATS_TIMEOUT:
    case NATS_NO_SERVER:
    case NATS_NO_RESPONDERS:
    case NATS_CONNECTION_CLOSED:
    case NATS_CONNECTION_DISCONNECTED:
    case NATS_STALE_CONNECTION:
    case NATS_IO_ERROR:
      return core::Unavailable(m);
    default:
      return core::IoError(m);
  }
}

core::Result<std::unique_ptr<NatsClient>> NatsClient::Connect(const NatsOptions& options) {
  SLAMD_RETURN_IF_ERROR(options.Validate());
  natsOptions* opts = nullptr;
  std::vector<const char*> urls;
  for (const std::string& s : options.servers) urls.push_back(s.c_str());
  natsStatus s = natsOptions_Create(&opts);
  if (s == NATS_OK) s = natsOptions_SetServers(opts, urls.data(), static_cast<int>(urls.size()));
  if (s == NATS_OK) s = natsOptions_SetTimeout(opts, options.connect_timeout_ms);
  if (s == NATS_OK) s = natsOptions_SetMaxReconnect(opts, -1);
  if (s == NATS_OK) s = natsOptions_SetReconnectWait(opts, options.reconnect_wait_ms);
  // Whichever server answers first, not always the first listed.
  if (s == NATS_OK) s = natsOptions_SetNoRandomize(opts, false);
  natsConnection* nc = nullptr;
  if (s == NATS_OK) s = natsConnection_Connect(&nc, opts);
  natsOptions_Destroy(opts);
  if (s != NATS_OK) {
    return NatsStatus(("cannot connect to NATS at " + JoinServers(options.servers)).c_str(), s);
  }
  jsCtx* js = nullptr;
  s = natsConnection_JetStream(&js, nc, nullptr);
  if (s != NATS_OK) {
    natsConnection_Destroy(nc);
    return NatsStatus("cannot open JetStream", s);
  }
  return std::unique_ptr<NatsClient>(new NatsClient(nc, js));
}

struct NatsClient::Subscription {
  MessageCallback on_message;
  natsSubscription* sub = nullptr;
};

NatsClient::NatsClient(natsConnection* nc, jsCtx* js) : nc_(nc), js_(js) {}

core::Status NatsClient::Publish(const std::string& subject, std::span<const std::uint8_t> bytes) {
  const std::int64_t max = natsConnection_GetMaxPayload(nc_);
  if (static_cast<std::int64_t>(bytes.size()) > max) {
    return core::InvalidArgument(
        "NATS publish on " + subject + ": " + std::to_string(bytes.size()) +
        " bytes, more than the server's max_payload of " + std::to_string(max));
  }
  return NatsStatus(
      ("NATS publish on " + subject).c_str(),
      natsConnection_Publish(nc_, subject.c_str(), bytes.data(), static_cast<int>(bytes.size())));
}

core::Status NatsClient::Subscribe(const std::string& subject, MessageCallback on_message) {
  auto holder = std::make_unique<Subscription>();
  holder->on_message = std::move(on_message);
  const auto deliver = [](natsConnection*, natsSubscription*, natsMsg* msg, void* closure) {
    const auto* data = reinterpret_cast<const std::uint8_t*>(natsMsg_GetData(msg));
    static_cast<Subscription*>(closure)->on_message(
        std::span(data, static_cast<std::size_t>(natsMsg_GetDataLength(msg))));
    natsMsg_Destroy(msg);
  };
  SLAMD_RETURN_IF_ERROR(NatsStatus(
      ("NATS subscribe to " + subject).c_str(),
      natsConnection_Subscribe(&holder->sub, nc_, subject.c_str(), deliver, holder.get())));
  subscriptions_.push_back(std::move(holder));
  return core::Status::Ok();
}

NatsClient::~NatsClient() {
  for (const auto& s : subscriptions_) {
    natsSubscription_Unsubscribe(s->sub);
    natsSubscription_Destroy(s->sub);
  }
  jsCtx_Destroy(js_);
  natsConnection_Close(nc_);
  natsConnection_Destroy(nc_);
}

}  // namespace slamd::server
