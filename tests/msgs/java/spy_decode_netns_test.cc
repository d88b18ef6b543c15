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
#include "tests/msgs/java/lcm_fields.h"
#include "tests/msgs/java/spy_output.h"
#include "tests/testing/datasets.h"
#include "tests/testing/processes.h"

namespace slamd {
namespace {

using testing::OnlyLoopback;
using testing::Spawn;
using testing::WaitExit;
using namespace spy_test;  // NOLINT: the two sides of the comparison

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";
using Clock = std::chrono::steady_clock;

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
  landmark.landmark_namespace = slamd::landmark_observation_t::NAMESPACE_ROBOT;
  landmark.values = {0.5, 2.0};
  landmark.num_values = 2;
  landmark.covariance = Diagonal({0.01, 0.05});
  landmark.num_covariance = 4;
  bus.publish("JV_LANDMARK", &landmark);
  // A stereo camera and a frame of it (refused: the robot's poses are 2D), both decoded.
  slamd::camera_info_t camera;
  camera.utime = 104;
  camera.robot = robot;
  camera.camera_id = 0;
  camera.from_pose_index = 0;
  camera.model = slamd::camera_info_t::MODEL_STEREO;
  camera.intrinsics = {400.0, 400.0, 0.0, 320.0, 240.0, 0.12};
  camera.num_intrinsics = 6;
  const double mount_t[3] = {0.1, 0.0, 0.2}, mount_q[4] = {1.0, 0.0, 0.0, 0.0};
  std::copy(mount_t, mount_t + 3, camera.body_t_camera);
  std::copy(mount_q, mount_q + 4, camera.body_q_camera);
  camera.width = 640;
  camera.height = 480;
  bus.publish("JV_CAMERA_INFO", &camera);
  slamd::frame_observations_t frame;
  frame.utime = 104;
  frame.robot = robot;
  frame.pose_index = 3;
  frame.camera_id = 0;
  frame.kind = slamd::frame_observations_t::KIND_STEREO;
  frame.landmark_namespace = slamd::frame_observations_t::NAMESPACE_MAP;
  frame.landmark_ids = {3, 9};
  frame.num_features = 2;
  frame.values = {300.5, 290.0, 200.0, 100.0, 95.5, 50.25};
  frame.num_values = 6;
  frame.sigmas = {1.5};
  frame.num_sigmas = 1;
  frame.num_covariance = 0;
  bus.publish("JV_FRAME", &frame);
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
  // Query once the graph is what the messages make: x0..x3 and l7; prior, odometry, landmark;
  // the bad odometry and the frame rejected.
  auto settled = [&] {
    for (const Decoded& d : recorder.messages) {
      if (d.channel == "JV_STATUS" && Str(d.fields, "num_variables") == "5" &&
          Str(d.fields, "num_factors") == "5" && Str(d.fields, "messages_rejected") == "2") {
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
       {"camera_info_t", "estimate_t", "frame_observations_t", "landmark_observation_t",
        "loop_closure_t", "map_t", "odometry_t", "prior_t", "query_reply_t", "query_t", "reject_t",
        "remove_factor_t", "status_t"}) {
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

  const Fields* reject = LastOn(spy_output, "JV_REJECT",
                                [](const Fields& f) { return Str(f, "channel") == "JV_ODOMETRY"; });
  ASSERT_NE(reject, nullptr);
  EXPECT_EQ(Str(*reject, "channel"), "JV_ODOMETRY");
  EXPECT_EQ(Str(*reject, "message_type"), "odometry_t");
  EXPECT_EQ(Str(*reject, "robot"), robot);
  EXPECT_EQ(Str(*reject, "message_utime"), "107");
  EXPECT_EQ(Str(*reject, "reason"),
            std::to_string(slamd::reject_t::REASON_COVARIANCE_NOT_POSITIVE_DEFINITE));
  EXPECT_NE(Str(*reject, "detail").find("covariance"), std::string::npos);
  const Fields* frame_reject = LastOn(
      spy_output, "JV_REJECT", [](const Fields& f) { return Str(f, "channel") == "JV_FRAME"; });
  ASSERT_NE(frame_reject, nullptr);
  EXPECT_EQ(Str(*frame_reject, "message_type"), "frame_observations_t");
  EXPECT_NE(Str(*frame_reject, "detail").find("2D pose"), std::string::npos);

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
  EXPECT_EQ(Str(*status, "messages_rejected"), "2");
  EXPECT_EQ(Str(*status, "rejects_by_reason[12]"), "1");
  EXPECT_EQ(Str(*status, "rejects_by_reason[17]"), "1");  // the frame: bad measurement

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
