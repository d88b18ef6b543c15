// loop_closure_t (msgs/lcm/loop_closure_t.lcm): the relative pose between poses of one or two
// robots, possibly with a robust kernel.
//
// Applied: a BetweenFactor from (robot_a, pose_a) to (robot_b, pose_b), with the message's
// kernel or the configured default (EstimatorParams::loop_closure_kernel). When exactly one side
// is known and the other robot has no pose yet, it connects (and anchors) that robot: the
// unknown pose is placed from the known one. In a map shard, an unknown pose of a robot another
// shard owns is placed the same way and kept as a shared pose (no robot state: it is not
// published). Identity: the two keys, smaller first.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "server/ingest/conversion.h"
#include "server/ingest/measurements.h"
#include "server/messages/message_spec.h"
#include "slamd/loop_closure_t.hpp"

namespace slamd::server {

struct LoopClosureMeasurement {
  std::int64_t utime;
  std::string robot_a;
  std::uint64_t pose_a;
  std::string robot_b;
  std::uint64_t pose_b;
  RelativePose measured;      // pose b in the frame of pose a -> BetweenFactor
  core::NoiseModel noise;     // dim 3 or 6
  core::RobustKernel robust;  // kNone unless the message named one
};

Verdict Validate(const slamd::loop_closure_t& msg, const Limits& limits = {},
                 std::optional<core::NoiseModel>* noise = nullptr,
                 core::RobustKernel* robust = nullptr);
Checked<LoopClosureMeasurement> Convert(const slamd::loop_closure_t& msg,
                                        const Limits& limits = {});
void ToLcm(const LoopClosureMeasurement& m, slamd::loop_closure_t* out);

struct LoopClosureSpec {
  using Lcm = slamd::loop_closure_t;
  using Value = LoopClosureMeasurement;
  static constexpr const char* kType = "loop_closure_t";
  static constexpr const char* kChannel = "LOOP_CLOSURE";
  static constexpr MessageRole kRole = MessageRole::kMeasurement;
  static constexpr char kIdentity = 'c';

  template <typename M>
  static const std::string& Robot(const M& m) {
    return m.robot_a;
  }
  template <typename M>
  static const std::string& SecondRobot(const M& m) {
    return m.robot_b;
  }
  // With the message's kernel, or `default_kernel` when it names none.
  static core::FactorPtr Factor(const Value& m, core::Key a, core::Key b,
                                const core::RobustKernel& default_kernel);
  static Outcome Apply(const Value& m, GraphBuilder& graph, Verdict* verdict);
};

}  // namespace slamd::server
