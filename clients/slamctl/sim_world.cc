// Synthetic worlds: the generators and the per-robot datasets. Writing them: sim_world_io.cc.
#include "clients/slamctl/sim_world.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>

#include "clients/slamctl/sim_rng.h"
#include "core/base/key.h"
#include "core/base/param_check.h"
#include "core/factors/between_factor.h"
#include "core/factors/relative_point_factor.h"

namespace slamd::clients::sim {

using core::NoiseModel;
using core::Point2;
using core::Point3;
using core::Pose2;
using core::Pose3;
using core::Rot3;
using core::Variable;

const char* WorldKindName(WorldKind kind) {
  switch (kind) {
    case WorldKind::kManhattan:
      return "manhattan";
    case WorldKind::kLandmarks:
      return "landmarks";
    case WorldKind::kSphere:
      return "sphere";
    case WorldKind::kHelix:
      return "helix";
  }
  return "?";
}

bool ParseWorldKind(const std::string& name, WorldKind* kind) {
  for (WorldKind k :
       {WorldKind::kManhattan, WorldKind::kLandmarks, WorldKind::kSphere, WorldKind::kHelix}) {
    if (name == WorldKindName(k)) {
      *kind = k;
      return true;
    }
  }
  return false;
}

int DefaultSteps(WorldKind kind) {
  switch (kind) {
    case WorldKind::kManhattan:
      return 1000;
    case WorldKind::kLandmarks:
      return 500;
    case WorldKind::kSphere:
      return 1024;
    case WorldKind::kHelix:
      return 1000;
  }
  return 1000;
}

core::Status SimParams::Validate() const {
  SLAMD_PARAM_CHECK(SimParams, steps, >=, 0);
  if (steps == 1) return core::InvalidArgument("SimParams::steps = 1; violates >= 2 (or 0)");
  SLAMD_PARAM_CHECK(SimParams, robots, >=, 1);
  SLAMD_PARAM_CHECK(SimParams, robots, <=, 1000);
  SLAMD_PARAM_CHECK(SimParams, sigma_translation, >=, 0.0);
  SLAMD_PARAM_CHECK(SimParams, sigma_rotation, >=, 0.0);
  SLAMD_PARAM_CHECK(SimParams, loop_probability, >=, 0.0);
  SLAMD_PARAM_CHECK(SimParams, loop_probability, <=, 1.0);
  SLAMD_PARAM_CHECK(SimParams, outliers, >=, 0.0);
  SLAMD_PARAM_CHECK(SimParams, outliers, <=, 1.0);
  SLAMD_PARAM_CHECK(SimParams, landmarks, >=, 0);
  SLAMD_PARAM_CHECK(SimParams, side, >=, 0);
  SLAMD_PARAM_CHECK(SimParams, patrol, >=, 0);
  SLAMD_PARAM_CHECK(SimParams, sensor_range, >, 0.0);
  SLAMD_PARAM_CHECK(SimParams, sigma_bearing, >=, 0.0);
  SLAMD_PARAM_CHECK(SimParams, sigma_range, >=, 0.0);
  SLAMD_PARAM_CHECK(SimParams, sigma_point, >=, 0.0);
  const std::pair<const char*, double> finite[] = {{"sigma_translation", sigma_translation},
                                                   {"sigma_rotation", sigma_rotation},
                                                   {"sigma_bearing", sigma_bearing},
                                                   {"sigma_range", sigma_range},
                                                   {"sigma_point", sigma_point},
                                                   {"sensor_range", sensor_range}};
  for (const auto& [name, value] : finite) {
    if (!std::isfinite(value)) {
      return core::InvalidArgument(std::string("SimParams::") + name + " = " +
                                   std::to_string(value) + "; violates finite");
    }
  }
  // The noise models must stay within NoiseModel's condition limit (1e14; 1e12 leaves margin):
  // the squared ratio of the largest to the smallest sigma of one model.
  const auto floor = [](double s) { return s > 0.0 ? s : kZeroSigmaFloor; };
  const auto ratio = [](double a, double b) { return std::max(a, b) / std::min(a, b); };
  const auto too_far = [](const char* name, double value, const char* other, double other_value) {
    return core::InvalidArgument(std::string("SimParams::") + name + " = " + std::to_string(value) +
                                 " is too far from " + other + " = " + std::to_string(other_value) +
                                 ": the noise model's condition number (largest / smallest "
                                 "sigma, squared) would exceed 1e12");
  };
  if (std::pow(ratio(floor(sigma_translation), floor(sigma_rotation)), 2) > 1e12) {
    return too_far("sigma_translation", sigma_translation, "sigma_rotation", sigma_rotation);
  }
  // Bearing-range: the point covariance has axes σr and r·σb, r in [0.1, sensor_range].
  if (world == WorldKind::kLandmarks && observation == ObservationKind::kBearingRange) {
    const double sb = floor(sigma_bearing), sr = floor(sigma_range);
    if (std::pow(std::max(ratio(0.1 * sb, sr), ratio(sensor_range * sb, sr)), 2) > 1e12) {
      return too_far("sigma_bearing", sigma_bearing, "sigma_range", sigma_range);
    }
  }
  return core::Status::Ok();
}

namespace {

constexpr double kPi = std::numbers::pi;

double Floor(double sigma) { return sigma > 0.0 ? sigma : kZeroSigmaFloor; }

NoiseModel PoseNoise(const SimParams& p, bool is_3d) {
  const double st = Floor(p.sigma_translation), sr = Floor(p.sigma_rotation);
  Eigen::VectorXd sigmas = is_3d ? Eigen::VectorXd(6) : Eigen::VectorXd(3);
  if (is_3d) {
    sigmas << st, st, st, sr, sr, sr;
  } else {
    sigmas << st, st, sr;
  }
  return NoiseModel::Diagonal(sigmas).value();
}

// The state of generation shared by every world.
class Generator {
 public:
  explicit Generator(const SimParams& params) : p_(params), rng_(params.seed) {
    world_.params = params;
    world_.is_3d = params.world == WorldKind::kSphere || params.world == WorldKind::kHelix;
    if (world_.params.steps == 0) world_.params.steps = DefaultSteps(params.world);
    steps_ = world_.params.steps;
    per_ring_ = std::max(4, static_cast<int>(std::lround(std::sqrt(steps_))));
    side_ = p_.side > 0
                ? std::max(4, p_.side)
                : std::max(4, static_cast<int>(std::ceil(std::sqrt(steps_ * p_.robots / 2.0))));
    world_.truth.resize(p_.robots);
    world_.initial.resize(p_.robots);
    pose_noise_ = PoseNoise(p_, world_.is_3d);
  }

