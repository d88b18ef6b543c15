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

Verdict Validate(const slamd::shard_summary_t& msg, const Limits& limits) {
  SLAMD_RETURN_IF_REJECTED(CheckUtime("shard_summary_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("shard_summary_t.from_shard", msg.from_shard, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("shard_summary_t.to_shard", msg.to_shard, limits.max_robot_name_length));
  const Layout* layout = nullptr;
  SLAMD_RETURN_IF_REJECTED(CheckDimension("shard_summary_t.dimension", msg.dimension, &layout));
  if (msg.num_poses < 1 || msg.num_poses > kMaxSummaryPoses) {
    return Reject(
        RejectReason::kTooManyElements, "shard_summary_t.num_poses",
        std::to_string(msg.num_poses) + " not in [1, " + std::to_string(kMaxSummaryPoses) + "]");
  }
  SLAMD_RETURN_IF_REJECTED(
      CheckCount("shard_summary_t.num_poses", msg.num_poses, msg.poses.size(), -1, ""));
  std::set<std::pair<std::string, std::int64_t>> seen;
  for (std::size_t i = 0; i < msg.poses.size(); ++i) {
    const slamd::key_t& k = msg.poses[i];
    const std::string field = "shard_summary_t.poses[" + std::to_string(i) + "]";
    if (k.kind != slamd::key_t::KIND_POSE) {
      return Reject(RejectReason::kBadKind, field + ".kind", "must be KIND_POSE (1)");
    }
    SLAMD_RETURN_IF_REJECTED(CheckName(field + ".robot", k.robot, limits.max_robot_name_length));
    SLAMD_RETURN_IF_REJECTED(CheckIndex(field + ".index", k.index));
    if (!seen.emplace(k.robot, k.index).second) {
      return Reject(RejectReason::kDuplicate, field, "names a pose listed before");
    }
  }
  const int n = msg.num_poses;
  SLAMD_RETURN_IF_REJECTED(CheckCount("shard_summary_t.num_values", msg.num_values,
                                      msg.values.size(), n * layout->num_values, layout->what));
  SLAMD_RETURN_IF_REJECTED(CheckFinite("shard_summary_t.values", msg.values));
  SLAMD_RETURN_IF_REJECTED(
      CheckMagnitude("shard_summary_t.values", msg.values, limits.max_abs_value));
  if (layout->has_quaternion) {
    for (int i = 0; i < n; ++i) {
      const double* q = msg.values.data() + i * layout->num_values + 3;
      SLAMD_RETURN_IF_REJECTED(CheckUnitQuaternion(
          "shard_summary_t.values[" + std::to_string(i * layout->num_values + 3) + "..]", q[0],
          q[1], q[2], q[3], limits.quaternion_norm_tolerance));
    }
  }
  const int columns = n * layout->cov_dim;
  if (msg.rows < 1 || msg.rows > columns) {
    return Reject(RejectReason::kSizeMismatch, "shard_summary_t.rows",
                  std::to_string(msg.rows) + " not in [1, " + std::to_string(columns) + "]");
  }
  SLAMD_RETURN_IF_REJECTED(CheckCount("shard_summary_t.num_a", msg.num_a, msg.a.size(),
                                      msg.rows * columns, "rows x the poses' tangent dimensions"));
  SLAMD_RETURN_IF_REJECTED(CheckCount("shard_summary_t.rows", msg.rows, msg.b.size(), -1, ""));
  SLAMD_RETURN_IF_REJECTED(CheckFinite("shard_summary_t.a", msg.a));
  return CheckFinite("shard_summary_t.b", msg.b);
}

Checked<ShardSummaryMessage> Convert(const slamd::shard_summary_t& msg, const Limits& limits) {
  Verdict verdict = Validate(msg, limits);
  if (!verdict.ok()) return verdict;
  ShardSummaryMessage m{.utime = msg.utime, .from_shard = msg.from_shard, .to_shard = msg.to_shard};
  const int per = msg.dimension == slamd::shard_summary_t::DIMENSION_2D ? 3 : 7;
  for (int i = 0; i < msg.num_poses; ++i) {
    m.poses.emplace_back(msg.poses[i].robot, static_cast<std::uint64_t>(msg.poses[i].index));
    const std::vector<double> v(msg.values.begin() + i * per, msg.values.begin() + (i + 1) * per);
    m.x0.push_back(std::visit([](const auto& p) -> core::Variable { return p; }, ToPose(v)));
  }
  const int columns = static_cast<int>(msg.a.size()) / msg.rows;
  m.A = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      msg.a.data(), msg.rows, columns);
  m.b = Eigen::Map<const Eigen::VectorXd>(msg.b.data(), msg.rows);
  return m;
}

void ToLcm(const ShardSummaryMessage& m, slamd::shard_summary_t* out) {
  out->utime = m.utime;
  out->from_shard = m.from_shard;
  out->to_shard = m.to_shard;
  const bool is2d = !m.x0.empty() && std::holds_alternative<core::Pose2>(m.x0[0]);
  out->dimension =
      is2d ? slamd::shard_summary_t::DIMENSION_2D : slamd::shard_summary_t::DIMENSION_3D;
  out->poses.clear();
  out->values.clear();
  for (std::size_t i = 0; i < m.poses.size(); ++i) {
    slamd::key_t k;
    k.robot = m.poses[i].first;
    k.kind = slamd::key_t::KIND_POSE;
    k.index = static_cast<std::int64_t>(m.poses[i].second);
    out->poses.push_back(std::move(k));
    const std::vector<double> v = ToValues(m.x0[i]);
    out->values.insert(out->values.end(), v.begin(), v.end());
  }
  out->num_poses = static_cast<std::int32_t>(out->poses.size());
  out->num_values = static_cast<std::int32_t>(out->values.size());
  out->rows = static_cast<std::int32_t>(m.A.rows());
  out->a = ToRowMajor(m.A);
  out->num_a = static_cast<std::int32_t>(out->a.size());
  out->b.assign(m.b.data(), m.b.data() + m.b.size());
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
  core::KeyVector keys;
  std::vector<std::pair<core::Key, const core::Variable*>> foreign;
  for (std::size_t i = 0; i < m.poses.size(); ++i) {
    const auto& [robot, index] = m.poses[i];
    const std::optional<std::uint8_t> id = g.FindOrAddRobot(robot);
    if (!id) {
      *v = {RejectReason::kTooManyElements, "shard_summary_t.poses: more than 255 robots"};
      return Outcome::kRejected;
    }
    const core::Key key = core::MakeKey('x', index, *id);
    if (g.Known(key)) {
      if (g.Estimate(key).index() != m.x0[i].index()) {
        *v = {RejectReason::kBadMeasurement,
              "shard_summary_t.dimension: does not match " + PoseName(robot, index)};
        return Outcome::kRejected;
      }
    } else if (g.policy().shards.Owns(robot)) {
      return Outcome::kHeld;  // a pose of ours that has not arrived yet
    } else {
      foreign.emplace_back(key, &m.x0[i]);
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
