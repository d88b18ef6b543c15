// Every registered factor type, through one example each (tests/testing/factor_examples.h):
// Jacobians against finite differences, the record round trip, and the text formats it declares.
#include "core/factors/factor_registry.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>

#include "tests/testing/factor_examples.h"

namespace slamd::core {
namespace {

using testing::EveryFactorTypeExample;
using testing::FactorExample;

TEST(FactorExamplesTest, EveryRegisteredTypeHasOneExample) {
  std::set<std::string> registered, examples;
  for (std::string_view name : FactorTypeNames()) {
    EXPECT_TRUE(registered.insert(std::string(name)).second) << name << " is registered twice";
  }
  for (const FactorExample& e : EveryFactorTypeExample(1)) examples.insert(e.factor->Name());
  EXPECT_EQ(registered, examples);
  // One prior per variable type, plus the others.
  EXPECT_TRUE(registered.count("PriorCal3DS2"));
  EXPECT_TRUE(registered.count("LinearContainer"));
}

class EveryFactorTest : public ::testing::TestWithParam<unsigned> {};

TEST_P(EveryFactorTest, JacobiansMatchFiniteDifferences) {
  for (const FactorExample& e : EveryFactorTypeExample(GetParam())) {
    SCOPED_TRACE(e.factor->Name());
    testing::ExpectJacobiansMatchNumerical(*e.factor, e.values, 1e-6);
  }
}

TEST_P(EveryFactorTest, RecordRoundTripGivesTheSameFactor) {
  for (const FactorExample& e : EveryFactorTypeExample(GetParam())) {
    SCOPED_TRACE(e.factor->Name());
    const FactorRecord record = EncodeFactor(*e.factor);
    EXPECT_EQ(record.type, e.factor->Name());
    Result<FactorPtr> back = DecodeFactor(record);
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    const Factor& f = **back;
    EXPECT_STREQ(f.Name(), e.factor->Name());
    EXPECT_EQ(ToKeyVector(f.keys()), ToKeyVector(e.factor->keys()));
    for (int k = 0; k < static_cast<int>(f.keys().size()); ++k) {
      EXPECT_EQ(f.KeyType(k), e.factor->KeyType(k));
    }
    EXPECT_TRUE(f.noise_model().Equals(e.factor->noise_model(), 1e-9));
    EXPECT_LT((f.Error(e.values) - e.factor->Error(e.values)).norm(), 1e-12);
    LinearizedFactor a, b;
    e.factor->Linearize(e.values, &a);
    f.Linearize(e.values, &b);
    EXPECT_LT((a.Ab() - b.Ab()).cwiseAbs().maxCoeff(), 1e-9);
    // Encoding again gives the same numbers.
    const FactorRecord again = EncodeFactor(f);
    EXPECT_EQ(again.measured, record.measured);
  }
}

TEST_P(EveryFactorTest, WithRobustKernelKeepsTheMeasurement) {
  const RobustKernel huber = RobustKernel::Create(RobustKernel::Kind::kHuber, 1.0).value();
  for (const FactorExample& e : EveryFactorTypeExample(GetParam())) {
    SCOPED_TRACE(e.factor->Name());
    Result<FactorPtr> robust = WithRobustKernel(*e.factor, huber);
    if (std::string(e.factor->Name()) == "LinearContainer") {
      EXPECT_FALSE(robust.ok());  // already whitened: no kernel
      continue;
    }
    ASSERT_TRUE(robust.ok()) << robust.status().ToString();
    EXPECT_EQ((*robust)->robust_kernel().kind(), RobustKernel::Kind::kHuber);
    const double chi2 = e.factor->Chi2(e.values);  // may be large: compare relatively
    EXPECT_LT(std::abs((*robust)->Chi2(e.values) - chi2), 1e-12 * std::max(1.0, chi2));
  }
}

// The digest stands for the measurement: equal through a record round trip and round-off in
// R, different for another key, noise, kernel, or for another factor altogether.
TEST_P(EveryFactorTest, DigestTellsMeasurementsApart) {
  std::set<std::uint64_t> digests;
  for (const FactorExample& e : EveryFactorTypeExample(GetParam())) {
    SCOPED_TRACE(e.factor->Name());
    const std::uint64_t digest = MeasurementDigest(*e.factor);
    EXPECT_TRUE(digests.insert(digest).second);
    const FactorRecord record = EncodeFactor(*e.factor);
    EXPECT_EQ(MeasurementDigest(*DecodeFactor(record).value()), digest);
    const auto digest_of = [](const FactorRecord& r) {
      Result<FactorPtr> f = DecodeFactor(r);
      EXPECT_TRUE(f.ok()) << f.status().ToString();
      return f.ok() ? MeasurementDigest(*f.value()) : 0;
    };
    const bool linear = std::string(e.factor->Name()) == "LinearContainer";
    // R's first entry (a linear container's b: its R is the identity) changed by `relative`.
    const auto nudged = [&](double relative) {
      FactorRecord r = record;
      if (linear) {
        const Eigen::Map<const Eigen::VectorXd> m(r.measured.data(), r.measured.size());
        r.measured[0] += relative * std::max(1.0, m.lpNorm<Eigen::Infinity>());
      } else {
        r.sqrt_information(0, 0) *= 1.0 + relative;
      }
      return r;
    };
    FactorRecord changed = nudged(1e-14);  // round-off: the same measurement
    EXPECT_TRUE(SameMeasurement(*DecodeFactor(changed).value(), *e.factor));
    EXPECT_EQ(digest_of(changed), digest);
    changed = nudged(1e-6);
    EXPECT_FALSE(SameMeasurement(*DecodeFactor(changed).value(), *e.factor));
    EXPECT_NE(digest_of(changed), digest);
    changed = record;
    changed.keys[0] += 1000;
    EXPECT_NE(digest_of(changed), digest);
    if (!linear) {  // a linear container takes no kernel
      changed = record;
      changed.robust = RobustKernel::Create(RobustKernel::Kind::kHuber, 1.0).value();
      EXPECT_NE(digest_of(changed), digest);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, EveryFactorTest, ::testing::Values(1u, 2u, 3u));

TEST(FactorRegistryTest, BadRecordsAreRefusedWithAReason) {
  FactorRecord r = EncodeFactor(*EveryFactorTypeExample(5)[5].factor);
  {
    FactorRecord bad = r;
    bad.type = "NoSuchFactor";
    const Status s = DecodeFactor(bad).status();
    EXPECT_EQ(s.code(), StatusCode::kNotFound);
    EXPECT_NE(s.message().find("NoSuchFactor"), std::string::npos) << s.message();
  }
  {
    FactorRecord bad = r;
    bad.keys.push_back(MakeKey('z', 9));
    const Status s = DecodeFactor(bad).status();
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(s.message().find("keys"), std::string::npos) << s.message();
  }
  {
    FactorRecord bad = r;
    bad.measured.pop_back();
    const Status s = DecodeFactor(bad).status();
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(s.message().find(r.type), std::string::npos) << s.message();
  }
  {
    FactorRecord bad = r;
    bad.sqrt_information =
        Eigen::MatrixXd::Identity(r.sqrt_information.rows() + 1, r.sqrt_information.rows() + 1);
    EXPECT_EQ(DecodeFactor(bad).status().code(), StatusCode::kInvalidArgument);
  }
  {
    FactorRecord bad = r;
    bad.measured[0] = std::numeric_limits<double>::quiet_NaN();
    EXPECT_EQ(DecodeFactor(bad).status().code(), StatusCode::kInvalidArgument);
  }
}

}  // namespace
}  // namespace slamd::core
