#include "core/factors/factor_registry.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "core/factors/bearing_range_factor.h"
#include "core/factors/between_factor.h"
#include "core/factors/linear_container_factor.h"
#include "core/factors/position_prior_factor.h"
#include "core/factors/prior_factor.h"
#include "core/factors/projection_factor.h"
#include "core/factors/relative_point_factor.h"
#include "core/factors/stereo_projection_factor.h"

namespace slamd::core {
namespace {

struct FactorType {
  const char* name;
  int num_keys;      // -1: any
  int residual_dim;  // -1: any
  Result<FactorPtr> (*decode)(const FactorRecord&, NoiseModel);
};

template <typename F>
FactorType Entry() {
  if constexpr (std::is_base_of_v<DynamicFactor, F>) {
    return {F::TypeName(), -1, -1, &F::Decode};
  } else {
    return {F::TypeName(), F::kNumKeys, F::kResidualDim, &F::Decode};
  }
}

template <std::size_t... I>
std::vector<FactorType> PriorsOfEveryKind(std::index_sequence<I...>) {
  return {Entry<PriorFactor<std::variant_alternative_t<I, Variable>>>()...};
}

// The list of factor types. Adding a factor type: one line here.
const std::vector<FactorType>& Registry() {
  static const std::vector<FactorType> registry = [] {
    std::vector<FactorType> r = PriorsOfEveryKind(internal::VariableIndices{});
    r.push_back(Entry<BetweenFactor<Pose2>>());
    r.push_back(Entry<BetweenFactor<Pose3>>());
    r.push_back(Entry<PositionPriorFactor<Pose2>>());
    r.push_back(Entry<PositionPriorFactor<Pose3>>());
    r.push_back(Entry<BearingRangeFactor>());
    r.push_back(Entry<RelativePointFactor<Pose2, Point2>>());
    r.push_back(Entry<RelativePointFactor<Pose3, Point3>>());
    r.push_back(Entry<LinearContainerFactor>());
    r.push_back(Entry<ProjectionFactor<Cal3_S2>>());
    r.push_back(Entry<ProjectionFactor<Cal3DS2>>());
    r.push_back(Entry<ProjectionFactor<Cal3Bundler>>());
    r.push_back(Entry<SelfCalibratingProjectionFactor<Cal3_S2>>());
    r.push_back(Entry<SelfCalibratingProjectionFactor<Cal3DS2>>());
    r.push_back(Entry<SelfCalibratingProjectionFactor<Cal3Bundler>>());
    r.push_back(Entry<StereoProjectionFactor>());
    return r;
  }();
  return registry;
}

}  // namespace

FactorRecord EncodeFactor(const Factor& factor) {
  FactorRecord r;
  r.type = factor.Name();
  r.keys = ToKeyVector(factor.keys());
  factor.EncodeMeasured(&r.measured);
  r.sqrt_information = factor.noise_model().sqrt_information();
  r.robust = factor.robust_kernel();
  r.values = factor.CarriedValues();
  return r;
}

Result<FactorPtr> DecodeFactor(const FactorRecord& record) {
  const FactorType* type = nullptr;
  for (const FactorType& t : Registry()) {
    if (record.type == t.name) type = &t;
  }
  if (type == nullptr) return NotFound("unknown factor type '" + record.type + "'");
  const std::string what = "factor type " + record.type + ": ";
  if (type->num_keys >= 0 && static_cast<int>(record.keys.size()) != type->num_keys) {
    return InvalidArgument(what + std::to_string(record.keys.size()) + " keys, expected " +
                           std::to_string(type->num_keys));
  }
  if (record.keys.empty()) return InvalidArgument(what + "no keys");
  const Eigen::Index rows = record.sqrt_information.rows();
  if (type->residual_dim >= 0 && rows != type->residual_dim) {
    return InvalidArgument(what + "a noise model of dimension " + std::to_string(rows) +
                           ", expected " + std::to_string(type->residual_dim));
  }
  Result<NoiseModel> noise = NoiseModel::FromSqrtInformation(record.sqrt_information);
  if (!noise.ok()) return InvalidArgument(what + noise.status().message());
  Result<FactorPtr> factor = type->decode(record, std::move(noise).value());
  if (!factor.ok()) return InvalidArgument(what + factor.status().message());
  return factor;
}

Result<FactorPtr> WithRobustKernel(const Factor& factor, const RobustKernel& kernel) {
  FactorRecord r = EncodeFactor(factor);
  r.robust = kernel;
  return DecodeFactor(r);
}

bool SameMeasurement(const Factor& a, const Factor& b, double tolerance) {
  const FactorRecord ra = EncodeFactor(a), rb = EncodeFactor(b);
  if (ra.type != rb.type || ra.keys != rb.keys || ra.robust.kind() != rb.robust.kind() ||
      ra.robust.parameter() != rb.robust.parameter() || ra.measured.size() != rb.measured.size() ||
      ra.sqrt_information.rows() != rb.sqrt_information.rows() ||
      ra.values.size() != rb.values.size()) {
    return false;
  }
  const auto close = [tolerance](const Eigen::Ref<const Eigen::VectorXd>& x,
                                 const Eigen::Ref<const Eigen::VectorXd>& y) {
    return (x - y).lpNorm<Eigen::Infinity>() <=
           tolerance * std::max(1.0, x.lpNorm<Eigen::Infinity>());
  };
  const Eigen::Map<const Eigen::VectorXd> ma(ra.measured.data(), ra.measured.size());
  const Eigen::Map<const Eigen::VectorXd> mb(rb.measured.data(), rb.measured.size());
  const Eigen::Map<const Eigen::VectorXd> Ra(ra.sqrt_information.data(),
                                             ra.sqrt_information.size());
  const Eigen::Map<const Eigen::VectorXd> Rb(rb.sqrt_information.data(),
                                             rb.sqrt_information.size());
  if (!close(ma, mb) || !close(Ra, Rb)) return false;
  for (std::size_t k = 0; k < ra.values.size(); ++k) {
    if (ra.values[k].index() != rb.values[k].index() ||
        !(LocalCoordinates(ra.values[k], rb.values[k]).lpNorm<Eigen::Infinity>() <= tolerance)) {
      return false;
    }
  }
  return true;
}

namespace {

// splitmix64's finaliser: every input bit reaches every output bit.
std::uint64_t Mix(std::uint64_t x) {
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

class Digest {
 public:
  void Add(std::uint64_t word) { h_ = Mix(h_ ^ Mix(word + 0x9e3779b97f4a7c15ULL)); }
  // The entries on a grid of 2^-30 of the largest magnitude (at least 1), and their count.
  void AddRounded(const double* x, std::size_t n) {
    Add(n);
    double largest = 1.0;
    for (std::size_t i = 0; i < n; ++i) largest = std::max(largest, std::abs(x[i]));
    const int exponent = std::ilogb(largest) + 1 - 30;
    for (std::size_t i = 0; i < n; ++i) {
      Add(static_cast<std::uint64_t>(std::llround(std::ldexp(x[i], -exponent))));
    }
  }
  std::uint64_t value() const { return h_; }

 private:
  std::uint64_t h_ = 0;
};

}  // namespace

std::uint64_t MeasurementDigest(const Factor& factor) {
  const FactorRecord r = EncodeFactor(factor);
  Digest d;
  for (char c : r.type) d.Add(static_cast<unsigned char>(c));
  d.Add(r.keys.size());
  for (Key k : r.keys) d.Add(k);
  d.Add(static_cast<std::uint64_t>(r.robust.kind()));
  const double parameter = r.robust.parameter();
  d.AddRounded(&parameter, 1);
  d.AddRounded(r.measured.data(), r.measured.size());
  d.Add(static_cast<std::uint64_t>(r.sqrt_information.rows()));
  d.AddRounded(r.sqrt_information.data(), r.sqrt_information.size());
  std::vector<double> coordinates;
  for (const Variable& v : r.values) {
    d.Add(v.index());
    coordinates.clear();
    EncodeVariable(v, &coordinates);
    d.AddRounded(coordinates.data(), coordinates.size());
  }
  return d.value();
}

std::vector<std::string_view> FactorTypeNames() {
  std::vector<std::string_view> names;
  for (const FactorType& t : Registry()) names.push_back(t.name);
  return names;
}

}  // namespace slamd::core