  SimWorld Run() {
    if (world_.params.world == WorldKind::kLandmarks) PlaceLandmarks();
    // 1. Every step, robot by robot: the true pose, odometry, loop closures, observations.
    std::vector<GridState> grid(p_.robots);
    for (int k = 0; k < p_.robots; ++k) grid[k] = GridStart(k);
    std::vector<std::vector<std::int64_t>> nodes(p_.robots);
    for (int t = 0; t < steps_; ++t) {
      for (int k = 0; k < p_.robots; ++k) {
        std::int64_t node;
        std::vector<std::int64_t> candidates;
        const Variable pose = world_.is_3d ? Variable(Pose3At(k, t, &node, &candidates))
                                           : Variable(GridStep(t, &grid[k], &node, &candidates));
        AddPose(k, t, pose);
        LoopClosures(k, t, candidates);
        if (world_.params.world == WorldKind::kLandmarks) Observe(k, t);
        by_node_[node].push_back({k, t});
      }
    }
    // 2. Outliers replace loop closures in place.
    AddOutliers();
    // 3. Landmarks nobody observed are dropped; the others renumbered in order.
    if (world_.params.world == WorldKind::kLandmarks) DropUnobservedLandmarks();
    return std::move(world_);
  }

 private:
  struct GridState {
    int cx = 0, cy = 0, heading = 0;  // heading: 0 = +x, 1 = +y, 2 = -x, 3 = -y
    std::vector<std::array<int, 3>> route;  // patrol: (cx, cy, heading) of each step so far
  };
  struct PoseRef {
    int robot, idx;
  };

