// Replay sources: datasets interleaved with inter-robot closures, and LCM event logs.
#include "clients/slamctl/replay_sources.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <utility>

#include "server/messages/inbound.h"
#include "server/transport/typed_subscribe.h"

namespace slamd::clients {
namespace {

std::vector<std::string> Tokens(const std::string& line) {
  std::vector<std::string> out;
  std::istringstream in(line);
  for (std::string t; in >> t;) out.push_back(t);
  return out;
}

bool ParseDouble(const std::string& s, double* v) {
  errno = 0;
  char* end = nullptr;
  *v = std::strtod(s.c_str(), &end);
  return end != s.c_str() && *end == '\0' && errno == 0 && std::isfinite(*v);
}

bool ParseIndex(const std::string& s, std::uint64_t* v) {
  if (s.empty() || s[0] == '-' || s[0] == '+') return false;
  errno = 0;
  char* end = nullptr;
  const unsigned long long x = std::strtoull(s.c_str(), &end, 10);
  if (*end != '\0' || errno != 0 || x > core::kMaxKeyIndex) return false;
  *v = x;
  return true;
}

// The symmetric matrix of an upper triangle given row by row.
Eigen::MatrixXd FromUpperTriangle(const std::vector<double>& upper, int n) {
  Eigen::MatrixXd m(n, n);
  int k = 0;
  for (int i = 0; i < n; ++i) {
    for (int j = i; j < n; ++j) m(i, j) = m(j, i) = upper[k++];
  }
  return m;
}

core::Result<InterRobotClosure> ParseClosureLine(const std::vector<std::string>& t,
                                                 const std::string& where) {
  const bool se2 = t[0] == "INTER_SE2";
  if (!se2 && t[0] != "INTER_SE3") {
    return core::DataLoss(where + ": expected INTER_SE2 or INTER_SE3, got '" + t[0] + "'");
  }
  const size_t want = se2 ? 5 + 3 + 6 : 5 + 7 + 21;
  if (t.size() != want) {
    return core::DataLoss(where + ": " + t[0] + " needs " + std::to_string(want) +
                          " fields (tag robotA idxA robotB idxB measurement information), got " +
                          std::to_string(t.size()));
  }
  server::LoopClosureMeasurement m{.utime = 0,
                                   .robot_a = t[1],
                                   .pose_a = 0,
                                   .robot_b = t[3],
                                   .pose_b = 0,
                                   .measured = core::Pose2(),
                                   .noise = core::NoiseModel::Unit(3),
                                   .robust = {}};
  for (const std::string* name : {&m.robot_a, &m.robot_b}) {
    if (!IsValidRobotName(*name)) {
      return core::DataLoss(where + ": robot name '" + *name +
                            "' needs 1..64 chars of [A-Za-z0-9_.-]");
    }
  }
  if (!ParseIndex(t[2], &m.pose_a) || !ParseIndex(t[4], &m.pose_b)) {
    return core::DataLoss(where + ": pose indices must be integers in 0..2^48-1, got '" + t[2] +
                          "' and '" + t[4] + "'");
  }
  std::vector<double> x;
  for (size_t i = 5; i < t.size(); ++i) {
    double v = 0;
    if (!ParseDouble(t[i], &v)) {
      return core::DataLoss(where + ": field " + std::to_string(i + 1) + ": '" + t[i] +
                            "' is not a finite number");
    }
    x.push_back(v);
  }
  const int n = se2 ? 3 : 6;
  const std::vector<double> info(x.begin() + (se2 ? 3 : 7), x.end());
  core::Result<core::NoiseModel> noise =
      core::NoiseModel::FromInformation(FromUpperTriangle(info, n));
  if (!noise.ok()) return core::DataLoss(where + ": information: " + noise.status().message());
  m.noise = *noise;
  if (se2) {
    m.measured = core::Pose2(x[0], x[1], x[2]);
  } else {
    const double norm = std::sqrt(x[3] * x[3] + x[4] * x[4] + x[5] * x[5] + x[6] * x[6]);
    if (!(norm > 1e-9)) return core::DataLoss(where + ": zero quaternion");
    m.measured = core::Pose3(core::Rot3::FromQuaternion(x[6], x[3], x[4], x[5]),
                             core::Point3(x[0], x[1], x[2]));
  }
  InterRobotClosure c;
  server::ToLcm(m, &c.message);
  return c;
}

template <typename Msg>
bool Decode(const std::vector<std::uint8_t>& bytes, Msg* msg) {
  return server::internal::DecodeAs(std::span<const std::uint8_t>(bytes), msg).ok();
}

}  // namespace

core::Result<std::vector<InterRobotClosure>> ParseInterRobot(const std::string& text,
                                                             const std::string& name) {
  std::vector<InterRobotClosure> out;
  std::istringstream in(text);
  int line_number = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_number;
    if (const size_t hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    const std::vector<std::string> t = Tokens(line);
    if (t.empty()) continue;
    core::Result<InterRobotClosure> c =
        ParseClosureLine(t, name + ":" + std::to_string(line_number));
    if (!c.ok()) return c.status();
    out.push_back(std::move(c).value());
    out.back().line = line_number;
  }
  return out;
}

core::Result<std::vector<InterRobotClosure>> ReadInterRobotFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return core::IoError(path + ": cannot open");
  std::ostringstream text;
  text << in.rdbuf();
  return ParseInterRobot(text.str(), path);
}

