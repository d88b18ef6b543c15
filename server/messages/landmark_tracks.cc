#include "server/messages/landmark_tracks.h"

#include <algorithm>

namespace slamd::server {

const LandmarkTracks::Track* LandmarkTracks::Find(core::Key landmark) const {
  const auto it = tracks_.find(landmark);
  return it == tracks_.end() ? nullptr : &it->second;
}

void LandmarkTracks::Remember(core::Key landmark) {
  for (const auto& [key, track] : before_) {
    if (key == landmark) return;
  }
  const auto it = tracks_.find(landmark);
  before_.emplace_back(landmark,
                       it == tracks_.end() ? std::nullopt : std::optional<Track>(it->second));
}

LandmarkTracks::Track& LandmarkTracks::Append(core::Key landmark, FrameObservations one_feature) {
  auto [it, inserted] = tracks_.try_emplace(landmark);
  if (inserted) it->second.first = next_++;
  it->second.observations.push_back(std::move(one_feature));
  ++observations_;
  return it->second;
}

const LandmarkTracks::Track& LandmarkTracks::Add(core::Key landmark,
                                                 FrameObservations one_feature) {
  Remember(landmark);
  return Append(landmark, std::move(one_feature));
}

void LandmarkTracks::Restore(core::Key landmark, FrameObservations one_feature, int waited) {
  Append(landmark, std::move(one_feature)).waited = waited;
}

void LandmarkTracks::SetReason(core::Key landmark, std::string why) {
  const auto it = tracks_.find(landmark);
  if (it == tracks_.end()) return;
  Remember(landmark);
  it->second.why = std::move(why);
}

void LandmarkTracks::Erase(core::Key landmark) {
  const auto it = tracks_.find(landmark);
  if (it == tracks_.end()) return;
  Remember(landmark);
  observations_ -= static_cast<int>(it->second.observations.size());
  tracks_.erase(it);
}

void LandmarkTracks::Rollback() {
  // One record per key (Remember): each key back to its state before the batch.
  for (auto& [key, before] : before_) {
    const auto current = tracks_.find(key);
    if (current != tracks_.end()) {
      observations_ -= static_cast<int>(current->second.observations.size());
      tracks_.erase(current);
    }
    if (before) {
      observations_ += static_cast<int>(before->observations.size());
      tracks_.emplace(key, std::move(*before));
    }
  }
  before_.clear();
}

std::vector<std::pair<core::Key, LandmarkTracks::Track>> LandmarkTracks::Age(int max_wait,
                                                                             int max_observations) {
  std::vector<std::pair<core::Key, Track>> dropped;
  for (auto it = tracks_.begin(); it != tracks_.end();) {
    if (++it->second.waited > max_wait) {
      observations_ -= static_cast<int>(it->second.observations.size());
      dropped.emplace_back(it->first, std::move(it->second));
      it = tracks_.erase(it);
    } else {
      ++it;
    }
  }
  while (observations_ > max_observations) {
    const auto oldest = std::min_element(
        tracks_.begin(), tracks_.end(),
        [](const auto& a, const auto& b) { return a.second.first < b.second.first; });
    observations_ -= static_cast<int>(oldest->second.observations.size());
    dropped.emplace_back(oldest->first, std::move(oldest->second));
    tracks_.erase(oldest);
  }
  return dropped;
}

}  // namespace slamd::server
