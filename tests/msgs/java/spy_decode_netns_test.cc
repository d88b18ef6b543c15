// LCM's own Java decoder agrees with slamd's encoding. SpyDecode (SpyDecode.java: lcm-spy's type
// lookup and decoding, with the Java classes lcm-gen made of msgs/lcm, slamd_lcm_types.jar)
// listens on the bus while this test streams a robot's prior, odometry, a landmark, a loop
// closure and its retraction, a bad odometry and a query to the real `slamd` over udpm (ttl=0,
// inside the private network namespace of scripts/netns-run). Every message on the bus, ours
// and slamd's (estimate_t, status_t, reject_t, query_reply_t, map_t), must come out of the Java
// decoder with the same fields, bit for bit, as the C++ decoder reads them; and the Java type
// scan must find every slamd type with the C++ fingerprint. Skipped (exit 77) when Java or the
// jar was not built.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#include "slamd/estimate_t.hpp"
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
#include "slamd/status_t.hpp"
#include "slamd/variable_t.hpp"
#include "tests/testing/datasets.h"
#include "tests/testing/processes.h"

namespace slamd {
namespace {

using testing::OnlyLoopback;
using testing::Spawn;
using testing::WaitExit;

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";
using Clock = std::chrono::steady_clock;

// A message's fields by path ("values[2]", "results[0].key.robot"), as SpyDecode prints them.
using Fields = std::map<std::string, std::string>;

// ---- The C++ side of the same flattening --------------------------------------------------

std::string Join(const std::string& path, const char* name) {
  return path.empty() ? name : path + "." + name;
}
void Put(Fields& f, const std::string& path, const std::string& v) { f[path] = v; }
void Put(Fields& f, const std::string& path, bool v) { f[path] = v ? "true" : "false"; }
void Put(Fields& f, const std::string& path, double v) {
  char text[40];
  std::snprintf(text, sizeof text, "%.17g", v);
  f[path] = text;
}
template <typename T>
requires std::is_integral_v<T>
void Put(Fields& f, const std::string& path, T v) {
  f[path] = std::to_string(static_cast<std::int64_t>(v));
}
void Put(Fields& f, const std::string& path, const slamd::key_t& m);
void Put(Fields& f, const std::string& path, const slamd::map_entry_t& m);
void Put(Fields& f, const std::string& path, const slamd::variable_t& m);
template <typename T>
void Put(Fields& f, const std::string& path, const std::vector<T>& v) {
  for (size_t i = 0; i < v.size(); ++i) Put(f, path + "[" + std::to_string(i) + "]", v[i]);
}

#define PUT(field) Put(f, Join(path, #field), m.field)
// LCM's boolean is an int8_t in C++, a boolean in Java.
#define PUT_BOOL(field) Put(f, Join(path, #field), m.field != 0)

void Put(Fields& f, const std::string& path, const slamd::key_t& m) {
  PUT(robot), PUT(kind), PUT(index);
}
void Put(Fields& f, const std::string& path, const slamd::map_entry_t& m) {
  PUT(index), PUT(num_values), PUT(values), PUT(num_covariance), PUT(covariance);
}
void Put(Fields& f, const std::string& path, const slamd::variable_t& m) {
  PUT(key), PUT_BOOL(found), PUT(num_values), PUT(values), PUT(num_covariance), PUT(covariance);
}
void Put(Fields& f, const std::string& path, const slamd::estimate_t& m) {
  PUT(utime), PUT(robot), PUT(update_sequence), PUT(pose_index), PUT(dimension);
  PUT(num_values), PUT(values), PUT(num_covariance), PUT(covariance);
  PUT(measurement_utime), PUT(latency_us);
}
void Put(Fields& f, const std::string& path, const slamd::landmark_observation_t& m) {
  PUT(utime), PUT(robot), PUT(pose_index), PUT(landmark_id), PUT(kind);
  PUT(num_values), PUT(values), PUT(num_covariance), PUT(covariance);
}
void Put(Fields& f, const std::string& path, const slamd::loop_closure_t& m) {
  PUT(utime), PUT(robot_a), PUT(pose_a), PUT(robot_b), PUT(pose_b), PUT(dimension);
  PUT(num_values), PUT(values), PUT(num_covariance), PUT(covariance);
  PUT(robust_kernel), PUT(robust_parameter);
}
void Put(Fields& f, const std::string& path, const slamd::map_t& m) {
  PUT(utime), PUT(robot), PUT(update_sequence), PUT(request_id), PUT(page_index);
  PUT(page_count), PUT(dimension), PUT(num_poses), PUT(poses), PUT(num_landmarks);
  PUT(landmarks);
}
void Put(Fields& f, const std::string& path, const slamd::odometry_t& m) {
  PUT(utime), PUT(robot), PUT(from_index), PUT(to_index), PUT(dimension);
  PUT(num_values), PUT(values), PUT(num_covariance), PUT(covariance);
}
void Put(Fields& f, const std::string& path, const slamd::prior_t& m) {
  PUT(utime), PUT(robot), PUT(pose_index), PUT(kind);
  PUT(num_values), PUT(values), PUT(num_covariance), PUT(covariance);
}
void Put(Fields& f, const std::string& path, const slamd::query_reply_t& m) {
  PUT(utime), PUT(client), PUT(request_id), PUT(update_sequence), PUT(status), PUT(error);
  PUT(num_results), PUT(results), PUT(joint_dimension), PUT(num_joint_covariance);
  PUT(joint_covariance), PUT(map_pages);
}
void Put(Fields& f, const std::string& path, const slamd::query_t& m) {
  PUT(utime), PUT(client), PUT(request_id), PUT(num_keys), PUT(keys);
  PUT_BOOL(want_marginals), PUT_BOOL(want_joint_marginal), PUT(map_robot);
}
void Put(Fields& f, const std::string& path, const slamd::reject_t& m) {
  PUT(utime), PUT(channel), PUT(message_type), PUT(robot), PUT(message_utime), PUT(reason);
  PUT(detail);
}
void Put(Fields& f, const std::string& path, const slamd::remove_factor_t& m) {
  PUT(utime), PUT(target), PUT(robot_a), PUT(index_a), PUT(robot_b), PUT(index_b), PUT(kind);
}
void Put(Fields& f, const std::string& path, const slamd::status_t& m) {
  PUT(utime), PUT(update_sequence), PUT(rebuilds), PUT(num_robots), PUT(num_variables);
  PUT(num_factors), PUT(messages_received), PUT(messages_accepted), PUT(messages_rejected);
  PUT(messages_already_held), PUT(decode_errors), PUT(num_rejects_by_reason);
  PUT(rejects_by_reason), PUT(queue_depth), PUT(queue_peak), PUT(queue_capacity);
  PUT(update_latency_p50_us), PUT(update_latency_p90_us), PUT(update_latency_p99_us);
  PUT(update_latency_max_us), PUT(publish_latency_p50_us), PUT(publish_latency_p99_us);
  PUT(journal_records), PUT(journal_bytes), PUT(chi2), PUT(residual_dimension), PUT_BOOL(settled);
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
TypeInfo Type(const char* name, bool message = true) {
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

std::vector<TypeInfo> AllTypes() {
  return {Type<slamd::estimate_t>("estimate_t"),
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

// ---- SpyDecode's output --------------------------------------------------------------------

std::string Unescape(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '\\' && i + 1 < s.size()) {
      const char c = s[++i];
      out += c == 't' ? '\t' : c == 'n' ? '\n' : c;
    } else {
      out += s[i];
    }
  }
  return out;
}

struct SpyOutput {
  bool ready = false;
  std::map<std::string, std::int64_t> types;  // LCM types found on the class path
  std::vector<Decoded> messages;
  std::vector<std::string> other_lines;
};

// Only messages on channels that start with `prefix` (not liblcm's LCM_SELF_TEST, say).
SpyOutput ReadSpyOutput(const std::string& path, const std::string& prefix = "") {
  SpyOutput out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> parts;
    for (size_t start = 0;;) {
      const size_t tab = line.find('\t', start);
      parts.push_back(line.substr(start, tab - start));
      if (tab == std::string::npos) break;
      start = tab + 1;
    }
    if (line == "ready") {
      out.ready = true;
    } else if (parts.size() == 3 && parts[0] == "lcmtype") {
      out.types[parts[1]] = std::strtoll(parts[2].c_str(), nullptr, 10);
    } else if (parts.size() >= 2 && parts[0].starts_with("@channel=") &&
               parts[1].starts_with("@type=")) {
      Decoded d{Unescape(parts[0].substr(9)), parts[1].substr(6), {}};
      if (!d.channel.starts_with(prefix)) continue;
      for (size_t i = 2; i < parts.size(); ++i) {
        const size_t eq = parts[i].find('=');
        d.fields[parts[i].substr(0, eq)] =
            eq == std::string::npos ? "" : Unescape(parts[i].substr(eq + 1));
      }
      out.messages.push_back(std::move(d));
    } else {
      out.other_lines.push_back(line);
    }
  }
  return out;
}

// Same value: equal text, or both numbers that read back to the same double (Java's
// Double.toString and C++'s %.17g print the same double differently).
bool SameValue(const std::string& a, const std::string& b) {
  if (a == b) return true;
  if (a.empty() || b.empty()) return false;
  char* end_a = nullptr;
  char* end_b = nullptr;
  const double x = std::strtod(a.c_str(), &end_a);
  const double y = std::strtod(b.c_str(), &end_b);
  return *end_a == '\0' && *end_b == '\0' && x == y;
}

double Num(const Fields& f, const std::string& key) {
  const auto it = f.find(key);
  if (it == f.end()) {
    ADD_FAILURE() << "no field " << key;
    return std::nan("");
  }
  return std::strtod(it->second.c_str(), nullptr);
}

std::string Str(const Fields& f, const std::string& key) {
  const auto it = f.find(key);
  return it == f.end() ? "<missing " + key + ">" : it->second;
}

// The last message SpyDecode printed on `channel` for which `pred` holds (nullptr if none).
const Fields* LastOn(const SpyOutput& spy, const std::string& channel,
                     const std::function<bool(const Fields&)>& pred = nullptr) {
  const Fields* found = nullptr;
  for (const Decoded& d : spy.messages) {
    if (d.channel == channel && (!pred || pred(d.fields))) found = &d.fields;
  }
  return found;
}

// Kills (SIGKILL) and reaps a child still running when the test ends, early or not.
struct ChildGuard {
  pid_t pid;
  ~ChildGuard() {
    if (pid > 0) {
      kill(pid, SIGKILL);
      WaitExit(pid);
    }
  }
};

// Row-major diagonal covariance.
std::vector<double> Diagonal(std::vector<double> sigmas) {
  const size_t n = sigmas.size();
  std::vector<double> c(n * n, 0.0);
  for (size_t i = 0; i < n; ++i) c[i * n + i] = sigmas[i] * sigmas[i];
  return c;
}

TEST(SpyDecodeNetnsTest, JavaDecoderAgreesWithSlamdOnEveryMessage) {
  const std::string java = SLAMD_JAVA;
  const std::string classpath = SLAMD_SPY_DECODE_CLASSPATH;
  if (java.empty() || access(java.c_str(), X_OK) != 0) {
    std::fprintf(stderr,
                 "no Java (javac/java and lcm.jar were not found at configure time); "
                 "skipping\n");
    std::exit(77);
  }
  for (size_t start = 0; start <= classpath.size();) {
    const size_t colon = std::min(classpath.find(':', start), classpath.size());
    const std::string jar = classpath.substr(start, colon - start);
    if (!std::filesystem::exists(jar)) {
      std::fprintf(stderr, "%s is missing (build the test's dependencies); skipping\n",
                   jar.c_str());
      std::exit(77);
    }
    start = colon + 1;
  }
  ASSERT_TRUE(OnlyLoopback()) << testing::kNotInNetns;
  const auto t0 = Clock::now();

  // 1. The Java decoder, subscribed to every channel before anything is sent.
  const std::string spy_out =
      ::testing::TempDir() + "slamd_spy_decode_" + std::to_string(getpid()) + ".out";
  const pid_t spy = Spawn(
      {java, "-Djava.net.preferIPv4Stack=true", "-Xmx64m", "-cp", classpath, "SpyDecode", kUrl},
      spy_out);
  ASSERT_GE(spy, 0);
  ChildGuard spy_guard{spy};
  for (auto deadline = Clock::now() + std::chrono::seconds(20);
       !ReadSpyOutput(spy_out).ready && Clock::now() < deadline;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(ReadSpyOutput(spy_out).ready) << "SpyDecode did not start";
  const double java_start_s = std::chrono::duration<double>(Clock::now() - t0).count();

  // 2. Our own recording of the bus, then slamd.
  lcm::LCM bus(kUrl);
  ASSERT_TRUE(bus.good());
  Recorder recorder;
  bus.subscribe("JV_.*", &Recorder::OnMessage, &recorder);
  const std::string config = testing::WriteTempFile(
      "slamd_spy_decode_netns_test.textproto",
      "refine { enabled: false }\npublish { status_rate_hz: 10 }\nlog_level: \"warn\"\n");
  const pid_t slamd =
      Spawn({SLAMD_PATH, "--config", config, "--lcm-url", kUrl, "--channel-prefix", "JV_"});
  ASSERT_GE(slamd, 0);
  ChildGuard slamd_guard{slamd};
  // Handles the bus until done() or the timeout; false on timeout.
  auto handle_until = [&](const std::function<bool()>& done, double timeout_s) {
    const auto deadline = Clock::now() + std::chrono::milliseconds(int(timeout_s * 1e3));
    while (!done()) {
      if (Clock::now() > deadline) return false;
      bus.handleTimeout(20);
    }
    return true;
  };
  int slamd_exit = -1;
  auto slamd_exited = [&] {
    int status = 0;
    if (waitpid(slamd, &status, WNOHANG) != slamd) return false;
    slamd_exit = testing::ExitCode(status);
    slamd_guard.pid = -1;
    return true;
  };
  ASSERT_TRUE(handle_until([&] { return recorder.Count("JV_STATUS") > 0 || slamd_exited(); }, 20))
      << "no status_t from slamd";
  ASSERT_EQ(slamd_exit, -1) << "slamd exited with " << slamd_exit;

  // 3. A robot: prior, three odometry steps, a landmark, a loop closure and its retraction, an
  // odometry whose covariance is not positive definite, and a query with a map.
  const std::string robot = "java_bot";
  slamd::prior_t prior;
  prior.utime = 100;
  prior.robot = robot;
  prior.pose_index = 0;
  prior.kind = slamd::prior_t::KIND_POSE_2D;
  prior.values = {0.0, 0.0, 0.0};
  prior.num_values = 3;
  prior.covariance = Diagonal({0.01, 0.01, 0.01});
  prior.num_covariance = 9;
  bus.publish("JV_PRIOR", &prior);
  for (int i = 0; i < 3; ++i) {
    slamd::odometry_t odo;
    odo.utime = 101 + i;
    odo.robot = robot;
    odo.from_index = i;
    odo.to_index = i + 1;
    odo.dimension = slamd::odometry_t::DIMENSION_2D;
    odo.values = {1.0, 0.0, 0.0};
    odo.num_values = 3;
    odo.covariance = Diagonal({0.05, 0.05, 0.02});
    odo.num_covariance = 9;
    bus.publish("JV_ODOMETRY", &odo);
  }
  slamd::landmark_observation_t landmark;
  landmark.utime = 104;
  landmark.robot = robot;
  landmark.pose_index = 3;
  landmark.landmark_id = 7;
  landmark.kind = slamd::landmark_observation_t::KIND_BEARING_RANGE_2D;
  landmark.values = {0.5, 2.0};
  landmark.num_values = 2;
  landmark.covariance = Diagonal({0.01, 0.05});
  landmark.num_covariance = 4;
  bus.publish("JV_LANDMARK", &landmark);
  slamd::loop_closure_t loop;
  loop.utime = 105;
  loop.robot_a = robot;
  loop.pose_a = 3;
  loop.robot_b = robot;
  loop.pose_b = 0;
  loop.dimension = slamd::loop_closure_t::DIMENSION_2D;
  loop.values = {-3.0, 0.0, 0.0};
  loop.num_values = 3;
  loop.covariance = Diagonal({0.1, 0.1, 0.05});
  loop.num_covariance = 9;
  loop.robust_kernel = "huber";
  loop.robust_parameter = 1.345;
  bus.publish("JV_LOOP_CLOSURE", &loop);
  slamd::remove_factor_t remove;
  remove.utime = 106;
  remove.target = slamd::remove_factor_t::TARGET_LOOP_CLOSURE;
  remove.robot_a = robot;
  remove.index_a = 3;
  remove.robot_b = robot;
  remove.index_b = 0;
  remove.kind = 0;
  bus.publish("JV_REMOVE_FACTOR", &remove);
  slamd::odometry_t bad;
  bad.utime = 107;
  bad.robot = robot;
  bad.from_index = 3;
  bad.to_index = 4;
  bad.dimension = slamd::odometry_t::DIMENSION_2D;
  bad.values = {1.0, 0.0, 0.0};
  bad.num_values = 3;
  bad.covariance = {1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0};
  bad.num_covariance = 9;
  bus.publish("JV_ODOMETRY", &bad);
  // Query once the graph is what the messages make: x0..x3 and l7; prior, odometry, landmark.
  auto settled = [&] {
    for (const Decoded& d : recorder.messages) {
      if (d.channel == "JV_STATUS" && Str(d.fields, "num_variables") == "5" &&
          Str(d.fields, "num_factors") == "5" && Str(d.fields, "messages_rejected") == "1") {
        return true;
      }
    }
    return false;
  };
  ASSERT_TRUE(handle_until(settled, 20)) << "slamd's status never showed 5 variables, 5 factors";
  slamd::query_t query;
  query.utime = 108;
  query.client = "java_test";
  query.request_id = 4242;
  query.keys.resize(2);
  query.keys[0].robot = robot;
  query.keys[0].kind = slamd::key_t::KIND_POSE;
  query.keys[0].index = 3;
  query.keys[1].robot = robot;
  query.keys[1].kind = slamd::key_t::KIND_LANDMARK;
  query.keys[1].index = 7;
  query.num_keys = 2;
  query.want_marginals = true;
  query.want_joint_marginal = true;
  query.map_robot = robot;
  bus.publish("JV_QUERY", &query);
  ASSERT_TRUE(handle_until(
      [&] { return recorder.Count("JV_QUERY_REPLY") > 0 && recorder.Count("JV_MAP") > 0; }, 20))
      << "no query reply and map from slamd";

  // 4. Stop slamd, take in what it sent last, and wait for the Java side to have printed as
  // many messages as we recorded.
  kill(slamd, SIGTERM);
  EXPECT_EQ(WaitExit(slamd), 0);
  slamd_guard.pid = -1;
  handle_until([] { return false; }, 0.2);
  SpyOutput spy_output;
  for (auto deadline = Clock::now() + std::chrono::seconds(10); Clock::now() < deadline;) {
    spy_output = ReadSpyOutput(spy_out, "JV_");
    if (spy_output.messages.size() >= recorder.messages.size()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::remove(spy_out.c_str());
  std::printf(
      "SpyDecode: %.2f s to start; %zu messages decoded in Java, %zu in C++; %.2f s in all\n",
      java_start_s, spy_output.messages.size(), recorder.messages.size(),
      std::chrono::duration<double>(Clock::now() - t0).count());
  for (const std::string& line : spy_output.other_lines)
    std::printf("SpyDecode: %s\n", line.c_str());

  // 5. The Java type scan (lcm-spy's) finds every slamd type with the C++ fingerprint, and no
  // other slamd type.
  std::map<std::string, std::int64_t> slamd_types;
  for (const auto& [name, fingerprint] : spy_output.types) {
    if (name.starts_with("slamd.")) slamd_types[name] = fingerprint;
  }
  std::map<std::string, std::int64_t> cpp_types;
  for (const TypeInfo& t : AllTypes()) cpp_types[t.java_name] = t.fingerprint;
  EXPECT_EQ(slamd_types, cpp_types);

  // 6. Message by message (in order on each channel), every field the same on both sides.
  std::map<std::string, std::vector<const Decoded*>> java_by_channel;
  std::map<std::string, std::vector<const Decoded*>> cpp_by_channel;
  for (const Decoded& d : spy_output.messages) java_by_channel[d.channel].push_back(&d);
  for (const Decoded& d : recorder.messages) cpp_by_channel[d.channel].push_back(&d);
  for (const auto& [channel, java_side] : java_by_channel) cpp_by_channel[channel];
  auto utimes = [](const std::vector<const Decoded*>& messages) {
    std::string text;
    for (const Decoded* d : messages) text.append(" ").append(Str(d->fields, "utime"));
    return text;
  };
  std::map<std::string, int> compared;  // messages per type
  for (const auto& [channel, cpp] : cpp_by_channel) {
    const std::vector<const Decoded*>& java_side = java_by_channel[channel];
    ASSERT_EQ(java_side.size(), cpp.size())
        << channel << ": utimes in Java" << utimes(java_side) << "; in C++" << utimes(cpp);
    for (size_t i = 0; i < cpp.size(); ++i) {
      const Decoded& c = *cpp[i];
      const Decoded& j = *java_side[i];
      ASSERT_EQ(j.type, c.type) << channel << " #" << i;
      std::vector<std::string> java_keys, cpp_keys;
      for (const auto& [k, v] : j.fields) java_keys.push_back(k);
      for (const auto& [k, v] : c.fields) cpp_keys.push_back(k);
      ASSERT_EQ(java_keys, cpp_keys) << channel << " #" << i;
      for (const auto& [k, v] : c.fields) {
        EXPECT_TRUE(SameValue(j.fields.at(k), v))
            << channel << " #" << i << " " << k << ": Java " << j.fields.at(k) << ", C++ " << v;
      }
      ++compared[c.type];
    }
  }
  std::string counts;
  for (const auto& [type, n] : compared) counts += " " + type.substr(6) + " " + std::to_string(n);
  std::printf("compared field by field:%s\n", counts.c_str());
  for (const char* type :
       {"estimate_t", "landmark_observation_t", "loop_closure_t", "map_t", "odometry_t", "prior_t",
        "query_reply_t", "query_t", "reject_t", "remove_factor_t", "status_t"}) {
    EXPECT_GT(compared[std::string("slamd.") + type], 0) << "no " << type << " on the bus";
  }

  // 7. What the Java decoder read of slamd's messages makes sense.
  const Fields* estimate = LastOn(spy_output, "JV_ESTIMATE");
  ASSERT_NE(estimate, nullptr);
  EXPECT_EQ(Str(*estimate, "robot"), robot);
  EXPECT_EQ(Str(*estimate, "pose_index"), "3");
  EXPECT_EQ(Str(*estimate, "dimension"), "2");
  EXPECT_NEAR(Num(*estimate, "values[0]"), 3.0, 1e-6);
  EXPECT_NEAR(Num(*estimate, "values[1]"), 0.0, 1e-6);
  EXPECT_NEAR(Num(*estimate, "values[2]"), 0.0, 1e-6);
  EXPECT_EQ(Str(*estimate, "num_covariance"), "9");

  const Fields* reject = LastOn(spy_output, "JV_REJECT");
  ASSERT_NE(reject, nullptr);
  EXPECT_EQ(Str(*reject, "channel"), "JV_ODOMETRY");
  EXPECT_EQ(Str(*reject, "message_type"), "odometry_t");
  EXPECT_EQ(Str(*reject, "robot"), robot);
  EXPECT_EQ(Str(*reject, "message_utime"), "107");
  EXPECT_EQ(Str(*reject, "reason"),
            std::to_string(slamd::reject_t::REASON_COVARIANCE_NOT_POSITIVE_DEFINITE));
  EXPECT_NE(Str(*reject, "detail").find("covariance"), std::string::npos);

  const Fields* reply = LastOn(spy_output, "JV_QUERY_REPLY");
  ASSERT_NE(reply, nullptr);
  EXPECT_EQ(Str(*reply, "client"), "java_test");
  EXPECT_EQ(Str(*reply, "request_id"), "4242");
  EXPECT_EQ(Str(*reply, "status"), std::to_string(slamd::query_reply_t::STATUS_OK));
  EXPECT_EQ(Str(*reply, "num_results"), "2");
  EXPECT_EQ(Str(*reply, "results[0].key.robot"), robot);
  EXPECT_EQ(Str(*reply, "results[0].key.kind"), std::to_string(slamd::key_t::KIND_POSE));
  EXPECT_EQ(Str(*reply, "results[0].key.index"), "3");
  EXPECT_EQ(Str(*reply, "results[0].found"), "true");
  EXPECT_NEAR(Num(*reply, "results[0].values[0]"), 3.0, 1e-6);
  EXPECT_EQ(Str(*reply, "results[0].num_covariance"), "9");
  // Three odometry steps after the prior (the loop closure retracted): x variances add up.
  EXPECT_NEAR(Num(*reply, "results[0].covariance[0]"), 0.01 * 0.01 + 3 * 0.05 * 0.05, 1e-9);
  EXPECT_EQ(Str(*reply, "results[1].key.kind"), std::to_string(slamd::key_t::KIND_LANDMARK));
  EXPECT_EQ(Str(*reply, "results[1].key.index"), "7");
  EXPECT_EQ(Str(*reply, "results[1].found"), "true");
  // The landmark 2 m away at bearing 0.5 rad from pose 3 = (3, 0, 0).
  EXPECT_NEAR(Num(*reply, "results[1].values[0]"), 3.0 + 2.0 * std::cos(0.5), 1e-6);
  EXPECT_NEAR(Num(*reply, "results[1].values[1]"), 2.0 * std::sin(0.5), 1e-6);
  EXPECT_EQ(Str(*reply, "results[1].num_covariance"), "4");
  EXPECT_EQ(Str(*reply, "joint_dimension"), "5");
  EXPECT_EQ(Str(*reply, "num_joint_covariance"), "25");
  EXPECT_EQ(Str(*reply, "map_pages"), "1");

  const Fields* map = LastOn(spy_output, "JV_MAP", [](const Fields& f) {
    return f.count("request_id") && f.at("request_id") == "4242";
  });
  ASSERT_NE(map, nullptr);
  EXPECT_EQ(Str(*map, "robot"), robot);
  EXPECT_EQ(Str(*map, "page_count"), "1");
  EXPECT_EQ(Str(*map, "num_poses"), "4");
  EXPECT_EQ(Str(*map, "poses[3].index"), "3");
  EXPECT_NEAR(Num(*map, "poses[3].values[0]"), 3.0, 1e-6);
  EXPECT_EQ(Str(*map, "num_landmarks"), "1");
  EXPECT_EQ(Str(*map, "landmarks[0].index"), "7");

  const Fields* status = LastOn(spy_output, "JV_STATUS");
  ASSERT_NE(status, nullptr);
  EXPECT_EQ(Str(*status, "num_robots"), "1");
  EXPECT_EQ(Str(*status, "num_variables"), "5");
  EXPECT_EQ(Str(*status, "num_factors"), "5");
  EXPECT_EQ(Str(*status, "messages_rejected"), "1");
  EXPECT_EQ(Str(*status, "rejects_by_reason[12]"), "1");

  // And what we sent, as Java read it: the query's nested keys and booleans, the closure's kernel.
  const Fields* sent_query = LastOn(spy_output, "JV_QUERY");
  ASSERT_NE(sent_query, nullptr);
  EXPECT_EQ(Str(*sent_query, "keys[1].robot"), robot);
  EXPECT_EQ(Str(*sent_query, "keys[1].index"), "7");
  EXPECT_EQ(Str(*sent_query, "want_joint_marginal"), "true");
  const Fields* sent_loop = LastOn(spy_output, "JV_LOOP_CLOSURE");
  ASSERT_NE(sent_loop, nullptr);
  EXPECT_EQ(Str(*sent_loop, "robust_kernel"), "huber");
  EXPECT_EQ(Num(*sent_loop, "robust_parameter"), 1.345);
}

}  // namespace
}  // namespace slamd
