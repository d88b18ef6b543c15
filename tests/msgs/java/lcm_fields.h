// The C++ side of the spy decode test's comparison (spy_decode_netns_test.cc): every slamd LCM
// message flattened to fields by path as C++ decodes it, every slamd type's fingerprint, and a
// recorder of the bus. The Java side, what SpyDecode printed, is read by spy_output.h.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <string>
#include <type_traits>
#include <vector>

#include "slamd/camera_info_t.hpp"
#include "slamd/estimate_t.hpp"
#include "slamd/frame_observations_t.hpp"
#include "slamd/key_t.hpp"
#include "slamd/landmark_observation_t.hpp"
#include "slamd/loop_closure_t.hpp"
#include "slamd/map_entry_t.hpp"
#include "slamd/map_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/query_reply_t.hpp"
#include "slamd/query_t.hpp"
#include "slamd/reject_t.hpp"
#include "slamd/remove_factor_t.hpp"
#include "slamd/shard_summary_t.hpp"
#include "slamd/status_t.hpp"
#include "slamd/variable_t.hpp"

namespace slamd::spy_test {

// A message's fields by path ("values[2]", "results[0].key.robot"), as SpyDecode prints them.
using Fields = std::map<std::string, std::string>;

// ---- The C++ side of the same flattening --------------------------------------------------

inline std::string Join(const std::string& path, const char* name) {
  return path.empty() ? name : path + "." + name;
}
inline void Put(Fields& f, const std::string& path, const std::string& v) { f[path] = v; }
inline void Put(Fields& f, const std::string& path, bool v) { f[path] = v ? "true" : "false"; }
inline void Put(Fields& f, const std::string& path, double v) {
  char text[40];
  std::snprintf(text, sizeof text, "%.17g", v);
  f[path] = text;
}
template <typename T>
requires std::is_integral_v<T>
inline void Put(Fields& f, const std::string& path, T v) {
  f[path] = std::to_string(static_cast<std::int64_t>(v));
}
inline void Put(Fields& f, const std::string& path, const slamd::key_t& m);
inline void Put(Fields& f, const std::string& path, const slamd::map_entry_t& m);
inline void Put(Fields& f, const std::string& path, const slamd::variable_t& m);
template <typename T>
inline void Put(Fields& f, const std::string& path, const std::vector<T>& v) {
  for (size_t i = 0; i < v.size(); ++i) Put(f, path + "[" + std::to_string(i) + "]", v[i]);
}

template <typename T, std::size_t N>
inline void Put(Fields& f, const std::string& path, const T (&v)[N]) {
  for (std::size_t i = 0; i < N; ++i) Put(f, path + "[" + std::to_string(i) + "]", v[i]);
}

#define PUT(field) Put(f, Join(path, #field), m.field)
// LCM's boolean is an int8_t in C++, a boolean in Java.
#define PUT_BOOL(field) Put(f, Join(path, #field), m.field != 0)

inline void Put(Fields& f, const std::string& path, const slamd::key_t& m) {
  PUT(robot), PUT(kind), PUT(index);
}
inline void Put(Fields& f, const std::string& path, const slamd::map_entry_t& m) {
  PUT(index), PUT(num_values), PUT(values), PUT(num_covariance), PUT(covariance);
}
inline void Put(Fields& f, const std::string& path, const slamd::variable_t& m) {
  PUT(key), PUT_BOOL(found), PUT(num_values), PUT(values), PUT(num_covariance), PUT(covariance);
}
inline void Put(Fields& f, const std::string& path, const slamd::estimate_t& m) {
  PUT(utime), PUT(robot), PUT(update_sequence), PUT(pose_index), PUT(dimension);
  PUT(num_values), PUT(values), PUT(num_covariance), PUT(covariance);
  PUT(measurement_utime), PUT(latency_us);
}
inline void Put(Fields& f, const std::string& path, const slamd::camera_info_t& m) {
  PUT(utime), PUT(robot), PUT(camera_id), PUT(from_pose_index), PUT(model);
  PUT(num_intrinsics), PUT(intrinsics), PUT(body_t_camera), PUT(body_q_camera);
  PUT(width), PUT(height);
}
inline void Put(Fields& f, const std::string& path, const slamd::frame_observations_t& m) {
  PUT(utime), PUT(robot), PUT(pose_index), PUT(camera_id), PUT(kind), PUT(landmark_namespace);
  PUT(num_features), PUT(landmark_ids), PUT(num_values), PUT(values), PUT(num_sigmas);
  PUT(sigmas), PUT(num_covariance), PUT(covariance), PUT(robust_kernel), PUT(robust_parameter);
}
inline void Put(Fields& f, const std::string& path, const slamd::landmark_observation_t& m) {
  PUT(utime), PUT(robot), PUT(pose_index), PUT(landmark_id), PUT(kind), PUT(landmark_namespace);
  PUT(num_values), PUT(values), PUT(num_covariance), PUT(covariance);
}
inline void Put(Fields& f, const std::string& path, const slamd::loop_closure_t& m) {
  PUT(utime), PUT(robot_a), PUT(pose_a), PUT(robot_b), PUT(pose_b), PUT(dimension);
  PUT(num_values), PUT(values), PUT(num_covariance), PUT(covariance);
  PUT(robust_kernel), PUT(robust_parameter);
}
inline void Put(Fields& f, const std::string& path, const slamd::map_t& m) {
  PUT(utime), PUT(robot), PUT(shard), PUT(update_sequence), PUT(request_id), PUT(page_index);
  PUT(page_count), PUT(dimension), PUT(num_poses), PUT(poses), PUT(num_landmarks);
  PUT(landmarks);
}
inline void Put(Fields& f, const std::string& path, const slamd::odometry_t& m) {
  PUT(utime), PUT(robot), PUT(from_index), PUT(to_index), PUT(dimension);
  PUT(num_values), PUT(values), PUT(num_covariance), PUT(covariance);
}
inline void Put(Fields& f, const std::string& path, const slamd::prior_t& m) {
  PUT(utime), PUT(robot), PUT(pose_index), PUT(kind);
  PUT(num_values), PUT(values), PUT(num_covariance), PUT(covariance);
}
inline void Put(Fields& f, const std::string& path, const slamd::query_reply_t& m) {
  PUT(utime), PUT(client), PUT(request_id), PUT(update_sequence), PUT(status), PUT(error);
  PUT(num_results), PUT(results), PUT(joint_dimension), PUT(num_joint_covariance);
  PUT(joint_covariance), PUT(map_pages), PUT(shard), PUT(shards_answering);
}
inline void Put(Fields& f, const std::string& path, const slamd::query_t& m) {
  PUT(utime), PUT(client), PUT(request_id), PUT(num_keys), PUT(keys);
  PUT_BOOL(want_marginals), PUT_BOOL(want_joint_marginal), PUT(map_robot);
}
inline void Put(Fields& f, const std::string& path, const slamd::reject_t& m) {
  PUT(utime), PUT(channel), PUT(message_type), PUT(robot), PUT(message_utime), PUT(reason);
  PUT(detail);
}
inline void Put(Fields& f, const std::string& path, const slamd::remove_factor_t& m) {
  PUT(utime), PUT(target), PUT(robot_a), PUT(index_a), PUT(robot_b), PUT(index_b), PUT(kind);
}
inline void Put(Fields& f, const std::string& path, const slamd::shard_summary_t& m) {
  PUT(utime), PUT(from_shard), PUT(to_shard), PUT(dimension), PUT(num_keys), PUT(keys);
  PUT(num_values), PUT(values), PUT(rows), PUT(b), PUT(num_a), PUT(a);
  PUT(num_map_landmarks), PUT(map_landmarks);
}
inline void Put(Fields& f, const std::string& path, const slamd::status_t& m) {
  PUT(utime), PUT(update_sequence), PUT(rebuilds), PUT(num_robots), PUT(num_variables);
  PUT(num_factors), PUT(messages_received), PUT(messages_accepted), PUT(messages_rejected);
  PUT(messages_already_held), PUT(decode_errors), PUT(landmark_tracks), PUT(track_observations);
  PUT(landmarks_dropped), PUT(removed_variables), PUT(merged_poses);
  PUT(reduced_left_out), PUT(rss_bytes), PUT(heap_in_use_bytes);
  PUT(num_rejects_by_reason);
  PUT(rejects_by_reason), PUT(queue_depth), PUT(queue_peak), PUT(queue_capacity);
  PUT(update_latency_p50_us), PUT(update_latency_p90_us), PUT(update_latency_p99_us);
  PUT(update_latency_max_us), PUT(publish_latency_p50_us), PUT(publish_latency_p99_us);
  PUT(journal_records), PUT(journal_bytes), PUT(journal_disk_bytes), PUT(journal_segments);
  PUT_BOOL(replication_held), PUT(replication_holds), PUT(replicated_batches),
      PUT(replication_pending_bytes), PUT(shard_not_owned), PUT(shard_summaries_sent),
      PUT(shard_summary_bytes), PUT(shard_queries_forwarded), PUT(shard_summaries_incomplete);
  PUT(chi2), PUT(residual_dimension), PUT_BOOL(settled);
}

#undef PUT
#undef PUT_BOOL

// Every slamd type: its Java name, C++ fingerprint and (messages only) a decoder of raw bytes.
struct TypeInfo {
  std::string java_name;
  std::int64_t fingerprint;
  std::function<bool(const lcm::ReceiveBuffer&, Fields*)> decode;
};

template <typename M>
inline TypeInfo Type(const char* name, bool message = true) {
  TypeInfo t{std::string("slamd.") + name, M::getHash(), nullptr};
  if (message) {
    t.decode = [](const lcm::ReceiveBuffer& buf, Fields* f) {
      M m;
      if (m.decode(buf.data, 0, buf.data_size) != static_cast<int>(buf.data_size)) return false;
      Put(*f, "", m);
      return true;
    };
  }
  return t;
}

inline std::vector<TypeInfo> AllTypes() {
  return {Type<slamd::camera_info_t>("camera_info_t"),
          Type<slamd::estimate_t>("estimate_t"),
          Type<slamd::frame_observations_t>("frame_observations_t"),
          Type<slamd::key_t>("key_t", false),
          Type<slamd::landmark_observation_t>("landmark_observation_t"),
          Type<slamd::loop_closure_t>("loop_closure_t"),
          Type<slamd::map_entry_t>("map_entry_t", false),
          Type<slamd::map_t>("map_t"),
          Type<slamd::odometry_t>("odometry_t"),
          Type<slamd::prior_t>("prior_t"),
          Type<slamd::query_reply_t>("query_reply_t"),
          Type<slamd::query_t>("query_t"),
          Type<slamd::reject_t>("reject_t"),
          Type<slamd::remove_factor_t>("remove_factor_t"),
          Type<slamd::shard_summary_t>("shard_summary_t"),
          Type<slamd::status_t>("status_t"),
          Type<slamd::variable_t>("variable_t", false)};
}

// A message as decoded on one side: channel, type name, fields.
struct Decoded {
  std::string channel;
  std::string type;
  Fields fields;
};

// Everything on the bus, decoded in C++ by fingerprint (as SpyDecode does in Java).
struct Recorder {
  std::vector<TypeInfo> types = AllTypes();
  std::vector<Decoded> messages;
  void OnMessage(const lcm::ReceiveBuffer* buf, const std::string& channel) {
    Decoded d{channel, "?", {}};
    std::int64_t fingerprint = 0;
    if (buf->data_size >= 8) {
      const auto* b = static_cast<const std::uint8_t*>(buf->data);
      for (int i = 0; i < 8; ++i) fingerprint = (fingerprint << 8) | b[i];
    }
    for (const TypeInfo& t : types) {
      if (t.decode && t.fingerprint == fingerprint) {
        d.type = t.java_name;
        EXPECT_TRUE(t.decode(*buf, &d.fields)) << channel << ": C++ decode of " << t.java_name;
      }
    }
    messages.push_back(std::move(d));
  }
  int Count(const std::string& channel) const {
    int n = 0;
    for (const Decoded& d : messages) n += d.channel == channel;
    return n;
  }
};

}  // namespace slamd::spy_test
