// Estimator's answers: pose estimates, keys, marginals, and the EstimateSnapshot it publishes.
#include <chrono>

#include "server/estimator/estimator.h"

namespace slamd::server {

using core::Key;
using core::MakeKey;
using core::Variable;

core::Result<Variable> Estimator::PoseEstimate(const std::string& robot,
                                               std::uint64_t index) const {
  const auto id = registry_.Find(robot);
  const Key key = id ? MakeKey('x', index, *id) : 0;
  if (id) {
    if (const auto alias = reduced_.aliases.find(key); alias != reduced_.aliases.end()) {
      return AliasEstimate(alias->second);
    }
  }
  if (!id || !isam_->linearization_point().Contains(key)) {
    return core::NotFound(PoseName(robot, index) + " is not in the graph");
  }
  return isam_->CalculateEstimate(key);
}

std::optional<Key> Estimator::KeyOf(const WireKey& key) const {
  if (key.index > core::kMaxKeyIndex) return std::nullopt;
  Key k;
  if (key.kind == KeyKind::kMapLandmark) {
    k = MapLandmarkKey(key.index);
  } else {
    const auto id = registry_.Find(key.robot);
    if (!id) return std::nullopt;
    k = MakeKey(key.kind == KeyKind::kPose ? 'x' : 'l', key.index, *id);
  }
  if (!isam_->linearization_point().Contains(k)) return std::nullopt;
  return k;
}

core::Status Estimator::Marginal(Key key, Eigen::MatrixXd* cov) {
  return marginals_->Marginal(key, core::Isam2Marginals::Frame::kEstimate, cov);
}

core::Status Estimator::JointMarginal(std::span<const Key> keys, Eigen::MatrixXd* cov) {
  return marginals_->JointMarginal(keys, core::Isam2Marginals::Frame::kEstimate, cov);
}

void Estimator::ComputeAllMarginals() { marginals_->ComputeAll(); }

core::Status Estimator::CachedMarginal(Key key, Eigen::MatrixXd* cov) const {
  return marginals_->CachedMarginal(key, core::Isam2Marginals::Frame::kEstimate, cov);
}

void Estimator::PublishSnapshot(bool bump) {
  if (bump) ++sequence_;
  auto snap = std::make_shared<EstimateSnapshot>();
  snap->update_sequence = sequence_;
  snap->num_variables = static_cast<std::int64_t>(isam_->linearization_point().size());
  snap->num_factors = num_factors_;
  snap->residual_dimension = residual_dimension_;
  snap->held_messages = static_cast<int>(held_.size());
  snap->landmark_tracks = tracks_.num_tracks();
  snap->track_observations = tracks_.num_observations();
  snap->settled = settled_;
  // chi2 is O(factors): after every update it would dominate a long run's update time. It is
  // recomputed at most every chi2_interval_s and at most 2% of the time, and whenever the
  // estimate settles; a swapped-in rebuild brings one computed on its helper thread.
  constexpr double kChi2MaxLoad = 0.02;
  const auto now = std::chrono::steady_clock::now();
  const double since = std::chrono::duration<double>(now - chi2_time_).count();
  const double interval = params_.chi2_interval_s;
  const bool due = since >= interval && (interval == 0.0 || since * kChi2MaxLoad >= chi2_cost_s_);
  const bool solved = !isam_->back_substitution_pending();  // chi2 needs all of δ
  if (solved && (chi2_sequence_ < 0 || (chi2_sequence_ != sequence_ && (due || settled_)))) {
    chi2_ = isam_->Chi2();
    chi2_sequence_ = sequence_;
    chi2_time_ = std::chrono::steady_clock::now();
    chi2_cost_s_ = std::chrono::duration<double>(chi2_time_ - now).count();
  }
  snap->chi2 = chi2_;
  snap->chi2_sequence = chi2_sequence_;
  for (std::uint8_t id : registry_.ids()) {
    RobotState& r = robots_[id];
    if (!r.anchored) continue;
    if (bump) {
      const Key newest = MakeKey('x', r.newest, id);
      const auto alias = reduced_.aliases.find(newest);
      const Variable pose = alias == reduced_.aliases.end() ? isam_->CalculateEstimate(newest)
                                                            : AliasEstimate(alias->second);
      const bool moved = r.moved_sequence == 0 || r.published_index != r.newest ||
                         pose.index() != r.published.index() ||
                         core::LocalCoordinates(r.published, pose).squaredNorm() > 0.0;
      if (moved) {
        r.published = pose;
        r.published_index = r.newest;
        r.moved_sequence = sequence_;
      }
    }
    if (r.moved_sequence == 0) continue;  // anchored by a batch that failed or not updated yet
    snap->robots.push_back({registry_.Name(id), id, r.published_index, r.published,
                            r.moved_sequence, r.measurement_utime, r.received_us});
  }
  snap->counters = counters_;
  snapshot_ = std::move(snap);
}

}  // namespace slamd::server