  // Grid cells span [lo, lo + side) on both axes; robot 0 starts at the cell (0, 0).
  int Lo() const { return -side_ / 2; }
  bool Inside(int cx, int cy) const {
    return cx >= Lo() && cx < Lo() + side_ && cy >= Lo() && cy < Lo() + side_;
  }
  std::int64_t CellNode(int cx, int cy) const {
    return static_cast<std::int64_t>(cx - Lo()) * side_ + (cy - Lo());
  }
  GridState GridStart(int robot) {
    if (robot == 0 || world_.is_3d) return GridState{};
    GridState s;
    s.cx = Lo() + rng_.Index(side_);
    s.cy = Lo() + rng_.Index(side_);
    s.heading = rng_.Index(4);
    return s;
  }

  // Random turns: left or right with probability 0.15 each; at a wall, turn left or right at
  // random, and back only when both are blocked.
  Pose2 GridStep(int t, GridState* s, std::int64_t* node, std::vector<std::int64_t>* candidates) {
    static constexpr int kDx[4] = {1, 0, -1, 0}, kDy[4] = {0, 1, 0, -1};
    const int patrol = p_.patrol;
    if (patrol > 0 && t > patrol) {  // the closed route, again and again
      if (t == patrol + 1) CloseRoute(s);
      const std::array<int, 3>& at = s->route[static_cast<std::size_t>(t) % s->route.size()];
      s->cx = at[0];
      s->cy = at[1];
      s->heading = at[2];
    } else if (t > 0) {
      const double u = rng_.Uniform();
      int h = u < 0.15 ? (s->heading + 1) % 4 : u < 0.3 ? (s->heading + 3) % 4 : s->heading;
      const int side_turn = rng_.Uniform() < 0.5 ? 1 : 3;
      for (int h_try : {h, (h + side_turn) % 4, (h + 4 - side_turn) % 4, (h + 2) % 4}) {
        if (Inside(s->cx + kDx[h_try], s->cy + kDy[h_try])) {
          h = h_try;
          break;
        }
      }
      s->heading = h;
      s->cx += kDx[h];
      s->cy += kDy[h];
    }
    if (patrol > 0 && t <= patrol) s->route.push_back({s->cx, s->cy, s->heading});
    *node = CellNode(s->cx, s->cy);
    *candidates = {*node};
    return Pose2(s->cx, s->cy, s->heading * kPi / 2);
  }

  // Patrol: the walk so far (steps 0..patrol) plus the way back to its start, x first, then y,
  // so that step t of the route is route[t % size] (the last cell is next to the start).
  void CloseRoute(GridState* s) {
    const std::array<int, 3> start = s->route.front();
    int cx = s->route.back()[0], cy = s->route.back()[1];
    if (cx == start[0] && cy == start[1]) {  // the walk ended where it began
      s->route.front()[2] = s->route.back()[2];
      s->route.pop_back();
      return;
    }
    while (cx != start[0] || cy != start[1]) {
      int heading;
      if (cx != start[0]) {
        heading = cx < start[0] ? 0 : 2;
        cx += cx < start[0] ? 1 : -1;
      } else {
        heading = cy < start[1] ? 1 : 3;
        cy += cy < start[1] ? 1 : -1;
      }
      if (cx == start[0] && cy == start[1]) {  // back at the start: step 0 of the next lap,
        s->route.front()[2] = heading;         // heading as it arrives
        break;
      }
      s->route.push_back({cx, cy, heading});
    }
  }

  // Sphere: ring r = g / n, column c; helix: turn g / n. g = t (+ the robot's offset).
  Pose3 Pose3At(int robot, int t, std::int64_t* node, std::vector<std::int64_t>* candidates) {
    const int n = per_ring_;
    const int offset = robot * n / p_.robots;
    const double radius = n / (2 * kPi);  // about 1 m between poses
    if (world_.params.world == WorldKind::kSphere) {
      const int rings = (steps_ + n - 1) / n;
      const int r = t / n, c = (t % n + offset) % n;
      const double lat = -kPi / 2 + kPi * (r + 0.5) / rings, lon = 2 * kPi * c / n;
      const Point3 up(std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat));
      const Point3 east(-std::sin(lon), std::cos(lon), 0.0);
      core::Matrix3 R;
      R.col(0) = east;
      R.col(1) = up.cross(east);
      R.col(2) = up;
      *node = static_cast<std::int64_t>(r) * n + c;
      *candidates = {*node, *node - n};
      return Pose3(Rot3(R), radius * up);
    }
    const int g = t + offset;
    const double angle = 2 * kPi * (g % n) / n;
    *node = g;
    *candidates = {*node, *node - n};
    return Pose3(
        Rot3::FromRollPitchYaw(0, 0, angle + kPi / 2),
        Point3(radius * std::cos(angle), radius * std::sin(angle), static_cast<double>(g) / n));
  }