core::Result<std::vector<ReplayItem>> InterleaveRobots(
    const std::vector<RobotDataset>& robots, const std::vector<InterRobotClosure>& closures,
    const server::ChannelNames& channels) {
  // Which poses each robot's steps introduce, and the closures waiting on each pose.
  std::map<std::string, std::set<std::uint64_t>> poses;
  for (const RobotDataset& r : robots) {
    for (const StepMessages& s : r.steps) poses[r.robot].insert(s.pose_index);
  }
  using PoseId = std::pair<std::string, std::uint64_t>;
  std::map<PoseId, std::vector<size_t>> waiting;
  for (size_t i = 0; i < closures.size(); ++i) {
    const slamd::loop_closure_t& m = closures[i].message;
    for (const auto& [robot, pose] : {PoseId{m.robot_a, m.pose_a}, PoseId{m.robot_b, m.pose_b}}) {
      auto it = poses.find(robot);
      if (it == poses.end()) {
        return core::InvalidArgument("inter-robot closure (line " +
                                     std::to_string(closures[i].line) + "): unknown robot '" +
                                     robot + "'");
      }
      if (!it->second.count(pose)) {
        return core::InvalidArgument("inter-robot closure (line " +
                                     std::to_string(closures[i].line) + "): robot '" + robot +
                                     "' has no pose " + std::to_string(pose));
      }
      waiting[{robot, pose}].push_back(i);
    }
  }
  std::set<PoseId> sent;
  std::vector<bool> closure_sent(closures.size(), false);
  std::vector<ReplayItem> items;
  auto add = [&](const RobotMessage& message, const std::string& robot,
                 std::int64_t new_pose) -> core::Status {
    ReplayItem item{.channel = ChannelOf(message, channels),
                    .bytes = {},
                    .robot = robot,
                    .new_pose = new_pose,
                    .log_utime = 0,
                    .utime = std::visit([](const auto& m) { return m.utime; }, message)};
    SLAMD_RETURN_IF_ERROR(EncodeMessage(message, &item.bytes));
    items.push_back(std::move(item));
    return core::Status::Ok();
  };
  size_t rounds = 0;
  for (const RobotDataset& r : robots) rounds = std::max(rounds, r.steps.size());
  for (size_t k = 0; k < rounds; ++k) {
    for (const RobotDataset& r : robots) {
      if (k >= r.steps.size()) continue;
      const StepMessages& step = r.steps[k];
      for (size_t j = 0; j < step.messages.size(); ++j) {
        const bool first = j == 0 && step.introduces_pose;
        SLAMD_RETURN_IF_ERROR(add(step.messages[j], r.robot,
                                  first ? static_cast<std::int64_t>(step.pose_index) : -1));
      }
      const PoseId id{r.robot, step.pose_index};
      sent.insert(id);
      for (size_t i : waiting[id]) {
        const slamd::loop_closure_t& m = closures[i].message;
        if (closure_sent[i] || !sent.count({m.robot_a, m.pose_a}) ||
            !sent.count({m.robot_b, m.pose_b})) {
          continue;
        }
        closure_sent[i] = true;
        slamd::loop_closure_t stamped = m;
        if (!step.messages.empty()) {
          stamped.utime = std::visit([](const auto& s) { return s.utime; }, step.messages.back());
        }
        SLAMD_RETURN_IF_ERROR(add(stamped, m.robot_a, -1));
      }
    }
  }
  return items;
}

