// Every variable type through its traits (core/variables): retract and local coordinates against
// each other, the exact encodings, names, entry kinds, and the estimate-tangent Jacobian against
// finite differences of the chart. Typed over the list itself, so a new type is covered by
// its RandomValue (tests/testing/random_values.h) where the default does not fit.
#include "core/variables/variable.h"

#include <gtest/gtest.h>

#include <random>

#include "tests/testing/numerical_derivative.h"
#include "tests/testing/random_values.h"

namespace slamd::core {
namespace {

template <typename T>
class VariableTypeTest : public ::testing::Test {};

template <typename V>
struct AsTypes;
template <typename... T>
struct AsTypes<std::variant<T...>> {
  using type = ::testing::Types<T...>;
};
using EveryVariableType = AsTypes<Variable>::type;
TYPED_TEST_SUITE(VariableTypeTest, EveryVariableType);

// A tangent vector of d entries, each normal with standard deviation `scale`.
Eigen::VectorXd RandomDelta(std::mt19937& rng, int d, double scale) {
  std::normal_distribution<double> n01(0.0, 1.0);
  Eigen::VectorXd delta(d);
  for (int k = 0; k < d; ++k) delta[k] = scale * n01(rng);
  return delta;
}

TYPED_TEST(VariableTypeTest, RetractAndLocalCoordinatesAreInverse) {
  using T = TypeParam;
  constexpr int d = VariableTraits<T>::kDim;
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const Variable a = testing::RandomValue<T>(rng);
    const Eigen::VectorXd delta = RandomDelta(rng, d, 0.3);
    Variable b = a;
    RetractInPlace(&b, delta.data());
    // local(a, a ⊕ δ) = δ, and a ⊕ local(a, b) = b.
    EXPECT_LT((LocalCoordinates(a, b) - delta).cwiseAbs().maxCoeff(), 1e-9);
    const Variable c = testing::RandomValue<T>(rng);
    Variable back = a;
    const Eigen::VectorXd ac = LocalCoordinates(a, c);
    RetractInPlace(&back, ac.data());
    EXPECT_LT(LocalCoordinates(c, back).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT(LocalCoordinates(a, a).cwiseAbs().maxCoeff(), 1e-15);
  }
}

TYPED_TEST(VariableTypeTest, EncodingReadsBackBitForBit) {
  using T = TypeParam;
  std::mt19937 rng(8);
  for (int trial = 0; trial < 10; ++trial) {
    const Variable v = testing::RandomValue<T>(rng);
    std::vector<double> numbers = {42.0};  // appended after what is there
    EncodeVariable(v, &numbers);
    ASSERT_EQ(static_cast<int>(numbers.size()), 1 + EncodedSize(kVariableType<T>));
    Result<Variable> back =
        DecodeVariable(kVariableType<T>, std::span<const double>(numbers).subspan(1));
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    std::vector<double> again;
    EncodeVariable(*back, &again);
    EXPECT_EQ(again, std::vector<double>(numbers.begin() + 1, numbers.end()));
  }
  // A wrong count or a NaN is refused with the type's name.
  const std::vector<double> short_input(EncodedSize(kVariableType<T>) - 1, 0.0);
  const Status s = DecodeVariable(kVariableType<T>, short_input).status();
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find(VariableTraits<T>::kName), std::string::npos) << s.message();
  std::vector<double> nan(EncodedSize(kVariableType<T>), std::numeric_limits<double>::quiet_NaN());
  EXPECT_FALSE(DecodeVariable(kVariableType<T>, nan).ok());
}

TYPED_TEST(VariableTypeTest, NameDimensionAndEntryKindsComeFromTheTraits) {
  using T = TypeParam;
  const VariableType type = kVariableType<T>;
  std::mt19937 rng(1);
  EXPECT_EQ(TypeOf(Variable(testing::RandomValue<T>(rng))), type);
  EXPECT_STREQ(VariableTypeName(type), VariableTraits<T>::kName);
  EXPECT_EQ(VariableTypeFromName(VariableTraits<T>::kName), type);
  EXPECT_EQ(TangentDim(type), VariableTraits<T>::kDim);
  EXPECT_LE(TangentDim(type), kMaxVariableDim);
  EXPECT_EQ(static_cast<int>(EntryKinds(type).size()), TangentDim(type));
}

TYPED_TEST(VariableTypeTest, EstimateJacobianMatchesTheChart) {
  // J = ∂Local(θ⊕δ, θ⊕(δ+ε))/∂ε at ε = 0.
  using T = TypeParam;
  constexpr int d = VariableTraits<T>::kDim;
  std::mt19937 rng(9);
  for (int trial = 0; trial < 5; ++trial) {
    const Variable theta = testing::RandomValue<T>(rng);
    const Eigen::VectorXd delta = RandomDelta(rng, d, 0.4);
    Variable estimate = theta;
    RetractInPlace(&estimate, delta.data());
    const Eigen::MatrixXd numerical = testing::NumericalJacobian(
        [&](const Eigen::VectorXd& eps) {
          Variable moved = theta;
          const Eigen::VectorXd total = delta + eps;
          RetractInPlace(&moved, total.data());
          return LocalCoordinates(estimate, moved);
        },
        Eigen::VectorXd::Zero(d));
    const Eigen::MatrixXd J = EstimateTangentJacobian(kVariableType<T>, delta.data());
    EXPECT_LT((J - numerical).cwiseAbs().maxCoeff(), 1e-6) << J << "\nvs\n" << numerical;
  }
}

TEST(VariableListTest, UnknownNamesAndKindsOfEntries) {
  EXPECT_FALSE(VariableTypeFromName("Pose4").has_value());
  EXPECT_EQ(kMaxVariableDim, 9);  // Cal3DS2
  // Poses put rotation last (the relinearisation check relies on it), calibrations are all
  // calibration entries, points all translation.
  const auto pose3 = EntryKinds(kVariableType<Pose3>);
  EXPECT_EQ(pose3[2], EntryKind::kTranslation);
  EXPECT_EQ(pose3[3], EntryKind::kRotation);
  for (EntryKind k : EntryKinds(kVariableType<Cal3Bundler>)) EXPECT_EQ(k, EntryKind::kCalibration);
  for (EntryKind k : EntryKinds(kVariableType<Point3>)) EXPECT_EQ(k, EntryKind::kTranslation);
}

TEST(VariableListTest, CalibrationsHoldTheirParametersInOrder) {
  const Cal3_S2 k(500.0, 510.0, 0.1, 320.0, 240.0);
  EXPECT_EQ(k.fx(), 500.0);
  EXPECT_EQ(k.fy(), 510.0);
  EXPECT_EQ(k.skew(), 0.1);
  EXPECT_EQ(k.u0(), 320.0);
  EXPECT_EQ(k.v0(), 240.0);
  EXPECT_EQ(k.K()(0, 1), 0.1);
  EXPECT_EQ(k.K()(1, 2), 240.0);
  const Cal3DS2 ds(k, -0.2, 0.05, 1e-3, -2e-3);
  EXPECT_EQ(ds.pinhole().vector(), k.vector());
  EXPECT_EQ(ds.k1(), -0.2);
  EXPECT_EQ(ds.p2(), -2e-3);
  const Cal3Bundler b(700.0, -0.1, 0.01);
  EXPECT_EQ(b.vector(), Eigen::Vector3d(700.0, -0.1, 0.01));
  // Plots draw poses and points, not calibrations.
  EXPECT_FALSE(PlanarPosition(b).has_value());
  EXPECT_TRUE(PlanarPosition(Point3(1, 2, 3)).has_value());
}

}  // namespace
}  // namespace slamd::core
