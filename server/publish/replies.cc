#include "server/publish/replies.h"

#include "server/messages/wire_values.h"

namespace slamd::server {
namespace {

slamd::key_t ToWire(const WireKey& k) {
  slamd::key_t out;
  out.robot = k.robot;
  out.kind = static_cast<std::int8_t>(k.kind);
  out.index = static_cast<std::int64_t>(k.index);
  return out;
}

slamd::map_entry_t ToEntry(const MapEntry& e) {
  slamd::map_entry_t out;
  out.index = static_cast<std::int64_t>(e.index);
  out.values = ToValues(e.value);
  out.num_values = static_cast<std::int32_t>(out.values.size());
  out.covariance = ToRowMajor(e.covariance);
  out.num_covariance = static_cast<std::int32_t>(out.covariance.size());
  return out;
}

}  // namespace

void FillQueryReply(const QueryRequest& query, const QueryAnswer& answer,
                    std::int64_t update_sequence, std::int32_t map_pages, std::int64_t now_utime,
                    slamd::query_reply_t* out) {
  out->utime = now_utime;
  out->client = query.client;
  out->request_id = query.request_id;
  out->update_sequence = update_sequence;
  out->status =
      answer.partial ? slamd::query_reply_t::STATUS_PARTIAL : slamd::query_reply_t::STATUS_OK;
  out->error = answer.partial ? answer.error : "";
  out->results.clear();
  for (const VariableAnswer& v : answer.results) {
    slamd::variable_t& r = out->results.emplace_back();
    r.key = ToWire(v.key);
    r.found = v.found;
    if (v.found) r.values = ToValues(v.value);
    r.num_values = static_cast<std::int32_t>(r.values.size());
    r.covariance = ToRowMajor(v.covariance);
    r.num_covariance = static_cast<std::int32_t>(r.covariance.size());
  }
  out->num_results = static_cast<std::int32_t>(out->results.size());
  out->joint_dimension = static_cast<std::int32_t>(answer.joint.rows());
  out->joint_covariance = ToRowMajor(answer.joint);
  out->num_joint_covariance = static_cast<std::int32_t>(out->joint_covariance.size());
  out->map_pages = map_pages;
  out->shards_answering = 1;  // a sharded daemon signs it (query_reply_t.shard)
}

void FillRejectedQueryReply(const QueryRequest& query, const std::string& error,
                            std::int64_t now_utime, slamd::query_reply_t* out) {
  *out = slamd::query_reply_t();
  out->utime = now_utime;
  out->client = query.client;
  out->request_id = query.request_id;
  out->status = slamd::query_reply_t::STATUS_REJECTED;
  out->error = error;
  out->shards_answering = 1;
}

std::vector<slamd::map_t> MapPages(const RobotMap& map, std::int64_t update_sequence,
                                   std::int64_t request_id, std::int64_t now_utime, int max_bytes) {
  slamd::map_t blank;
  blank.utime = now_utime;
  blank.robot = map.robot;
  blank.update_sequence = update_sequence;
  blank.request_id = request_id;
  blank.dimension = map.is3d ? slamd::map_t::DIMENSION_3D : slamd::map_t::DIMENSION_2D;
  blank.num_poses = 0;
  blank.num_landmarks = 0;
  // The fixed part plus the 8-byte fingerprint LCM prepends to the message.
  const int overhead = blank.getEncodedSize();
  std::vector<slamd::map_t> pages(1, blank);
  int bytes = overhead;
  const auto add = [&](const MapEntry& e, bool pose) {
    slamd::map_entry_t entry = ToEntry(e);
    const int size = entry._getEncodedSizeNoHash();  // nested: no fingerprint of its own
    if (bytes + size > max_bytes && (pages.back().num_poses + pages.back().num_landmarks) > 0) {
      pages.push_back(blank);
      bytes = overhead;
    }
    bytes += size;
    slamd::map_t& page = pages.back();
    if (pose) {
      page.poses.push_back(std::move(entry));
      page.num_poses = static_cast<std::int32_t>(page.poses.size());
    } else {
      page.landmarks.push_back(std::move(entry));
      page.num_landmarks = static_cast<std::int32_t>(page.landmarks.size());
    }
  };
  for (const MapEntry& e : map.poses) add(e, true);
  for (const MapEntry& e : map.landmarks) add(e, false);
  for (size_t i = 0; i < pages.size(); ++i) {
    pages[i].page_index = static_cast<std::int32_t>(i);
    pages[i].page_count = static_cast<std::int32_t>(pages.size());
  }
  return pages;
}

void FillReject(const Verdict& verdict, std::string_view channel, std::string_view message_type,
                std::string_view robot, std::int64_t message_utime, std::int64_t now_utime,
                slamd::reject_t* out) {
  out->utime = now_utime;
  out->channel = std::string(channel);
  out->message_type = std::string(message_type);
  out->robot = std::string(robot);
  out->message_utime = message_utime;
  out->reason = static_cast<std::int32_t>(verdict.reason);
  out->detail = verdict.message;
}

}  // namespace slamd::server
