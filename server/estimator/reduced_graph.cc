#include "server/estimator/reduced_graph.h"

#include <algorithm>
#include <cmath>
#include <string_view>

#include "core/base/check.h"
#include "core/geometry/pose2.h"
#include "core/geometry/pose3.h"

namespace slamd::server {
namespace {

// Pose2 or Pose3 and their tangent matrices; a point of the same dimension.
template <typename P>
struct Kind;
template <>
struct Kind<core::Pose2> {
  using Tangent = core::Matrix3;
  using Point = core::Point2;
  using PointByPose = core::Matrix23;
  using PointByPoint = core::Matrix2;
};
template <>
struct Kind<core::Pose3> {
  using Tangent = core::Matrix6;
  using Point = core::Point3;
  using PointByPose = core::Matrix36;
  using PointByPoint = core::Matrix3;
};

template <typename P>
const P& As(const core::Variable& v, const char* what) {
  const P* p = std::get_if<P>(&v);
  SLAMD_CHECK(p != nullptr) << "reduced pose graph: " << what << " is not a "
                            << (std::is_same_v<P, core::Pose2> ? "Pose2" : "Pose3");
  return *p;
}

// Calls f(P{}) with the pose kind of `v` (Pose2 or Pose3; anything else is a broken invariant).
template <typename F>
auto WithPoseKind(const core::Variable& v, F&& f) {
  if (std::holds_alternative<core::Pose2>(v)) return f(core::Pose2());
  SLAMD_CHECK(std::holds_alternative<core::Pose3>(v))
      << "reduced pose graph: a pose alias must be a Pose2 or Pose3";
  return f(core::Pose3());
}

}  // namespace

core::Variable ComposePoses(const core::Variable& a, const core::Variable& b) {
  return WithPoseKind(a, [&](auto pose) -> core::Variable {
    using P = decltype(pose);
    return As<P>(a, "a pose").Compose(As<P>(b, "a pose"));
  });
}

std::optional<Eigen::Vector3d> PositionOf(const core::Variable& v) {
  if (const auto* p = std::get_if<core::Pose2>(&v)) {
    return Eigen::Vector3d(p->translation().x(), p->translation().y(), 0.0);
  }
  if (const auto* p = std::get_if<core::Pose3>(&v)) return p->translation();
  return std::nullopt;
}

PoseAlias NodeAlias(core::Key node, const core::Variable& like) {
  return WithPoseKind(like, [&](auto pose) {
    using P = decltype(pose);
    constexpr int n = Kind<P>::Tangent::RowsAtCompileTime;
    return PoseAlias{node, P(), Eigen::MatrixXd::Zero(n, n)};
  });
}

PoseAlias ComposeAlias(const PoseAlias& from, const ComposedMeasurement& z) {
  return WithPoseKind(from.offset, [&](auto pose) {
    using P = decltype(pose);
    typename Kind<P>::Tangent H1, H2;
    const P composed =
        As<P>(from.offset, "the alias offset").Compose(As<P>(z.measured, "the odometry"), &H1, &H2);
    Eigen::MatrixXd cov =
        H1 * from.covariance * H1.transpose() + H2 * z.covariance * H2.transpose();
    return PoseAlias{from.anchor, composed, 0.5 * (cov + cov.transpose())};
  });
}

PoseAlias RelativeAlias(core::Key anchor, const core::Variable& anchor_pose,
                        const core::Variable& pose, const Eigen::MatrixXd& joint) {
  return WithPoseKind(anchor_pose, [&](auto kind) {
    using P = decltype(kind);
    constexpr int n = Kind<P>::Tangent::RowsAtCompileTime;
    SLAMD_CHECK(joint.rows() == 2 * n && joint.cols() == 2 * n)
        << "reduced pose graph: a joint marginal of two poses is " << 2 * n << "x" << 2 * n;
    typename Kind<P>::Tangent H1, H2;
    const P offset =
        As<P>(anchor_pose, "the anchor").Between(As<P>(pose, "the aliased pose"), &H1, &H2);
    Eigen::Matrix<double, n, 2 * n> H;
    H << H1, H2;
    Eigen::MatrixXd cov = H * joint * H.transpose();
    return PoseAlias{anchor, offset, 0.5 * (cov + cov.transpose())};
  });
}

bool IsRelativePoint(const core::Factor& f) {
  const std::string_view name = f.Name();
  return name == "RelativePoint2" || name == "RelativePoint3";
}

bool Composable(const core::Factor& f) {
  return core::MeasuredRelativePose(f).has_value() || IsRelativePoint(f);
}

ComposedMeasurement InverseRelative(const ComposedMeasurement& z) {
  return WithPoseKind(z.measured, [&](auto pose) {
    using P = decltype(pose);
    typename Kind<P>::Tangent H;
    const P inverse = As<P>(z.measured, "the relative pose").Inverse(&H);
    Eigen::MatrixXd cov = H * z.covariance * H.transpose();
    return ComposedMeasurement{inverse, 0.5 * (cov + cov.transpose())};
  });
}

ComposedMeasurement ComposeBetween(const PoseAlias& from, const ComposedMeasurement& z,
                                   const PoseAlias& to) {
  const PoseAlias through = ComposeAlias(from, z);  // from.anchor ∘ (Za ∘ z)
  const ComposedMeasurement back = InverseRelative({to.offset, to.covariance});  // Zb⁻¹
  const PoseAlias all = ComposeAlias(through, back);
  return {all.offset, all.covariance};
}

ComposedMeasurement ComposePoint(const PoseAlias& from, const ComposedMeasurement& p) {
  return WithPoseKind(from.offset, [&](auto pose) {
    using P = decltype(pose);
    using Point = typename Kind<P>::Point;
    const Point* point = std::get_if<Point>(&p.measured);
    SLAMD_CHECK(point != nullptr) << "reduced pose graph: a point of the pose's dimension";
    typename Kind<P>::PointByPose Hpose;
    typename Kind<P>::PointByPoint Hp;
    const Point moved = As<P>(from.offset, "the alias offset").TransformFrom(*point, &Hpose, &Hp);
    Eigen::MatrixXd cov =
        Hpose * from.covariance * Hpose.transpose() + Hp * p.covariance * Hp.transpose();
    return ComposedMeasurement{moved, 0.5 * (cov + cov.transpose())};
  });
}

void NodeGrid::Reset(double cell) {
  cell_ = cell;
  cells_.clear();
}

void NodeGrid::Add(core::Key key, const Eigen::Vector3d& at) { cells_[Cell(at)].push_back(key); }

std::array<long, 3> NodeGrid::Cell(const Eigen::Vector3d& at) const {
  return {std::lround(std::floor(at[0] / cell_)), std::lround(std::floor(at[1] / cell_)),
          std::lround(std::floor(at[2] / cell_))};
}

long NodeGrid::Reach(double radius) const {
  return std::max(1L, std::lround(std::ceil(radius / cell_)));
}

PoseDistance DistanceBetween(const core::Variable& a, const core::Variable& b) {
  return WithPoseKind(a, [&](auto pose) {
    using P = decltype(pose);
    const P& pa = As<P>(a, "a pose");
    const P& pb = As<P>(b, "a pose");
    const P rel = pa.Between(pb);
    double angle = 0.0;
    if constexpr (std::is_same_v<P, core::Pose2>) {
      angle = std::abs(rel.theta());
    } else {
      angle = core::Rot3::Log(rel.rotation()).norm();
    }
    return PoseDistance{(pb.translation() - pa.translation()).norm(), angle};
  });
}

}  // namespace slamd::server
