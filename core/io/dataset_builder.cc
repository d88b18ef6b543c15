// DatasetBuilder (reader_internal.h): from vertices and measurements to a Dataset.
#include <algorithm>
#include <queue>
#include <tuple>
#include <unordered_map>

#include "core/base/key.h"
#include "core/factors/between_factor.h"
#include "core/factors/relative_point_factor.h"
#include "core/io/reader_internal.h"

namespace slamd::core::internal {
namespace {

Key PoseKey(std::uint64_t id) { return MakeKey('x', id); }
Key LandmarkKey(std::uint64_t id) { return MakeKey('l', id); }

// a ∘ b, or a ∘ b⁻¹ when `invert_b`; both Pose2 or both Pose3.
Variable ComposePoses(const Variable& a, const Variable& b, bool invert_b) {
  if (const Pose2* a2 = std::get_if<Pose2>(&a)) {
    const Pose2& b2 = std::get<Pose2>(b);
    return a2->Compose(invert_b ? b2.Inverse() : b2);
  }
  const Pose3& b3 = std::get<Pose3>(b);
  return std::get<Pose3>(a).Compose(invert_b ? b3.Inverse() : b3);
}

// pose.TransformFrom(point): a point in the pose's frame to the world frame.
Variable PointToWorld(const Variable& pose, const Variable& point) {
  if (const Pose2* p2 = std::get_if<Pose2>(&pose))
    return p2->TransformFrom(std::get<Point2>(point));
  return std::get<Pose3>(pose).TransformFrom(std::get<Point3>(point));
}

// Stores a vertex unless `id` already has one; `kind` ("pose" / "landmark") names it in the error.
Status AddVertex(const SourceLine& line, std::uint64_t id, const Variable& value, const char* kind,
                 std::map<std::uint64_t, Variable>* vertices, std::vector<std::uint64_t>* ids) {
  if (!vertices->emplace(id, value).second) {
    return line.Problem("duplicate vertex for " + std::string(kind) + " " + std::to_string(id));
  }
  ids->push_back(id);
  return Status::Ok();
}

void SortUnique(std::vector<std::uint64_t>* ids) {
  std::sort(ids->begin(), ids->end());
  ids->erase(std::unique(ids->begin(), ids->end()), ids->end());
}

}  // namespace

DatasetBuilder::DatasetBuilder(std::string path, DatasetFormat format) {
  dataset_.path = std::move(path);
  dataset_.format = format;
}

Status DatasetBuilder::SetDimension(const SourceLine& line, bool is_3d) {
  if (!dimension_set_) {
    dimension_set_ = true;
    dataset_.is_3d = is_3d;
    return Status::Ok();
  }
  if (dataset_.is_3d == is_3d) return Status::Ok();
  return line.Error(dataset_.is_3d ? "a 3D line (the file's first pose line is 3D)"
                                   : "a 2D line (the file's first pose line is 2D)");
}

Status DatasetBuilder::AddPoseVertex(const SourceLine& line, std::uint64_t id,
                                     const Variable& pose) {
  SLAMD_CHECK(std::holds_alternative<Pose3>(pose) == dataset_.is_3d && dimension_set_)
      << "reader bug: SetDimension must precede AddPoseVertex";
  return AddVertex(line, id, pose, "pose", &pose_vertices_, &pose_ids_);
}

Status DatasetBuilder::AddLandmarkVertex(const SourceLine& line, std::uint64_t id,
                                         const Variable& point) {
  SLAMD_CHECK(std::holds_alternative<Point3>(point) == dataset_.is_3d && dimension_set_)
      << "reader bug: SetDimension must precede AddLandmarkVertex";
  return AddVertex(line, id, point, "landmark", &landmark_vertices_, &landmark_ids_);
}

Status DatasetBuilder::AddPoseEdge(const SourceLine& line, std::uint64_t i, std::uint64_t j,
                                   const Variable& measured, NoiseModel noise, bool equivalence) {
  SLAMD_CHECK(std::holds_alternative<Pose3>(measured) == dataset_.is_3d && dimension_set_)
      << "reader bug: SetDimension must precede AddPoseEdge";
  if (i == j) return line.Error("an edge between two different poses");
  edges_.push_back({i, j, measured});
  pose_ids_.push_back(i);
  pose_ids_.push_back(j);
  if (const Pose2* z = std::get_if<Pose2>(&measured)) {
    dataset_.graph.Emplace<BetweenFactor<Pose2>>(PoseKey(i), PoseKey(j), *z, std::move(noise));
  } else {
    dataset_.graph.Emplace<BetweenFactor<Pose3>>(PoseKey(i), PoseKey(j), std::get<Pose3>(measured),
                                                 std::move(noise));
  }
  if (equivalence) {
    ++dataset_.num_equivalences;
  } else {
    ++dataset_.num_pose_edges;
    if (std::max(i, j) - std::min(i, j) != 1) ++dataset_.num_loop_like;
  }
  return Status::Ok();
}

Status DatasetBuilder::AddLandmarkObservation(const SourceLine& line, std::uint64_t pose,
                                              std::uint64_t lm, const Variable& measured,
                                              NoiseModel noise) {
  (void)line;
  SLAMD_CHECK(std::holds_alternative<Point3>(measured) == dataset_.is_3d && dimension_set_)
      << "reader bug: SetDimension must precede AddLandmarkObservation";
  observations_.push_back({pose, lm, measured});
  pose_ids_.push_back(pose);
  landmark_ids_.push_back(lm);
  if (const Point2* z = std::get_if<Point2>(&measured)) {
    dataset_.graph.Emplace<RelativePointFactor<Pose2, Point2>>(PoseKey(pose), LandmarkKey(lm), *z,
                                                               std::move(noise));
  } else {
    dataset_.graph.Emplace<RelativePointFactor<Pose3, Point3>>(
        PoseKey(pose), LandmarkKey(lm), std::get<Point3>(measured), std::move(noise));
  }
  ++dataset_.num_landmark_observations;
  return Status::Ok();
}

// Repeated passes over the edges in file order (dataset.h) give each pose a "label": the pass p
// and the file index q of the edge that sets it (seeds: (0, -1)). An edge e = (u, v) with u set
// at (p, q) fires in pass p if it comes after q in the file, and in pass p + 1 otherwise, so it
// offers v the label (p, e) or (p + 1, e). v is set by the smallest offer: Dijkstra's algorithm
// on these lexicographic labels, which reproduces the passes exactly in O(E log E).
Status DatasetBuilder::InitialPoses(const ReadOptions& options,
                                    std::map<std::uint64_t, Variable>* poses) const {
  // Incident edges of each pose, in file order.
  std::unordered_map<std::uint64_t, std::vector<int>> incident;
  for (int e = 0; e < static_cast<int>(edges_.size()); ++e) {
    incident[edges_[e].i].push_back(e);
    incident[edges_[e].j].push_back(e);
  }
  // Dijkstra on (pass, edge index) labels from `seeds` (all labelled (0, -1)).
  // Queue entries: (pass, edge, target pose).
  const auto propagate = [&](const std::vector<std::uint64_t>& seeds) {
    using Offer = std::tuple<int, int, std::uint64_t>;
    std::priority_queue<Offer, std::vector<Offer>, std::greater<Offer>> queue;
    const auto offer_from = [&](std::uint64_t u, int pass, int set_by) {
      for (const int e : incident[u]) {
        const std::uint64_t v = edges_[e].i == u ? edges_[e].j : edges_[e].i;
        if (poses->count(v) == 0) queue.emplace(e > set_by ? pass : pass + 1, e, v);
      }
    };
    for (const std::uint64_t id : seeds) offer_from(id, 0, -1);
    while (!queue.empty()) {
      const auto [pass, e, v] = queue.top();
      queue.pop();
      if (poses->count(v) != 0) continue;
      const PoseEdge& edge = edges_[e];
      // x_j = x_i ∘ z, x_i = x_j ∘ z⁻¹.
      (*poses)[v] = v == edge.j ? ComposePoses(poses->at(edge.i), edge.measured, false)
                                : ComposePoses(poses->at(edge.j), edge.measured, true);
      offer_from(v, pass, e);
    }
  };

  // 1. From the vertices (unless told to ignore them).
  if (!options.compose_initial_from_odometry) {
    *poses = pose_vertices_;
    std::vector<std::uint64_t> seeds;
    for (const auto& [id, pose] : pose_vertices_) seeds.push_back(id);
    propagate(seeds);
  }
  // 2. The lowest id, if still unknown, starts at its vertex (compose mode) or the identity.
  const std::uint64_t first = pose_ids_.front();  // sorted: the lowest id
  if (poses->count(first) == 0) {
    const auto it = pose_vertices_.find(first);
    (*poses)[first] = it != pose_vertices_.end() ? it->second
                      : dataset_.is_3d           ? Variable(Pose3())
                                                 : Variable(Pose2());
    propagate({first});
  }
  // 3. Poses no chain reaches.
  for (const std::uint64_t id : pose_ids_) {
    if (poses->count(id) == 0) {
      return DataLoss(dataset_.path + ": cannot initialise pose " + KeyToString(PoseKey(id)) +
                      ": it has no vertex, and no chain of pose-pose edges reaches it from a pose"
                      " with one (or from the lowest pose id)");
    }
  }
  return Status::Ok();
}

void DatasetBuilder::InitialLandmarks(const ReadOptions& options,
                                      const std::map<std::uint64_t, Variable>& poses,
                                      std::map<std::uint64_t, Variable>* landmarks) const {
  if (!options.compose_initial_from_odometry) *landmarks = landmark_vertices_;
  for (const Observation& obs : observations_) {
    if (landmarks->count(obs.landmark) == 0) {
      (*landmarks)[obs.landmark] = PointToWorld(poses.at(obs.pose), obs.measured);
    }
  }
  // A landmark nobody observes keeps its vertex even when vertices are otherwise ignored.
  for (const auto& [id, point] : landmark_vertices_) landmarks->emplace(id, point);
}

Result<Dataset> DatasetBuilder::Finish(const ReadOptions& options) && {
  SortUnique(&pose_ids_);
  SortUnique(&landmark_ids_);
  if (pose_ids_.empty()) {
    return DataLoss(dataset_.path + ": expected at least one pose, found none");
  }
  for (const Fixed& fixed : fixed_) {
    if (!std::binary_search(pose_ids_.begin(), pose_ids_.end(), fixed.id)) {
      return DataLoss(dataset_.path + ":" + std::to_string(fixed.line) + ": FIX names pose " +
                      std::to_string(fixed.id) + ", which no vertex or edge mentions");
    }
    dataset_.fixed.push_back(PoseKey(fixed.id));
  }

  std::map<std::uint64_t, Variable> poses;
  SLAMD_RETURN_IF_ERROR(InitialPoses(options, &poses));
  std::map<std::uint64_t, Variable> landmarks;
  InitialLandmarks(options, poses, &landmarks);

  // Insert fails only for a non-finite value: a composition of huge measurements that overflowed.
  const auto insert = [this](Key key, const Variable& value) -> Status {
    if (dataset_.initial.Insert(key, value).ok()) return Status::Ok();
    return DataLoss(dataset_.path + ": the initial guess of " + KeyToString(key) +
                    " is not finite (the measurements composed to reach it overflow)");
  };
  for (const std::uint64_t id : pose_ids_) {
    dataset_.poses.push_back(PoseKey(id));
    SLAMD_RETURN_IF_ERROR(insert(PoseKey(id), poses.at(id)));
  }
  for (const std::uint64_t id : landmark_ids_) {
    dataset_.landmarks.push_back(LandmarkKey(id));
    SLAMD_RETURN_IF_ERROR(insert(LandmarkKey(id), landmarks.at(id)));
  }
  return std::move(dataset_);
}

}  // namespace slamd::core::internal
