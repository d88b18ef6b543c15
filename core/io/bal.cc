// BAL problems: ReadBal and WriteBal. Layout and the camera conversion: sfm_io.h.
#include <algorithm>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <variant>

#include "core/geometry/rot3.h"
#include "core/io/reader_internal.h"
#include "core/io/sfm_io.h"

namespace slamd::core {
namespace {

using internal::TokenStream;

// F = diag(1, -1, -1): BAL's camera frame rotated by π about its x axis is slamd's. F is its own
// inverse, so the same product converts both ways.
Matrix3 FlipYZ(const Matrix3& R) {
  Matrix3 out = R;
  out.row(1) *= -1.0;
  out.row(2) *= -1.0;
  return out;
}
Vector3 FlipYZ(const Vector3& t) { return Vector3(t.x(), -t.y(), -t.z()); }

// The numbers a BAL camera stores: R·X + t maps the world to its camera frame.
struct BalCamera {
  Vector3 rotation_vector;
  Vector3 translation;
  Cal3Bundler calibration;
};

Pose3 PoseFromBal(const BalCamera& camera) {
  const Matrix3 R_cw = FlipYZ(Rot3::Exp(camera.rotation_vector).matrix());
  return Pose3(Rot3(R_cw), FlipYZ(camera.translation)).Inverse();
}

BalCamera BalFromImage(const SfmImage& image, const Cal3Bundler& calibration) {
  const Pose3 T_cw = image.pose.Inverse();
  return {.rotation_vector = Rot3::Log(Rot3(FlipYZ(T_cw.rotation().matrix()))),
          .translation = FlipYZ(T_cw.translation()),
          .calibration = calibration};
}

// What WriteBal can write (sfm_io.h): one Cal3Bundler per image, pixels centred.
Status CheckBalRepresentable(const Reconstruction& r) {
  if (Status valid = r.Validate(); !valid.ok()) {
    return InvalidArgument("WriteBal: " + valid.message());
  }
  if (r.intrinsics.size() != r.images.size()) {
    return InvalidArgument("WriteBal: " + std::to_string(r.intrinsics.size()) + " intrinsics for " +
                           std::to_string(r.images.size()) +
                           " images; BAL has one camera model per image");
  }
  for (std::size_t i = 0; i < r.images.size(); ++i) {
    const std::string image = "WriteBal: image " + std::to_string(i);
    if (r.images[i].intrinsics != static_cast<int>(i)) {
      return InvalidArgument(
          image + " uses intrinsics " + std::to_string(r.images[i].intrinsics) +
          "; BAL has one camera model per image (image i must use intrinsics i)");
    }
    const SfmIntrinsics& k = r.intrinsics[i];
    if (!std::holds_alternative<Cal3Bundler>(k.calibration)) {
      return InvalidArgument(image + ": intrinsics " + std::to_string(i) +
                             " are not a Cal3Bundler, BAL's only camera model");
    }
    if (!k.principal_point.isZero(0.0)) {
      return InvalidArgument(image + ": intrinsics " + std::to_string(i) +
                             " have a non-zero principal point; BAL pixels are centred");
    }
  }
  return Status::Ok();
}

// Numbers one per line, as the BAL files of Agarwal et al. write cameras and points.
void AppendBalColumn(std::initializer_list<double> values, std::string* out) {
  for (const double x : values) {
    internal::AppendNumber(x, out);
    out->push_back('\n');
  }
}

}  // namespace

Result<Reconstruction> ReadBal(const std::string& path) {
  Result<std::string> text = internal::ReadTextFile(path, "BAL file");
  if (!text.ok()) return text.status();
  TokenStream tokens(path, *text);
  // Every number takes at least two characters (one and a separator): no count read from the
  // header reserves more than that, whatever it says.
  const auto reserve = [&](std::uint64_t n) {
    return std::min<std::uint64_t>(n, text->size() / 2);
  };

  // 1. Header. Counts fit an int, since indices into the vectors are ints.
  constexpr std::uint64_t kCountLimit = std::numeric_limits<int>::max();
  std::uint64_t num_cameras, num_points, num_observations;
  SLAMD_RETURN_IF_ERROR(tokens.Index({.field = "num_cameras"}, kCountLimit, &num_cameras));
  SLAMD_RETURN_IF_ERROR(tokens.Index({.field = "num_points"}, kCountLimit, &num_points));
  SLAMD_RETURN_IF_ERROR(
      tokens.Index({.field = "num_observations"}, kCountLimit, &num_observations));

  // 2. Observations: camera, point, pixel; y flips with the camera frame.
  Reconstruction r;
  r.observations.reserve(reserve(num_observations));
  for (std::uint64_t k = 0; k < num_observations; ++k) {
    const auto name = [&](std::string_view field) {
      return internal::FieldName{
          .field = field, .record = "observation", .index = static_cast<std::int64_t>(k)};
    };
    std::uint64_t camera, point;
    double x, y;
    SLAMD_RETURN_IF_ERROR(tokens.Index(name("the camera"), num_cameras, &camera));
    SLAMD_RETURN_IF_ERROR(tokens.Index(name("the point"), num_points, &point));
    SLAMD_RETURN_IF_ERROR(tokens.Number(name("x"), &x));
    SLAMD_RETURN_IF_ERROR(tokens.Number(name("y"), &y));
    r.observations.push_back({.image = static_cast<int>(camera),
                              .point = static_cast<int>(point),
                              .uv = Vector2(x, -y)});
  }

  // 3. Cameras: one image and one intrinsics each.
  static constexpr const char* kCameraFields[9] = {"w1", "w2", "w3", "t1", "t2",
                                                   "t3", "f",  "k1", "k2"};
  r.images.reserve(reserve(num_cameras));
  r.intrinsics.reserve(reserve(num_cameras));
  for (std::uint64_t i = 0; i < num_cameras; ++i) {
    double v[9];
    for (int k = 0; k < 9; ++k) {
      SLAMD_RETURN_IF_ERROR(tokens.Number(
          {.field = kCameraFields[k], .record = "camera", .index = static_cast<std::int64_t>(i)},
          &v[k]));
    }
    const BalCamera camera{.rotation_vector = Vector3(v[0], v[1], v[2]),
                           .translation = Vector3(v[3], v[4], v[5]),
                           .calibration = Cal3Bundler(v[6], v[7], v[8])};
    SfmIntrinsics intrinsics;
    intrinsics.calibration = camera.calibration;
    intrinsics.id = static_cast<std::uint32_t>(i);
    r.intrinsics.push_back(std::move(intrinsics));
    SfmImage image;
    image.pose = PoseFromBal(camera);
    image.intrinsics = static_cast<int>(i);
    image.id = static_cast<std::uint32_t>(i);
    r.images.push_back(std::move(image));
  }

  // 4. Points, then nothing.
  static constexpr const char* kPointFields[3] = {"X", "Y", "Z"};
  r.points.reserve(reserve(num_points));
  for (std::uint64_t j = 0; j < num_points; ++j) {
    SfmPoint point{.id = j};
    for (int k = 0; k < 3; ++k) {
      SLAMD_RETURN_IF_ERROR(tokens.Number(
          {.field = kPointFields[k], .record = "point", .index = static_cast<std::int64_t>(j)},
          &point.position[k]));
    }
    r.points.push_back(point);
  }
  SLAMD_RETURN_IF_ERROR(tokens.End("the last point"));
  return r;
}

Status WriteBal(const Reconstruction& r, const std::string& path) {
  SLAMD_RETURN_IF_ERROR(CheckBalRepresentable(r));
  std::string out = std::to_string(r.images.size()) + " " + std::to_string(r.points.size()) + " " +
                    std::to_string(r.observations.size()) + "\n";
  for (const SfmObservation& o : r.observations) {
    out.append(std::to_string(o.image)).append(" ").append(std::to_string(o.point));
    internal::AppendNumbers({o.uv.x(), -o.uv.y()}, &out);
    out.push_back('\n');
  }
  for (std::size_t i = 0; i < r.images.size(); ++i) {
    const BalCamera c =
        BalFromImage(r.images[i], std::get<Cal3Bundler>(r.intrinsics[i].calibration));
    const Vector3& w = c.rotation_vector;
    const Vector3& t = c.translation;
    AppendBalColumn({w.x(), w.y(), w.z(), t.x(), t.y(), t.z(), c.calibration.f(),
                     c.calibration.k1(), c.calibration.k2()},
                    &out);
  }
  for (const SfmPoint& p : r.points) {
    AppendBalColumn({p.position.x(), p.position.y(), p.position.z()}, &out);
  }
  return internal::WriteTextFile(path, out, "WriteBal");
}

}  // namespace slamd::core
