#include "core/factors/linear_container_factor.h"

#include <string>
#include <unordered_set>
#include <utility>

namespace slamd::core {

namespace {

// x's coordinates the root-relative form takes (linear_container_factor.h) and their
// derivatives by x's and the root's tangents: d x d and d x TangentDim(root).
struct RelativeCoordinates {
  Eigen::VectorXd local;
  Eigen::MatrixXd by_x, by_root;
};

template <typename Pose>
RelativeCoordinates RelativeTo(const Pose& r0, const Variable& x0, const Pose& r,
                               const Variable& x) {
  using Point = decltype(r.TransformTo(std::declval<Pose>().translation()));
  constexpr int kPoseDim = Pose::kDim;
  RelativeCoordinates out;
  if (const Pose* m = std::get_if<Pose>(&x)) {
    Eigen::Matrix<double, kPoseDim, kPoseDim> h_root, h_m;
    const Pose rel = r.Between(*m, &h_root, &h_m);
    const Pose rel0 = r0.Between(std::get<Pose>(x0));
    out.local = rel0.LocalCoordinates(rel);
    // ∂Local(rel₀, rel ⊕ ε)/∂ε = J⁻¹, J the chart's derivative at rel (as for the plain form).
    const TangentMatrix j_inv =
        EstimateTangentJacobian(kVariableType<Pose>, out.local.data()).inverse();
    out.by_x = j_inv * h_m;
    out.by_root = j_inv * h_root;
  } else if (const Point* l = std::get_if<Point>(&x)) {
    Eigen::Matrix<double, Point::RowsAtCompileTime, kPoseDim> h_root;
    Eigen::Matrix<double, Point::RowsAtCompileTime, Point::RowsAtCompileTime> h_l;
    const Point rel = r.TransformTo(*l, &h_root, &h_l);
    const auto turn = r0.rotation().matrix();
    out.local = turn * (rel - r0.TransformTo(std::get<Point>(x0)));
    out.by_x = turn * h_l;
    out.by_root = turn * h_root;
  } else {
    out.local = LocalCoordinates(x0, x);
    out.by_x = EstimateTangentJacobian(TypeOf(x0), out.local.data()).inverse();
    out.by_root = Eigen::MatrixXd::Zero(out.local.size(), kPoseDim);
  }
  return out;
}

}  // namespace

Result<FactorPtr> LinearContainerFactor::Create(KeyVector keys,
                                                std::vector<Variable> linearization_point,
                                                Eigen::MatrixXd A, Eigen::VectorXd b) {
  return Make(std::move(keys), std::move(linearization_point), std::move(A), std::move(b), false);
}

Result<FactorPtr> LinearContainerFactor::CreateRootRelative(
    KeyVector keys, std::vector<Variable> linearization_point, Eigen::MatrixXd A,
    Eigen::VectorXd b) {
  if (linearization_point.empty()) return InvalidArgument("LinearContainerFactor: no keys");
  const VariableType root = TypeOf(linearization_point.back());
  const bool planar = root == kVariableType<Pose2>;
  if (!planar && root != kVariableType<Pose3>) {
    return InvalidArgument(std::string("LinearContainerFactor: a root-relative root is a Pose2 or "
                                       "Pose3, not a ") +
                           VariableTypeName(root));
  }
  for (std::size_t k = 0; k + 1 < linearization_point.size(); ++k) {
    const VariableType t = TypeOf(linearization_point[k]);
    const bool other_dim = planar ? t == kVariableType<Pose3> || t == kVariableType<Point3>
                                  : t == kVariableType<Pose2> || t == kVariableType<Point2>;
    if (other_dim) {
      return InvalidArgument(std::string("LinearContainerFactor: a ") + VariableTypeName(t) +
                             " relative to a " + VariableTypeName(root) + " root");
    }
  }
  return Make(std::move(keys), std::move(linearization_point), std::move(A), std::move(b), true);
}

Result<FactorPtr> LinearContainerFactor::Make(KeyVector keys,
                                              std::vector<Variable> linearization_point,
                                              Eigen::MatrixXd A, Eigen::VectorXd b,
                                              bool root_relative) {
  if (keys.empty()) return InvalidArgument("LinearContainerFactor: no keys");
  if (linearization_point.size() != keys.size()) {
    return InvalidArgument("LinearContainerFactor: " + std::to_string(keys.size()) + " keys but " +
                           std::to_string(linearization_point.size()) + " linearisation values");
  }
  std::unordered_set<Key> seen;
  std::vector<VariableType> types;
  int columns = 0;
  for (std::size_t k = 0; k < keys.size(); ++k) {
    if (!seen.insert(keys[k]).second) {
      return InvalidArgument("LinearContainerFactor: key " + KeyToString(keys[k]) +
                             " is listed twice");
    }
    if (!AllFinite(linearization_point[k])) {
      return InvalidArgument("LinearContainerFactor: the linearisation value of " +
                             KeyToString(keys[k]) + " is not finite");
    }
    types.push_back(TypeOf(linearization_point[k]));
    if (!root_relative || k + 1 < keys.size()) columns += TangentDim(types.back());
  }
  if (b.size() < 1 || A.rows() != b.size() || A.cols() != columns) {
    return InvalidArgument("LinearContainerFactor: A is " + std::to_string(A.rows()) + "x" +
                           std::to_string(A.cols()) + " and b has " + std::to_string(b.size()) +
                           " entries; expected m x " + std::to_string(columns) + " and m >= 1");
  }
  if (!A.allFinite() || !b.allFinite()) {
    return InvalidArgument("LinearContainerFactor: A or b has a NaN or infinite entry");
  }
  return FactorPtr(std::make_shared<const LinearContainerFactor>(
      std::move(keys), std::move(types), std::move(linearization_point), std::move(A), std::move(b),
      root_relative));
}

LinearContainerFactor::LinearContainerFactor(KeyVector keys, std::vector<VariableType> types,
                                             std::vector<Variable> linearization_point,
                                             Eigen::MatrixXd A, Eigen::VectorXd b,
                                             bool root_relative)
    : DynamicFactor(std::move(keys), std::move(types), NoiseModel::Unit(static_cast<int>(b.size())),
                    RobustKernel()),
      x0_(std::move(linearization_point)),
      A_(std::move(A)),
      b_(std::move(b)),
      root_relative_(root_relative) {
  offsets_.push_back(0);
  for (std::size_t k = 0; k + (root_relative_ ? 1 : 0) < x0_.size(); ++k) {
    offsets_.push_back(offsets_.back() + TangentDim(TypeOf(x0_[k])));
  }
}

Result<FactorPtr> LinearContainerFactor::Decode(const FactorRecord& r, NoiseModel noise) {
  const int m = noise.dim();
  if (!noise.Equals(NoiseModel::Unit(m), 0.0) || !r.robust.is_none()) {
    return InvalidArgument("a linear container factor has the unit noise model and no kernel");
  }
  int columns = 0;
  for (const Variable& v : r.values) columns += TangentDim(TypeOf(v));
  // The root-relative form has no columns for its last key.
  const int relative_columns =
      r.values.empty() ? -1 : columns - TangentDim(TypeOf(r.values.back()));
  const std::size_t expected = static_cast<std::size_t>(m) * (columns + 1);
  const std::size_t relative = static_cast<std::size_t>(m) * (relative_columns + 1);
  if (r.measured.size() != expected && r.measured.size() != relative) {
    return InvalidArgument("measured: b and A are " + std::to_string(expected) + " numbers (or " +
                           std::to_string(relative) + " relative to a root), not " +
                           std::to_string(r.measured.size()));
  }
  const bool root_relative = r.measured.size() == relative;
  const int width = root_relative ? relative_columns : columns;
  const Eigen::VectorXd b = Eigen::Map<const Eigen::VectorXd>(r.measured.data(), m);
  const Eigen::MatrixXd A = Eigen::Map<const Eigen::MatrixXd>(r.measured.data() + m, m, width);
  return root_relative ? CreateRootRelative(r.keys, r.values, A, b)
                       : Create(r.keys, r.values, A, b);
}

void LinearContainerFactor::EncodeMeasured(std::vector<double>* out) const {
  out->insert(out->end(), b_.data(), b_.data() + b_.size());
  out->insert(out->end(), A_.data(), A_.data() + A_.size());
}

Eigen::VectorXd LinearContainerFactor::Evaluate(std::span<const Variable* const> x,
                                                std::vector<Eigen::MatrixXd>* H) const {
  if (root_relative_) return EvaluateRootRelative(x, H);
  Eigen::VectorXd e = b_;
  for (std::size_t k = 0; k < x0_.size(); ++k) {
    const int d = offsets_[k + 1] - offsets_[k];
    const Eigen::VectorXd delta = LocalCoordinates(x0_[k], *x[k]);
    e.noalias() += A_.middleCols(offsets_[k], d) * delta;
    if (!H) continue;
    // ∂δ/∂ε for x ⊕ ε is J⁻¹, J = ∂Local(x, x₀ ⊕ (δ + ε))/∂ε (the identity at x₀).
    const TangentMatrix J = EstimateTangentJacobian(TypeOf(x0_[k]), delta.data());
    (*H)[k] = A_.middleCols(offsets_[k], d) * J.inverse();
  }
  return e;
}

Eigen::VectorXd LinearContainerFactor::EvaluateRootRelative(std::span<const Variable* const> x,
                                                            std::vector<Eigen::MatrixXd>* H) const {
  const std::size_t root = x0_.size() - 1;
  Eigen::VectorXd e = b_;
  if (H) (*H)[root] = Eigen::MatrixXd::Zero(b_.size(), TangentDim(TypeOf(x0_[root])));
  for (std::size_t k = 0; k < root; ++k) {
    const RelativeCoordinates c =
        std::holds_alternative<Pose2>(x0_[root])
            ? RelativeTo(std::get<Pose2>(x0_[root]), x0_[k], std::get<Pose2>(*x[root]), *x[k])
            : RelativeTo(std::get<Pose3>(x0_[root]), x0_[k], std::get<Pose3>(*x[root]), *x[k]);
    const auto a = A_.middleCols(offsets_[k], offsets_[k + 1] - offsets_[k]);
    e.noalias() += a * c.local;
    if (!H) continue;
    (*H)[k] = a * c.by_x;
    (*H)[root].noalias() += a * c.by_root;
  }
  return e;
}

}  // namespace slamd::core