bool IsLcmLog(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char magic[4] = {0, 0, 0, 0};
  if (!in.read(reinterpret_cast<char*>(magic), 4)) return false;
  return magic[0] == 0xED && magic[1] == 0xA1 && magic[2] == 0xDA && magic[3] == 0x01;
}

core::Result<std::vector<ReplayItem>> ReadLcmLog(const std::string& path,
                                                 const server::ChannelNames& channels,
                                                 const std::string& extra_channels) {
  std::optional<std::regex> extra;
  if (!extra_channels.empty()) {
    try {
      extra.emplace(extra_channels, std::regex::ECMAScript);
    } catch (const std::regex_error& e) {
      return core::InvalidArgument("--channels '" + extra_channels + "': " + e.what());
    }
  }
  if (!IsLcmLog(path)) return core::InvalidArgument(path + ": not an LCM event log");
  lcm::LogFile log(path, "r");
  if (!log.good()) return core::IoError(path + ": cannot open the LCM log");
  std::set<std::string> inbound;  // what slamd takes from robots (not queries)
  server::InboundSpecs::ForEach([&](auto spec) {
    using Spec = typename decltype(spec)::type;
    if (Spec::kRole != server::MessageRole::kQuery) inbound.insert(channels.Inbound<Spec>());
  });
  std::map<std::string, std::set<std::uint64_t>> known;  // poses given to the server per robot
  std::vector<ReplayItem> items;
  while (const lcm::LogEvent* event = log.readNextEvent()) {
    const bool slamd_channel = inbound.count(event->channel) > 0;
    if (!slamd_channel && !(extra && std::regex_match(event->channel, *extra))) continue;
    ReplayItem item;
    item.channel = event->channel;
    const auto* data = static_cast<const std::uint8_t*>(event->data);
    item.bytes.assign(data, data + event->datalen);
    item.log_utime = event->timestamp;
    auto introduce = [&](const std::string& robot, std::uint64_t pose) {
      if (known[robot].insert(pose).second) item.new_pose = static_cast<std::int64_t>(pose);
    };
    if (event->channel == channels.Inbound<server::OdometrySpec>()) {
      slamd::odometry_t m;
      if (Decode(item.bytes, &m) && m.from_index >= 0 && m.to_index >= 0) {
        item.robot = m.robot;
        item.utime = m.utime;
        known[m.robot].insert(static_cast<std::uint64_t>(m.from_index));
        introduce(m.robot, static_cast<std::uint64_t>(m.to_index));
      }
    } else if (event->channel == channels.Inbound<server::PriorSpec>()) {
      slamd::prior_t m;
      if (Decode(item.bytes, &m) && m.pose_index >= 0) {
        item.robot = m.robot;
        item.utime = m.utime;
        introduce(m.robot, static_cast<std::uint64_t>(m.pose_index));
      }
    } else if (event->channel == channels.Inbound<server::LoopClosureSpec>()) {
      slamd::loop_closure_t m;
      if (Decode(item.bytes, &m)) {
        item.robot = m.robot_a;
        item.utime = m.utime;
      }
    } else if (event->channel == channels.Inbound<server::LandmarkObservationSpec>()) {
      slamd::landmark_observation_t m;
      if (Decode(item.bytes, &m)) {
        item.robot = m.robot;
        item.utime = m.utime;
      }
    }
    items.push_back(std::move(item));
  }
  return items;
}

}  // namespace slamd::clients