  // A noisy between measurement with error exactly n at the truth (sim_world.h).
  Variable MeasureBetween(const Variable& a, const Variable& b) {
    if (world_.is_3d) {
      core::Vector6 n;
      for (int i = 0; i < 6; ++i) n(i) = Sample(i < 3 ? p_.sigma_translation : p_.sigma_rotation);
      return std::get<Pose3>(a).Between(std::get<Pose3>(b)) * Pose3::Exp(n).Inverse();
    }
    const double nx = Sample(p_.sigma_translation), ny = Sample(p_.sigma_translation);
    const double nt = Sample(p_.sigma_rotation);
    return std::get<Pose2>(a).Between(std::get<Pose2>(b)) * Pose2(nx, ny, nt).Inverse();
  }
  // Always draws, so that noise_free and noisy worlds of one seed share everything else.
  double Sample(double sigma) {
    const double z = rng_.Normal();
    return p_.noise_free ? 0.0 : sigma * z;
  }

  void AddPose(int k, int t, Variable truth) {
    // Robot 0 starts at the identity: 3D worlds are moved into its first frame.
    if (world_.is_3d) {
      if (k == 0 && t == 0) frame_ = std::get<Pose3>(truth).Inverse();
      truth = frame_ * std::get<Pose3>(truth);
    }
    world_.truth[k].push_back(truth);
    if (t == 0) {
      world_.initial[k].push_back(truth);
      return;
    }
    SimEdge e{.kind = SimEdge::Kind::kOdometry,
              .robot_a = k,
              .idx_a = t - 1,
              .robot_b = k,
              .idx_b = t,
              .measured = MeasureBetween(world_.truth[k][t - 1], truth),
              .noise = pose_noise_};
    const Variable& prev = world_.initial[k][t - 1];
    world_.initial[k].push_back(
        world_.is_3d ? Variable(std::get<Pose3>(prev) * std::get<Pose3>(e.measured))
                     : Variable(std::get<Pose2>(prev) * std::get<Pose2>(e.measured)));
    world_.edges.push_back(std::move(e));
  }

  void LoopClosures(int k, int t, const std::vector<std::int64_t>& candidates) {
    int added = 0;
    const int max_loops = world_.is_3d ? 2 : kMaxLoopsPerPose;
    for (const std::int64_t node : candidates) {
      const auto it = by_node_.find(node);
      if (it == by_node_.end()) continue;
      const std::vector<PoseRef>& visits = it->second;
      for (std::size_t i = 0; i < visits.size(); ++i) {
        // Patrols close loops with the latest visits (the last laps), random walks with the
        // first ones.
        const PoseRef& ref = visits[p_.patrol > 0 ? visits.size() - 1 - i : i];
        if (ref.robot == k && ref.idx >= t - 1) continue;
        if (added >= max_loops || rng_.Uniform() >= p_.loop_probability) continue;
        ++added;
        world_.edges.push_back(SimEdge{
            .kind = ref.robot == k ? SimEdge::Kind::kLoop : SimEdge::Kind::kInterRobot,
            .robot_a = ref.robot,
            .idx_a = ref.idx,
            .robot_b = k,
            .idx_b = t,
            .measured = MeasureBetween(world_.truth[ref.robot][ref.idx], world_.truth[k][t]),
            .noise = pose_noise_});
      }
    }
  }

  void PlaceLandmarks() {
    if (world_.params.landmarks == 0) world_.params.landmarks = std::max(1, side_ * side_ / 4);
    for (int i = 0; i < world_.params.landmarks; ++i) {
      const double x = rng_.Uniform(Lo() - 0.5, Lo() + side_ - 0.5);
      const double y = rng_.Uniform(Lo() - 0.5, Lo() + side_ - 0.5);
      world_.landmarks.emplace_back(x, y);
    }
  }

