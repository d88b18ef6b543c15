// Camera worlds: the checks of their params, the city and object generators, and the
// measurements. Writing them: sim_camera_world_io.cc.
#include "clients/slamctl/sim_camera_world.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <utility>
#include <variant>

#include "clients/slamctl/sim_rng.h"
#include "core/base/param_check.h"
#include "core/geometry/camera.h"

namespace slamd::clients::sim {

using core::Point3;
using core::Pose3;
using core::Vector2;
using core::Vector3;

const char* CameraWorldKindName(CameraWorldKind kind) {
  return kind == CameraWorldKind::kCity ? "camera-city" : "camera-object";
}

bool ParseCameraWorldKind(const std::string& name, CameraWorldKind* kind) {
  for (CameraWorldKind k : {CameraWorldKind::kCity, CameraWorldKind::kObject}) {
    if (name == CameraWorldKindName(k)) {
      *kind = k;
      return true;
    }
  }
  return false;
}

int DefaultCameras(CameraWorldKind kind) { return kind == CameraWorldKind::kCity ? 60 : 36; }
int DefaultPoints(CameraWorldKind kind) { return kind == CameraWorldKind::kCity ? 6000 : 1500; }

core::Status CameraSimParams::Validate() const {
  SLAMD_PARAM_CHECK(CameraSimParams, cameras, >=, 0);
  if (cameras == 1) {
    return core::InvalidArgument("CameraSimParams::cameras = 1; violates >= 2 (or 0)");
  }
  SLAMD_PARAM_CHECK(CameraSimParams, cameras, <=, 100000);
  SLAMD_PARAM_CHECK(CameraSimParams, points, >=, 0);
  SLAMD_PARAM_CHECK(CameraSimParams, points, <=, 10000000);
  SLAMD_PARAM_CHECK(CameraSimParams, width, >=, 16);
  SLAMD_PARAM_CHECK(CameraSimParams, width, <=, 100000);
  SLAMD_PARAM_CHECK(CameraSimParams, height, >=, 16);
  SLAMD_PARAM_CHECK(CameraSimParams, height, <=, 100000);
  SLAMD_PARAM_CHECK(CameraSimParams, focal, >, 0.0);
  SLAMD_PARAM_CHECK(CameraSimParams, sigma_pixel, >=, 0.0);
  SLAMD_PARAM_CHECK(CameraSimParams, outliers, >=, 0.0);
  SLAMD_PARAM_CHECK(CameraSimParams, outliers, <=, 1.0);
  SLAMD_PARAM_CHECK(CameraSimParams, init_sigma_camera, >=, 0.0);
  SLAMD_PARAM_CHECK(CameraSimParams, init_sigma_rotation, >=, 0.0);
  SLAMD_PARAM_CHECK(CameraSimParams, init_sigma_point, >=, 0.0);
  SLAMD_PARAM_CHECK(CameraSimParams, baseline, >, 0.0);
  const std::pair<const char*, double> finite[] = {{"focal", focal},
                                                   {"k1", k1},
                                                   {"k2", k2},
                                                   {"sigma_pixel", sigma_pixel},
                                                   {"init_sigma_camera", init_sigma_camera},
                                                   {"init_sigma_rotation", init_sigma_rotation},
                                                   {"init_sigma_point", init_sigma_point},
                                                   {"baseline", baseline}};
  for (const auto& [name, value] : finite) {
    if (!std::isfinite(value)) {
      return core::InvalidArgument(std::string("CameraSimParams::") + name + " = " +
                                   std::to_string(value) + "; violates finite");
    }
  }
  if (model == CameraModel::kPinhole) {
    for (const auto& [name, value] : {std::pair{"k1", k1}, std::pair{"k2", k2}}) {
      if (value != 0.0) {
        return core::InvalidArgument(std::string("CameraSimParams::") + name + " = " +
                                     std::to_string(value) +
                                     "; violates == 0 for the PINHOLE model (use OPENCV)");
      }
    }
  }
  return core::Status::Ok();
}

namespace {

using std::numbers::pi;

constexpr double kEyeHeight = 1.6;                // m, city cameras above the street
constexpr double kCityPitch = 10.0 * pi / 180.0;  // city cameras look this much up
constexpr double kObjectDistance = 4.0;           // m, object cameras from its centre
const Vector3 kObjectAxes(1.0, 0.8, 0.6);         // m, the ellipsoid's semi-axes
const Point3 kObjectCenter(0.0, 0.0, 0.6);        // resting on the ground

using Color = std::array<std::uint8_t, 3>;

// A point of a surface: where it is, which way the surface faces there, its colour.
struct SurfacePoint {
  Point3 position;
  Vector3 normal;
  Color color;
};

// An axis-aligned building standing on the ground.
struct Building {
  double x0, y0, x1, y1, height;
  Color color;
};

// What generation builds before measuring: cameras, points and what can hide them.
struct Geometry {
  std::vector<Pose3> cameras;
  std::vector<SurfacePoint> points;
  std::vector<Building> occluders;
  double max_depth = std::numeric_limits<double>::infinity();
};

// A camera at `eye` looking at `target`, image x horizontal (along z_c × world z), y down.
Pose3 LookAt(const Point3& eye, const Point3& target) {
  const Vector3 z = (target - eye).normalized();
  const Vector3 x = z.cross(Vector3::UnitZ()).normalized();
  core::Matrix3 R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  return Pose3(core::Rot3(R), eye);
}

// Whether the segment from `from` to just before `to` passes through the building (the slab
// test): a point on a facade is not hidden by its own building.
bool Hides(const Building& b, const Point3& from, const Point3& to) {
  const Vector3 d = to - from;
  const double lo[3] = {b.x0, b.y0, 0.0}, hi[3] = {b.x1, b.y1, b.height};
  double t0 = 0.0, t1 = 1.0 - 1e-9;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0.0) {
      if (from[k] < lo[k] || from[k] > hi[k]) return false;
      continue;
    }
    double ta = (lo[k] - from[k]) / d[k], tb = (hi[k] - from[k]) / d[k];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

Color Scaled(const Color& c, double s) {
  Color out;
  for (int k = 0; k < 3; ++k) out[k] = static_cast<std::uint8_t>(std::clamp(c[k] * s, 0.0, 255.0));
  return out;
}

// The city (file comment of sim_camera_world.h): buildings and points first, then the path.
Geometry City(int num_cameras, int num_points, Rng* rng) {
  static constexpr Color kFacades[] = {{178, 34, 34},   {205, 133, 63}, {112, 128, 144},
                                       {85, 107, 47},   {70, 90, 160},  {160, 82, 45},
                                       {128, 128, 128}, {189, 183, 107}};
  const int grid = std::max(2, static_cast<int>(std::lround(std::sqrt(num_cameras / 40.0))));
  Geometry g;
  g.max_depth = kCityMaxDepth;
  // 1. One building per block, on the driven grid's blocks and a ring around them.
  std::vector<double> cumulative_height;
  for (int bx = -1; bx <= grid; ++bx) {
    for (int by = -1; by <= grid; ++by) {
      const double half_street = kCityStreet / 2;
      Building b{.x0 = bx * kCityBlock + half_street,
                 .y0 = by * kCityBlock + half_street,
                 .x1 = (bx + 1) * kCityBlock - half_street,
                 .y1 = (by + 1) * kCityBlock - half_street,
                 .height = rng->Uniform(8.0, 30.0),
                 .color = kFacades[rng->Index(std::size(kFacades))]};
      cumulative_height.push_back(b.height +
                                  (g.occluders.empty() ? 0.0 : cumulative_height.back()));
      g.occluders.push_back(b);
    }
  }
  // 2. Points uniform over the facades: a building in proportion to its height (its facades'
  // area), one of its four facades, a place on it.
  const double side = kCityBlock - kCityStreet;
  for (int j = 0; j < num_points; ++j) {
    const double pick = rng->Uniform(0.0, cumulative_height.back());
    const std::size_t index =
        std::upper_bound(cumulative_height.begin(), cumulative_height.end(), pick) -
        cumulative_height.begin();
    const Building& b = g.occluders[std::min(index, g.occluders.size() - 1)];
    // Facades +x, +y, -x, -y: the corner a facade starts from, the direction along it.
    const int face = rng->Index(4);
    const double along = rng->Uniform(0.0, side), z = rng->Uniform(0.0, b.height);
    const Point3 start(face == 0 ? b.x1 : b.x0, face == 1 ? b.y1 : b.y0, z);
    const Vector3 direction = face % 2 == 0 ? Vector3::UnitY() : Vector3::UnitX();
    SurfacePoint p;
    p.position = start + along * direction;
    p.normal = (face < 2 ? 1.0 : -1.0) * (face % 2 == 0 ? Vector3::UnitX() : Vector3::UnitY());
    p.color = Scaled(b.color, rng->Uniform(0.75, 1.15));
    g.points.push_back(p);
  }
  // 3. The path: from crossing to crossing along the street lines, kCityStep per image.
  static constexpr int kDx[4] = {1, 0, -1, 0}, kDy[4] = {0, 1, 0, -1};
  static constexpr double kViewYaw[3] = {0.0, 50.0 * pi / 180.0, -50.0 * pi / 180.0};
  const int per_block = static_cast<int>(std::lround(kCityBlock / kCityStep));
  const auto inside = [grid](int c) { return c >= 0 && c <= grid; };
  int cx = 0, cy = 0, heading = 0;
  while (static_cast<int>(g.cameras.size()) < num_cameras) {
    for (int s = 0; s < per_block && static_cast<int>(g.cameras.size()) < num_cameras; ++s) {
      const Point3 eye(cx * kCityBlock + kDx[heading] * s * kCityStep,
                       cy * kCityBlock + kDy[heading] * s * kCityStep, kEyeHeight);
      const double yaw = heading * pi / 2 + kViewYaw[g.cameras.size() % 3];
      const Vector3 view(std::cos(yaw) * std::cos(kCityPitch), std::sin(yaw) * std::cos(kCityPitch),
                         std::sin(kCityPitch));
      g.cameras.push_back(LookAt(eye, eye + view));
    }
    cx += kDx[heading];
    cy += kDy[heading];
    const double u = rng->Uniform();
    const int wanted = u < 0.5 ? heading : u < 0.75 ? (heading + 1) % 4 : (heading + 3) % 4;
    for (int h : {wanted, heading, (heading + 1) % 4, (heading + 3) % 4, (heading + 2) % 4}) {
      if (inside(cx + kDx[h]) && inside(cy + kDy[h])) {
        heading = h;
        break;
      }
    }
  }
  return g;
}

// The object (file comment of sim_camera_world.h): points on the ellipsoid, cameras on rings.
Geometry Object(int num_cameras, int num_points, Rng* rng) {
  Geometry g;
  for (int j = 0; j < num_points; ++j) {
    Vector3 u(rng->Normal(), rng->Normal(), rng->Normal());
    u = u.norm() > 0.0 ? Vector3(u.normalized()) : Vector3::UnitZ();
    // x = c + a∘u lies on Σ ((x - c)_k / a_k)² = 1, whose gradient is along u / a.
    const Vector3 normal = u.cwiseQuotient(kObjectAxes).normalized();
    Color color;
    for (int k = 0; k < 3; ++k)
      color[k] = static_cast<std::uint8_t>(std::lround(127.5 * (1 + normal[k])));
    g.points.push_back({.position = kObjectCenter + kObjectAxes.cwiseProduct(u),
                        .normal = normal,
                        .color = color});
  }
  const int rings = std::max(1, static_cast<int>(std::lround(std::sqrt(num_cameras / 4.0))));
  for (int i = 0; i < rings; ++i) {
    const int on_ring = num_cameras / rings + (i < num_cameras % rings ? 1 : 0);
    const double elevation = (10.0 + 50.0 * (i + 0.5) / rings) * pi / 180.0;
    for (int k = 0; k < on_ring; ++k) {
      const double azimuth = 2 * pi * (k + 0.5 * (i % 2)) / on_ring;
      const Vector3 dir(std::cos(elevation) * std::cos(azimuth),
                        std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
      g.cameras.push_back(LookAt(kObjectCenter + kObjectDistance * dir, kObjectCenter));
    }
  }
  return g;
}

// The pixel of `p` in a camera at `pose` with any calibration.
core::Projection ProjectWith(const core::Calibration& calibration, const Pose3& pose,
                             const Point3& p) {
  return std::visit([&](const auto& K) { return core::Project(pose, K, p); }, calibration);
}

bool InImage(const Vector2& uv, const CameraSimParams& p) {
  return uv.x() >= 0.0 && uv.x() < p.width && uv.y() >= 0.0 && uv.y() < p.height;
}

// Whether camera `pose` sees the point (facing, near enough, not hidden): before projecting.
bool Sees(const Geometry& g, const Pose3& pose, const SurfacePoint& point) {
  const Vector3 to_camera = pose.translation() - point.position;
  if (point.normal.dot(to_camera) <= 0.0) return false;
  if (pose.TransformTo(point.position).z() > g.max_depth) return false;
  return std::none_of(g.occluders.begin(), g.occluders.end(), [&](const Building& b) {
    return Hides(b, pose.translation(), point.position);
  });
}

// Keeps the observations whose image and point survive: points seen by >= 2 images, images
// seeing >= kMinImageObservations points, repeated until nothing changes; renumbers both.
void Prune(std::vector<Pose3>* cameras, std::vector<SurfacePoint>* points,
           std::vector<core::SfmObservation>* observations) {
  std::vector<bool> image_alive(cameras->size(), true), point_alive(points->size(), true);
  for (bool changed = true; changed;) {
    changed = false;
    std::vector<int> views(points->size(), 0), seen(cameras->size(), 0);
    for (const core::SfmObservation& o : *observations) {
      if (image_alive[o.image] && point_alive[o.point]) ++views[o.point];
    }
    for (std::size_t j = 0; j < points->size(); ++j) {
      if (point_alive[j] && views[j] < 2) {
        point_alive[j] = false;
        changed = true;
      }
    }
    for (const core::SfmObservation& o : *observations) {
      if (image_alive[o.image] && point_alive[o.point]) ++seen[o.image];
    }
    for (std::size_t i = 0; i < cameras->size(); ++i) {
      if (image_alive[i] && seen[i] < kMinImageObservations) {
        image_alive[i] = false;
        changed = true;
      }
    }
  }
  // Renumber in order.
  const auto compact = [](auto* items, const std::vector<bool>& alive) {
    std::vector<int> index(alive.size(), -1);
    std::size_t kept = 0;
    for (std::size_t k = 0; k < alive.size(); ++k) {
      if (!alive[k]) continue;
      index[k] = static_cast<int>(kept);
      (*items)[kept++] = (*items)[k];
    }
    items->resize(kept);
    return index;
  };
  const std::vector<int> image_index = compact(cameras, image_alive);
  const std::vector<int> point_index = compact(points, point_alive);
  std::vector<core::SfmObservation> kept;
  for (const core::SfmObservation& o : *observations) {
    if (image_index[o.image] < 0 || point_index[o.point] < 0) continue;
    kept.push_back({.image = image_index[o.image], .point = point_index[o.point], .uv = o.uv});
  }
  *observations = std::move(kept);
}

class CameraWorldGenerator {
 public:
  explicit CameraWorldGenerator(const CameraSimParams& params) : p_(params), rng_(params.seed) {}

  core::Result<CameraWorld> Run() {
    CameraWorld world;
    world.params = p_;
    CameraSimParams& p = world.params;
    if (p.cameras == 0) p.cameras = DefaultCameras(p.world);
    if (p.points == 0) p.points = DefaultPoints(p.world);
    // 1. Cameras and points.
    Geometry g = p.world == CameraWorldKind::kCity ? City(p.cameras, p.points, &rng_)
                                                   : Object(p.cameras, p.points, &rng_);
    const core::SfmIntrinsics intrinsics = Intrinsics();
    // 2. True pixels where a camera sees a point, image by image; then the pruning.
    std::vector<core::SfmObservation> observations;
    for (std::size_t i = 0; i < g.cameras.size(); ++i) {
      for (std::size_t j = 0; j < g.points.size(); ++j) {
        if (!Sees(g, g.cameras[i], g.points[j])) continue;
        const core::Projection uv =
            ProjectWith(intrinsics.calibration, g.cameras[i], g.points[j].position);
        if (!uv.in_front() || !InImage(uv.uv, p)) continue;
        observations.push_back(
            {.image = static_cast<int>(i), .point = static_cast<int>(j), .uv = uv.uv});
      }
    }
    Prune(&g.cameras, &g.points, &observations);
    if (g.cameras.size() < 2) {
      return core::InvalidArgument(
          std::string(CameraWorldKindName(p.world)) + ": fewer than 2 images see " +
          std::to_string(kMinImageObservations) + " points each; place more points");
    }
    world.truth = TrueReconstruction(g, intrinsics, std::move(observations));
    // 3. Measurements: noise, then outliers.
    std::vector<core::SfmObservation>& measured = world.truth.observations;
    for (core::SfmObservation& o : measured) o.uv += Vector2(PixelNoise(), PixelNoise());
    const int count = static_cast<int>(std::llround(p.outliers * measured.size()));
    std::vector<int> order(measured.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
    for (int k = 0; k < count; ++k) {  // partial Fisher–Yates: the first `count` of a shuffle
      std::swap(order[k], order[k + rng_.Index(static_cast<int>(order.size()) - k)]);
      measured[order[k]].uv = Vector2(rng_.Uniform(0.0, p.width), rng_.Uniform(0.0, p.height));
    }
    world.outliers.assign(order.begin(), order.begin() + count);
    std::sort(world.outliers.begin(), world.outliers.end());
    // 4. The initial guess.
    world.initial = world.truth;
    for (core::SfmImage& image : world.initial.images) {
      core::Vector6 xi;
      for (int k = 0; k < 6; ++k) {
        xi(k) = rng_.Normal() * (k < 3 ? p.init_sigma_camera : p.init_sigma_rotation);
      }
      image.pose = image.pose.Retract(xi);
    }
    for (core::SfmPoint& point : world.initial.points) {
      for (int k = 0; k < 3; ++k) point.position(k) += rng_.Normal() * p.init_sigma_point;
    }
    // 5. Stereo, last: it changes nothing else.
    if (p.stereo) world.stereo = Stereo(world);
    return world;
  }

 private:
  // The one camera of every image (file comment of sim_camera_world.h).
  core::SfmIntrinsics Intrinsics() const {
    const core::Cal3_S2 pinhole(p_.focal, p_.focal, 0.0, p_.width / 2.0, p_.height / 2.0);
    core::SfmIntrinsics in{.width = p_.width, .height = p_.height, .id = 1};
    if (p_.model == CameraModel::kPinhole) {
      in.calibration = pinhole;
      in.model = "PINHOLE";
    } else {
      in.calibration = core::Cal3DS2(pinhole, p_.k1, p_.k2, 0.0, 0.0);
      in.model = "OPENCV";
    }
    return in;
  }

  static core::Reconstruction TrueReconstruction(const Geometry& g,
                                                 const core::SfmIntrinsics& intrinsics,
                                                 std::vector<core::SfmObservation> observations) {
    core::Reconstruction r;
    r.intrinsics.push_back(intrinsics);
    for (std::size_t i = 0; i < g.cameras.size(); ++i) {
      char name[32];
      std::snprintf(name, sizeof name, "image_%04zu.png", i + 1);
      r.images.push_back({.pose = g.cameras[i],
                          .intrinsics = 0,
                          .name = name,
                          .id = static_cast<std::uint32_t>(i + 1)});
    }
    for (std::size_t j = 0; j < g.points.size(); ++j) {
      r.points.push_back({.position = g.points[j].position,
                          .color = g.points[j].color,
                          .id = static_cast<std::uint64_t>(j + 1)});
    }
    r.observations = std::move(observations);
    return r;
  }

  // Always draws, so that noise-free and noisy worlds of one seed share everything else.
  double PixelNoise() {
    const double z = rng_.Normal();
    return p_.noise_free ? 0.0 : p_.sigma_pixel * z;
  }

  std::vector<StereoObservation> Stereo(const CameraWorld& world) {
    const core::Reconstruction& truth = world.truth;
    const core::Calibration& calibration = truth.intrinsics.front().calibration;
    const core::Cal3_S2Stereo K(std::holds_alternative<core::Cal3_S2>(calibration)
                                    ? std::get<core::Cal3_S2>(calibration)
                                    : std::get<core::Cal3DS2>(calibration).pinhole(),
                                p_.baseline);
    std::vector<StereoObservation> stereo;
    std::size_t next_outlier = 0;
    for (std::size_t k = 0; k < truth.observations.size(); ++k) {
      const core::SfmObservation& o = truth.observations[k];
      const core::StereoProjection s =
          core::ProjectStereo(truth.images[o.image].pose, K, truth.points[o.point].position);
      const Vector3 noise(PixelNoise(), PixelNoise(), PixelNoise());
      const bool outlier = next_outlier < world.outliers.size() &&
                           world.outliers[next_outlier] == static_cast<int>(k);
      next_outlier += outlier;
      const bool seen = s.in_front() && InImage(Vector2(s.uuv.x(), s.uuv.z()), p_) &&
                        InImage(Vector2(s.uuv.y(), s.uuv.z()), p_);
      if (outlier || !seen) continue;
      stereo.push_back({.observation = static_cast<int>(k), .uuv = s.uuv + noise});
    }
    return stereo;
  }

  const CameraSimParams& p_;
  Rng rng_;
};

}  // namespace

core::Result<CameraWorld> GenerateCameraWorld(const CameraSimParams& params) {
  SLAMD_RETURN_IF_ERROR(params.Validate());
  return CameraWorldGenerator(params).Run();
}

core::Reconstruction AsBal(const core::Reconstruction& r) {
  core::Reconstruction bal = r;
  bal.intrinsics.clear();
  std::vector<Vector2> principal_point;
  for (std::size_t i = 0; i < r.images.size(); ++i) {
    const core::SfmIntrinsics& in = r.intrinsics[r.images[i].intrinsics];
    const auto [bundler, pp] = std::visit(
        [&](const auto& K) -> std::pair<core::Cal3Bundler, Vector2> {
          using Cal = std::decay_t<decltype(K)>;
          if constexpr (std::is_same_v<Cal, core::Cal3_S2>) {
            return {core::Cal3Bundler(K.fx(), 0.0, 0.0), Vector2(K.u0(), K.v0())};
          } else if constexpr (std::is_same_v<Cal, core::Cal3DS2>) {
            return {core::Cal3Bundler(K.pinhole().fx(), K.k1(), K.k2()),
                    Vector2(K.pinhole().u0(), K.pinhole().v0())};
          } else {
            return {K, in.principal_point};
          }
        },
        in.calibration);
    bal.intrinsics.push_back({.calibration = bundler, .id = static_cast<std::uint32_t>(i)});
    bal.images[i].intrinsics = static_cast<int>(i);
    principal_point.push_back(pp);
  }
  for (core::SfmObservation& o : bal.observations) o.uv -= principal_point[o.image];
  return bal;
}

}  // namespace slamd::clients::sim
