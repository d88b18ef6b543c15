// LandmarkTracks: the observations of landmarks not in the graph yet, each landmark's held until
// its views determine it (frame_observations.h). Ordered by key, so that what a journal replay
// does with them is what the live server did. Changes since the last Commit can be undone (an
// update the solver refused undoes its batch). Estimator thread only.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/base/key.h"
#include "server/messages/frame_observations.h"

namespace slamd::server {

class LandmarkTracks {
 public:
  struct Track {
    std::vector<FrameObservations> observations;  // one feature each, in arrival order
    std::string why;         // why its views did not determine it at the last try
    int waited = 0;          // updates it has waited through
    std::int64_t first = 0;  // order of creation (the oldest is dropped first)
  };

  // The landmark's track; null when it has none.
  const Track* Find(core::Key landmark) const;
  // Appends a one-feature observation to the landmark's track (made when it has none).
  const Track& Add(core::Key landmark, FrameObservations one_feature);
  void SetReason(core::Key landmark, std::string why);
  // Add for a snapshot's restore: no undo record, and the track has waited `waited` updates.
  void Restore(core::Key landmark, FrameObservations one_feature, int waited);
  void Erase(core::Key landmark);

  void Commit() { before_.clear(); }
  void Rollback();

  // One more update waited by every track. Returns (and removes) the tracks that have now
  // waited more than max_wait updates, then the oldest while more than max_observations are
  // held in all.
  std::vector<std::pair<core::Key, Track>> Age(int max_wait, int max_observations);

  int num_tracks() const { return static_cast<int>(tracks_.size()); }
  int num_observations() const { return observations_; }
  const std::map<core::Key, Track>& tracks() const { return tracks_; }

 private:
  void Remember(core::Key landmark);  // its state before this batch's first change
  Track& Append(core::Key landmark, FrameObservations one_feature);

  std::map<core::Key, Track> tracks_;
  std::vector<std::pair<core::Key, std::optional<Track>>> before_;
  int observations_ = 0;
  std::int64_t next_ = 0;
};

}  // namespace slamd::server
