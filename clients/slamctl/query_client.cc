// Query round trip and formatting (see query_client.h).
#include "clients/slamctl/query_client.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "clients/slamctl/dataset_messages.h"
#include "clients/slamctl/json_writer.h"
#include "clients/slamctl/shard_replies.h"

namespace slamd::clients {
namespace {

std::string Number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

std::string Array(const std::vector<double>& v) {
  std::string out = "[";
  for (size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + Number(v[i]);
  return out + "]";
}

std::string Row(const std::vector<double>& v, size_t begin, size_t n) {
  std::string out;
  char buf[32];
  for (size_t i = begin; i < begin + n && i < v.size(); ++i) {
    std::snprintf(buf, sizeof(buf), "%s%.6g", i == begin ? "" : " ", v[i]);
    out += buf;
  }
  return out;
}

// Appends a square row-major matrix, one indented row per line.
void AppendMatrix(const std::vector<double>& m, const char* indent, std::string* out) {
  const size_t n = static_cast<size_t>(std::lround(std::sqrt(static_cast<double>(m.size()))));
  for (size_t r = 0; r < n; ++r) *out += std::string(indent) + Row(m, r * n, n) + "\n";
}

std::string EntryJson(const slamd::map_entry_t& e) {
  return "{\"index\": " + std::to_string(e.index) + ", \"values\": " + Array(e.values) +
         ", \"covariance\": " + Array(e.covariance) + "}";
}

const char* StatusName(std::int8_t status) {
  switch (status) {
    case slamd::query_reply_t::STATUS_OK:
      return "ok";
    case slamd::query_reply_t::STATUS_PARTIAL:
      return "partial";
    case slamd::query_reply_t::STATUS_REJECTED:
      return "rejected";
    default:
      return "unknown";
  }
}

}  // namespace

core::Result<server::WireKey> ParseKey(const std::string& text, const std::string& default_robot) {
  const auto bad = [&](const std::string& why) {
    return core::InvalidArgument("key '" + text + "': " + why +
                                 " (expected ROBOT:xN for a pose or ROBOT:lN for a landmark, or "
                                 "xN / lN with --robot; mN for a landmark of the shared map)");
  };
  server::WireKey key;
  std::string local = text;
  const size_t colon = text.rfind(':');
  if (colon == std::string::npos && text.starts_with('m')) {
    key.kind = server::KeyKind::kMapLandmark;  // robot "": the shared map
  } else {
    if (colon != std::string::npos) {
      key.robot = text.substr(0, colon);
      local = text.substr(colon + 1);
    } else if (default_robot.empty()) {
      return bad("no robot");
    } else {
      key.robot = default_robot;
    }
    if (!IsValidRobotName(key.robot)) return bad("robot name needs 1..64 chars of [A-Za-z0-9_.-]");
    if (local.size() < 2 || (local[0] != 'x' && local[0] != 'l')) return bad("no x or l index");
    key.kind = local[0] == 'x' ? server::KeyKind::kPose : server::KeyKind::kLandmark;
  }
  if (local.size() < 2) return bad("no index");
  const std::string digits = local.substr(1);
  if (digits.find_first_not_of("0123456789") != std::string::npos)
    return bad("index is not a number");
  errno = 0;
  const unsigned long long index = std::strtoull(digits.c_str(), nullptr, 10);
  if (errno != 0 || index > core::kMaxKeyIndex) return bad("index above 2^48-1");
  key.index = index;
  return key;
}

std::string WireKeyToString(const std::string& robot, std::int8_t kind, std::int64_t index) {
  return server::WireKeyName({.robot = robot,
                              .kind = static_cast<server::KeyKind>(kind),
                              .index = static_cast<std::uint64_t>(index)});
}

std::int64_t RandomRequestId() {
  std::random_device device;
  std::uniform_int_distribution<std::int64_t> id(1, (std::int64_t{1} << 62));
  return id(device);
}

core::Result<QueryAnswer> RunQuery(LcmClient& client, const server::ChannelNames& channels,
                                   const slamd::query_t& query, double timeout_s) {
  QueryAnswer answer;
  ShardReplies replies(query.request_id, query.client);
  SLAMD_RETURN_IF_ERROR(client.Subscribe<slamd::query_reply_t>(channels.QueryReply(),
                                                               [&](const slamd::query_reply_t& r) {
                                                                 if (replies.Add(r))
                                                                   answer.reply = replies.merged();
                                                               }));
  SLAMD_RETURN_IF_ERROR(client.Subscribe<slamd::map_t>(channels.Map(), [&](const slamd::map_t& m) {
    if (m.request_id == query.request_id) answer.map_pages.push_back(m);
  }));
  SLAMD_RETURN_IF_ERROR(client.Publish(channels.Inbound<server::QuerySpec>(), query));
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  core::Result<bool> got = client.HandleUntil([&] { return replies.complete(); }, timeout_s);
  if (!got.ok()) return got.status();
  if (!*got) {
    return core::OutOfRange("timed out: no " + replies.Missing() + " on " + channels.QueryReply() +
                            " within " + std::to_string(timeout_s) + " s");
  }
  const double left = timeout_s - std::chrono::duration<double>(Clock::now() - start).count();
  core::Result<bool> pages = client.HandleUntil(
      [&] { return static_cast<int>(answer.map_pages.size()) >= answer.reply.map_pages; },
      std::max(left, 0.0));
  if (!pages.ok()) return pages.status();
  if (!*pages) {
    return core::OutOfRange("timed out: " + std::to_string(answer.map_pages.size()) + " of " +
                            std::to_string(answer.reply.map_pages) + " map_t pages arrived");
  }
  return answer;
}

std::string FormatAnswer(const QueryAnswer& a) {
  const slamd::query_reply_t& r = a.reply;
  std::string out = "update " + std::to_string(r.update_sequence) + "  status " +
                    StatusName(r.status) + (r.error.empty() ? "" : " (" + r.error + ")") + "\n";
  for (const slamd::variable_t& v : r.results) {
    out += WireKeyToString(v.key.robot, v.key.kind, v.key.index);
    if (!v.found) {
      out += "  not found\n";
      continue;
    }
    out += "  " + Row(v.values, 0, v.values.size()) + "\n";
    if (!v.covariance.empty()) {
      out += "  covariance:\n";
      AppendMatrix(v.covariance, "    ", &out);
    }
  }
  if (r.joint_dimension > 0) {
    out += "joint covariance (" + std::to_string(r.joint_dimension) + "x" +
           std::to_string(r.joint_dimension) + "):\n";
    AppendMatrix(r.joint_covariance, "  ", &out);
  }
  for (const slamd::map_t& m : a.map_pages) {
    out += "map " + m.robot + (m.shard.empty() ? "" : " (shard " + m.shard + ")") + " page " +
           std::to_string(m.page_index + 1) + "/" + std::to_string(m.page_count) + ": " +
           std::to_string(m.num_poses) + " poses, " + std::to_string(m.num_landmarks) +
           " landmarks\n";
    for (const slamd::map_entry_t& e : m.poses) {
      out += "  x" + std::to_string(e.index) + "  " + Row(e.values, 0, e.values.size()) + "\n";
    }
    for (const slamd::map_entry_t& e : m.landmarks) {
      out += "  l" + std::to_string(e.index) + "  " + Row(e.values, 0, e.values.size()) + "\n";
    }
  }
  return out;
}

std::string AnswerJson(const QueryAnswer& a) {
  const slamd::query_reply_t& r = a.reply;
  std::string results = "[";
  for (size_t i = 0; i < r.results.size(); ++i) {
    const slamd::variable_t& v = r.results[i];
    results += (i ? ", " : "") + std::string("{\"key\": ") +
               JsonQuote(WireKeyToString(v.key.robot, v.key.kind, v.key.index)) +
               ", \"found\": " + (v.found ? "true" : "false") + ", \"values\": " + Array(v.values) +
               ", \"covariance\": " + Array(v.covariance) + "}";
  }
  results += "]";
  std::string map = "[";
  for (size_t i = 0; i < a.map_pages.size(); ++i) {
    const slamd::map_t& m = a.map_pages[i];
    std::string poses = "[", landmarks = "[";
    for (size_t k = 0; k < m.poses.size(); ++k) poses += (k ? ", " : "") + EntryJson(m.poses[k]);
    for (size_t k = 0; k < m.landmarks.size(); ++k) {
      landmarks += (k ? ", " : "") + EntryJson(m.landmarks[k]);
    }
    map += (i ? ", " : "") + std::string("{\"robot\": ") + JsonQuote(m.robot) +
           ", \"shard\": " + JsonQuote(m.shard) + ", \"page\": " + std::to_string(m.page_index) +
           ", \"page_count\": " + std::to_string(m.page_count) + ", \"poses\": " + poses +
           "], \"landmarks\": " + landmarks + "]}";
  }
  map += "]";
  return "{\"request_id\": " + std::to_string(r.request_id) +
         ", \"update_sequence\": " + std::to_string(r.update_sequence) +
         ", \"status\": " + JsonQuote(StatusName(r.status)) + ", \"error\": " + JsonQuote(r.error) +
         ", \"results\": " + results +
         ", \"joint_covariance\": {\"dimension\": " + std::to_string(r.joint_dimension) +
         ", \"values\": " + Array(r.joint_covariance) + "}, \"map\": " + map + "}";
}

}  // namespace slamd::clients