  void Observe(int k, int t) {
    const Pose2& x = std::get<Pose2>(world_.truth[k][t]);
    for (int l = 0; l < static_cast<int>(world_.landmarks.size()); ++l) {
      const Point2 d = x.TransformTo(world_.landmarks[l]);
      const double range = d.norm();
      if (range < 0.1 || range > p_.sensor_range) continue;  // too close: bearing ill-defined
      SimObservation o{.robot = k, .idx = t, .landmark = l};
      if (p_.observation == ObservationKind::kRelativePoint) {
        const double nx = Sample(p_.sigma_point), ny = Sample(p_.sigma_point);
        o.point = d + Point2(nx, ny);
        o.noise = NoiseModel::Isotropic(2, Floor(p_.sigma_point)).value();
      } else {
        const double nb = Sample(p_.sigma_bearing), nr = Sample(p_.sigma_range);
        o.bearing = std::atan2(d.y(), d.x()) + nb;
        o.range = range + nr;
        const double c = std::cos(o.bearing), s = std::sin(o.bearing);
        o.point = Point2(o.range * c, o.range * s);
        // First-order covariance of r·(cos b, sin b): J = ∂point/∂(b, r).
        core::Matrix2 J;
        J << -o.range * s, c, o.range * c, s;
        const core::Matrix2 S = Eigen::Vector2d(Floor(p_.sigma_bearing), Floor(p_.sigma_range))
                                    .array()
                                    .square()
                                    .matrix()
                                    .asDiagonal();
        o.noise = NoiseModel::FromCovariance(J * S * J.transpose()).value();
      }
      world_.observations.push_back(std::move(o));
    }
  }

  void AddOutliers() {
    std::vector<int> loops;
    for (int i = 0; i < static_cast<int>(world_.edges.size()); ++i) {
      if (world_.edges[i].kind != SimEdge::Kind::kOdometry) loops.push_back(i);
    }
    const int count = static_cast<int>(std::llround(p_.outliers * loops.size()));
    const double size = world_.is_3d ? per_ring_ / kPi : side_;
    for (int i = 0; i < count; ++i) {  // partial Fisher–Yates: the first `count` of a shuffle
      std::swap(loops[i], loops[i + rng_.Index(static_cast<int>(loops.size()) - i)]);
      SimEdge& e = world_.edges[loops[i]];
      e.outlier = true;
      // The later pose (robot_b, idx_b) stays, so the edge arrives at the same time; the earlier
      // one is drawn among the poses robot_a had then.
      const int available = e.robot_a == e.robot_b  ? e.idx_b - 1
                            : e.robot_a < e.robot_b ? e.idx_b + 1
                                                    : e.idx_b;
      e.idx_a = rng_.Index(std::max(1, available));
      if (world_.is_3d) {
        const double qw = rng_.Normal(), qx = rng_.Normal(), qy = rng_.Normal(), qz = rng_.Normal();
        const Point3 t(rng_.Uniform(-size, size), rng_.Uniform(-size, size),
                       rng_.Uniform(-size, size));
        e.measured = Pose3(Rot3::FromQuaternion(qw, qx, qy, qz), t);
      } else {
        const double x = rng_.Uniform(-size, size), y = rng_.Uniform(-size, size);
        e.measured = Pose2(x, y, rng_.Uniform(-kPi, kPi));
      }
    }
  }

  void DropUnobservedLandmarks() {
    std::vector<int> new_id(world_.landmarks.size(), -1);
    for (const SimObservation& o : world_.observations) new_id[o.landmark] = 0;
    std::vector<Point2> kept;
    for (std::size_t l = 0; l < new_id.size(); ++l) {
      if (new_id[l] < 0) continue;
      new_id[l] = static_cast<int>(kept.size());
      kept.push_back(world_.landmarks[l]);
    }
    world_.landmarks = std::move(kept);
    for (SimObservation& o : world_.observations) o.landmark = new_id[o.landmark];
  }

  const SimParams& p_;
  Rng rng_;
  SimWorld world_;
  int steps_ = 0, per_ring_ = 4, side_ = 4;
  NoiseModel pose_noise_ = NoiseModel::Unit(3);
  Pose3 frame_;                                           // 3D: world -> robot 0's first frame
  std::map<std::int64_t, std::vector<PoseRef>> by_node_;  // poses registered at each node
};

}  // namespace

