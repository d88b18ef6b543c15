#include "server/messages/shard_summary.h"

#include <set>
#include <span>
#include <utility>

#include "core/factors/linear_container_factor.h"
#include "server/ingest/field_checks.h"
#include "server/messages/wire_values.h"
#include "slamd/key_t.hpp"

namespace slamd::server {
namespace {

using internal::CheckCount;
using internal::CheckDimension;
using internal::CheckFinite;
using internal::CheckIndex;
using internal::CheckMagnitude;
using internal::CheckName;
using internal::CheckUnitQuaternion;
using internal::CheckUtime;
using internal::Layout;
using internal::Reject;

}  // namespace

namespace {

// Values and tangent columns of one key of a summary in a world of `layout`'s dimension.
int KeyValues(const slamd::key_t& k, const Layout& layout) {
  const bool is2d = !layout.has_quaternion;
  return k.kind == slamd::key_t::KIND_POSE ? layout.num_values : (is2d ? 2 : 3);
}
int KeyColumns(const slamd::key_t& k, const Layout& layout) {
  const bool is2d = !layout.has_quaternion;
  return k.kind == slamd::key_t::KIND_POSE ? layout.cov_dim : (is2d ? 2 : 3);
}

Verdict CheckKeys(const slamd::shard_summary_t& msg, const Limits& limits) {
  if (msg.num_keys < 0 || msg.num_keys > kMaxSummaryKeys) {
    return Reject(
        RejectReason::kTooManyElements, "shard_summary_t.num_keys",
        std::to_string(msg.num_keys) + " not in [0, " + std::to_string(kMaxSummaryKeys) + "]");
  }
  SLAMD_RETURN_IF_REJECTED(
      CheckCount("shard_summary_t.num_keys", msg.num_keys, msg.keys.size(), -1, ""));
  std::set<std::tuple<std::string, int, std::int64_t>> seen;
  for (std::size_t i = 0; i < msg.keys.size(); ++i) {
    const slamd::key_t& k = msg.keys[i];
    const std::string field = "shard_summary_t.keys[" + std::to_string(i) + "]";
    if (k.kind == slamd::key_t::KIND_POSE) {
      SLAMD_RETURN_IF_REJECTED(CheckName(field + ".robot", k.robot, limits.max_robot_name_length));
    } else if (k.kind == slamd::key_t::KIND_MAP_LANDMARK) {
      SLAMD_RETURN_IF_REJECTED(MustBeEmpty((field + ".robot").c_str(), k.robot, "a map landmark"));
    } else {
      return Reject(RejectReason::kBadKind, field + ".kind",
                    "must be KIND_POSE (1) or KIND_MAP_LANDMARK (3)");
    }
    SLAMD_RETURN_IF_REJECTED(CheckIndex(field + ".index", k.index));
    if (!seen.emplace(k.robot, k.kind, k.index).second) {
      return Reject(RejectReason::kDuplicate, field, "names a variable listed before");
    }
  }
  if (msg.num_map_landmarks < 0 || msg.num_map_landmarks > kMaxSummaryMapLandmarks) {
    return Reject(RejectReason::kTooManyElements, "shard_summary_t.num_map_landmarks",
                  std::to_string(msg.num_map_landmarks) + " not in [0, " +
                      std::to_string(kMaxSummaryMapLandmarks) + "]");
  }
  SLAMD_RETURN_IF_REJECTED(CheckCount("shard_summary_t.num_map_landmarks", msg.num_map_landmarks,
                                      msg.map_landmarks.size(), -1, ""));
  for (std::size_t i = 0; i < msg.map_landmarks.size(); ++i) {
    const std::string field = "shard_summary_t.map_landmarks[" + std::to_string(i) + "]";
    SLAMD_RETURN_IF_REJECTED(CheckIndex(field, msg.map_landmarks[i]));
    if (i > 0 && msg.map_landmarks[i] <= msg.map_landmarks[i - 1]) {
      return Reject(RejectReason::kDuplicate, field, "not above the one before (ascending)");
    }
  }
  return {};
}

}  // namespace

Verdict Validate(const slamd::shard_summary_t& msg, const Limits& limits) {
  SLAMD_RETURN_IF_REJECTED(CheckUtime("shard_summary_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("shard_summary_t.from_shard", msg.from_shard, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("shard_summary_t.to_shard", msg.to_shard, limits.max_robot_name_length));
  const Layout* layout = nullptr;
  SLAMD_RETURN_IF_REJECTED(CheckDimension("shard_summary_t.dimension", msg.dimension, &layout));
  SLAMD_RETURN_IF_REJECTED(CheckKeys(msg, limits));
  int values = 0, columns = 0;
  for (const slamd::key_t& k : msg.keys) {
    values += KeyValues(k, *layout);
    columns += KeyColumns(k, *layout);
  }
  SLAMD_RETURN_IF_REJECTED(CheckCount("shard_summary_t.num_values", msg.num_values,
                                      msg.values.size(), values, "the keys' values"));
  SLAMD_RETURN_IF_REJECTED(CheckFinite("shard_summary_t.values", msg.values));
  SLAMD_RETURN_IF_REJECTED(
      CheckMagnitude("shard_summary_t.values", msg.values, limits.max_abs_value));
  int at = 0;
  for (const slamd::key_t& k : msg.keys) {
    if (k.kind == slamd::key_t::KIND_POSE && layout->has_quaternion) {
      const double* q = msg.values.data() + at + 3;
      SLAMD_RETURN_IF_REJECTED(
          CheckUnitQuaternion("shard_summary_t.values[" + std::to_string(at + 3) + "..]", q[0],
                              q[1], q[2], q[3], limits.quaternion_norm_tolerance));
    }
    at += KeyValues(k, *layout);
  }
  const int min_rows = columns > 0 ? 1 : 0;
  if (msg.rows < min_rows || msg.rows > columns) {
    return Reject(RejectReason::kSizeMismatch, "shard_summary_t.rows",
                  std::to_string(msg.rows) + " not in [" + std::to_string(min_rows) + ", " +
                      std::to_string(columns) + "]");
  }
  SLAMD_RETURN_IF_REJECTED(CheckCount("shard_summary_t.num_a", msg.num_a, msg.a.size(),
                                      msg.rows * columns, "rows x the keys' tangent dimensions"));
  SLAMD_RETURN_IF_REJECTED(CheckCount("shard_summary_t.rows", msg.rows, msg.b.size(), -1, ""));
  SLAMD_RETURN_IF_REJECTED(CheckFinite("shard_summary_t.a", msg.a));
  return CheckFinite("shard_summary_t.b", msg.b);
}

Checked<ShardSummaryMessage> Convert(const slamd::shard_summary_t& msg, const Limits& limits) {
  Verdict verdict = Validate(msg, limits);
  if (!verdict.ok()) return verdict;
  ShardSummaryMessage m{.utime = msg.utime, .from_shard = msg.from_shard, .to_shard = msg.to_shard};
  const bool is2d = msg.dimension == slamd::shard_summary_t::DIMENSION_2D;
  const Layout& layout = is2d ? internal::kPose2Layout : internal::kPose3Layout;
  auto value = msg.values.begin();
  for (const slamd::key_t& k : msg.keys) {
    const int n = KeyValues(k, layout);
    const std::vector<double> v(value, value + n);
    value += n;
    if (k.kind == slamd::key_t::KIND_POSE) {
      m.keys.push_back({k.robot, KeyKind::kPose, static_cast<std::uint64_t>(k.index)});
      m.x0.push_back(std::visit([](const auto& p) -> core::Variable { return p; }, ToPose(v)));
    } else {
      m.keys.push_back({"", KeyKind::kMapLandmark, static_cast<std::uint64_t>(k.index)});
      m.x0.push_back(is2d ? core::Variable(core::Point2(v[0], v[1]))
                          : core::Variable(core::Point3(v[0], v[1], v[2])));
    }
  }
  const int columns = msg.rows > 0 ? static_cast<int>(msg.a.size()) / msg.rows : 0;
  m.A = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      msg.a.data(), msg.rows, columns);
  m.b = Eigen::Map<const Eigen::VectorXd>(msg.b.data(), msg.rows);
  m.map_landmarks.assign(msg.map_landmarks.begin(), msg.map_landmarks.end());
  return m;
}

void ToLcm(const ShardSummaryMessage& m, slamd::shard_summary_t* out) {
  out->utime = m.utime;
  out->from_shard = m.from_shard;
  out->to_shard = m.to_shard;
  const bool is2d = m.x0.empty() || std::holds_alternative<core::Pose2>(m.x0[0]) ||
                    std::holds_alternative<core::Point2>(m.x0[0]);
  out->dimension =
      is2d ? slamd::shard_summary_t::DIMENSION_2D : slamd::shard_summary_t::DIMENSION_3D;
  out->keys.clear();
  out->values.clear();
  for (std::size_t i = 0; i < m.keys.size(); ++i) {
    slamd::key_t k;
    k.robot = m.keys[i].robot;
    k.kind = static_cast<std::int8_t>(m.keys[i].kind);
    k.index = static_cast<std::int64_t>(m.keys[i].index);
    out->keys.push_back(std::move(k));
    const std::vector<double> v = ToValues(m.x0[i]);
    out->values.insert(out->values.end(), v.begin(), v.end());
  }
  out->num_keys = static_cast<std::int32_t>(out->keys.size());
  out->num_values = static_cast<std::int32_t>(out->values.size());
  out->rows = static_cast<std::int32_t>(m.A.rows());
  out->a = ToRowMajor(m.A);
  out->num_a = static_cast<std::int32_t>(out->a.size());
  out->b.assign(m.b.data(), m.b.data() + m.b.size());
  out->map_landmarks.assign(m.map_landmarks.begin(), m.map_landmarks.end());
  out->num_map_landmarks = static_cast<std::int32_t>(out->map_landmarks.size());
}

core::Key ShardIdentity(const std::string& shard) {
  std::uint64_t h = 1469598103934665603ull;
  for (const unsigned char c : shard) h = (h ^ c) * 1099511628211ull;
  return h;
}

Outcome ShardSummarySpec::Apply(const Value& m, GraphBuilder& g, Verdict* v) {
  if (m.to_shard != g.policy().shards.self) {
    *v = {RejectReason::kUnknownRobot, "shard_summary_t.to_shard: '" + m.to_shard +
                                           "' is not this slamd's shard ('" +
                                           g.policy().shards.self + "')"};
    return Outcome::kRejected;
  }
  g.NoteShardLandmarks(m.from_shard, m.map_landmarks);
  if (m.keys.empty()) return Outcome::kApplied;  // it only says which landmarks it holds
  core::KeyVector keys;
  std::vector<std::pair<core::Key, const core::Variable*>> foreign;
  for (std::size_t i = 0; i < m.keys.size(); ++i) {
    const WireKey& k = m.keys[i];
    core::Key key = MapLandmarkKey(k.index);
    if (k.kind == KeyKind::kPose) {
      const std::optional<std::uint8_t> id = g.FindOrAddRobot(k.robot);
      if (!id) {
        *v = {RejectReason::kTooManyElements, "shard_summary_t.keys: more than 255 robots"};
        return Outcome::kRejected;
      }
      key = core::MakeKey('x', k.index, *id);
    }
    if (g.Known(key)) {
      if (g.Estimate(key).index() != m.x0[i].index()) {
        *v = {RejectReason::kBadMeasurement,
              "shard_summary_t.dimension: does not match " + WireKeyName(k)};
        return Outcome::kRejected;
      }
    } else if (k.kind == KeyKind::kPose && g.policy().shards.Owns(k.robot)) {
      return Outcome::kHeld;  // a pose of ours that has not arrived yet
    } else {
      foreign.emplace_back(key, &m.x0[i]);  // another shard's pose, or a landmark not held here
    }
    keys.push_back(key);
  }
  core::Result<core::FactorPtr> factor = core::LinearContainerFactor::Create(keys, m.x0, m.A, m.b);
  if (!factor.ok()) {
    *v = {RejectReason::kBadMeasurement, "shard_summary_t: " + factor.status().message()};
    return Outcome::kRejected;
  }
  g.FirstTime({kIdentity, ShardIdentity(m.from_shard), 0, 0});
  for (const auto& [key, value] : foreign) g.AddVariable(key, *value);
  return g.AddReplacing(std::move(factor).value(), keys.front());
}

}  // namespace slamd::server