core::Result<SimWorld> Generate(const SimParams& params) {
  SLAMD_RETURN_IF_ERROR(params.Validate());
  return Generator(params).Run();
}

namespace {

// Landmark ids a robot observes, ascending.
std::vector<int> ObservedBy(const SimWorld& world, int robot) {
  std::vector<bool> seen(world.landmarks.size(), false);
  for (const SimObservation& o : world.observations) {
    if (o.robot == robot) seen[o.landmark] = true;
  }
  std::vector<int> ids;
  for (std::size_t l = 0; l < seen.size(); ++l) {
    if (seen[l]) ids.push_back(static_cast<int>(l));
  }
  return ids;
}

}  // namespace

core::Dataset RobotDataset(const SimWorld& world, int robot, std::vector<int>* factor_of_edge) {
  core::Dataset d;
  d.format = core::DatasetFormat::kG2o;
  d.is_3d = world.is_3d;
  const std::vector<Variable>& initial = world.initial[robot];
  for (std::size_t i = 0; i < initial.size(); ++i) {
    const core::Key key = core::MakeKey('x', i);
    d.poses.push_back(key);
    (void)d.initial.Insert(key, initial[i]);
  }
  // Landmarks at the robot's first observation, seen from its initial guess.
  std::map<int, Point2> first;
  for (const SimObservation& o : world.observations) {
    if (o.robot == robot && !first.count(o.landmark)) {
      first[o.landmark] = std::get<Pose2>(initial[o.idx]).TransformFrom(o.point);
    }
  }
  for (const auto& [id, point] : first) {
    d.landmarks.push_back(core::MakeKey('l', id));
    (void)d.initial.Insert(core::MakeKey('l', id), point);
  }
  // Merge edges and observations in generation order (both are ordered by the later pose).
  if (factor_of_edge) factor_of_edge->assign(world.edges.size(), -1);
  std::size_t e = 0, o = 0;
  const auto next_edge = [&] {
    while (e < world.edges.size() &&
           (world.edges[e].robot_a != robot || world.edges[e].robot_b != robot)) {
      ++e;
    }
  };
  const auto next_obs = [&] {
    while (o < world.observations.size() && world.observations[o].robot != robot) ++o;
  };
  for (next_edge(), next_obs(); e < world.edges.size() || o < world.observations.size();
       next_edge(), next_obs()) {
    if (e < world.edges.size() &&
        (o == world.observations.size() || world.edges[e].idx_b <= world.observations[o].idx)) {
      const SimEdge& edge = world.edges[e];
      if (factor_of_edge) (*factor_of_edge)[e] = static_cast<int>(d.graph.size());
      const core::Key a = core::MakeKey('x', edge.idx_a), b = core::MakeKey('x', edge.idx_b);
      if (world.is_3d) {
        d.graph.Emplace<core::BetweenFactor<Pose3>>(a, b, std::get<Pose3>(edge.measured),
                                                    edge.noise);
      } else {
        d.graph.Emplace<core::BetweenFactor<Pose2>>(a, b, std::get<Pose2>(edge.measured),
                                                    edge.noise);
      }
      ++d.num_pose_edges;
      if (std::abs(edge.idx_b - edge.idx_a) != 1) ++d.num_loop_like;
      ++e;
    } else if (o < world.observations.size()) {
      const SimObservation& obs = world.observations[o];
      d.graph.Emplace<core::RelativePointFactor<Pose2, Point2>>(
          core::MakeKey('x', obs.idx), core::MakeKey('l', obs.landmark), obs.point, obs.noise);
      ++d.num_landmark_observations;
      ++o;
    }
  }
  return d;
}

core::Values RobotTruth(const SimWorld& world, int robot) {
  core::Values v;
  for (std::size_t i = 0; i < world.truth[robot].size(); ++i) {
    (void)v.Insert(core::MakeKey('x', i), world.truth[robot][i]);
  }
  for (const int id : ObservedBy(world, robot)) {
    (void)v.Insert(core::MakeKey('l', id), world.landmarks[id]);
  }
  return v;
}

}  // namespace slamd::clients::sim
