#include "server/snapshot/state_codec.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <tuple>

#include "core/factors/between_factor.h"
#include "core/factors/factor_registry.h"
#include "core/geometry/rot3.h"
#include "server/estimator/estimator.h"
#include "slamd_proto/snapshot.pb.h"
#include "tests/testing/factor_examples.h"
#include "tests/testing/noise.h"

namespace slamd::server {
namespace {

using core::Pose2;
using core::Pose3;

using testing::Noise;

Pose3 P3(double x, double yaw) {
  return Pose3(core::Rot3::FromRollPitchYaw(0.1, -0.05, yaw), core::Point3(x, 0.2, -0.1));
}

// Every factor type the estimator makes, a removal, a robust loop closure, and a held message.
std::vector<Inbound> Messages() {
  std::vector<Inbound> m;
  m.push_back(
      {PriorMeasurement{1, "r", 0, PriorKind::kPose2, Pose2(1, 2, 0.3), Noise(3, 0.01)}, 0});
  for (std::uint64_t i = 0; i < 5; ++i) {
    m.push_back({OdometryMeasurement{2, "r", i, i + 1, Pose2(1, 0.1, 0.2), Noise(3, 0.1)}, 0});
  }
  m.push_back({LandmarkMeasurement{3, "r", 1, 7, LandmarkKind::kBearingRange2,
                                   BearingRange{0.2, 3.0}, Noise(2, 0.05)},
               0});
  m.push_back({LandmarkMeasurement{3, "r", 2, 7, LandmarkKind::kBearingRange2,
                                   BearingRange{0.1, 2.5}, Noise(2, 0.05)},
               0});
  m.push_back({LandmarkMeasurement{3, "r", 3, 8, LandmarkKind::kRelativePoint2, core::Point2(1, -1),
                                   Noise(2, 0.05)},
               0});
  m.push_back(
      {PriorMeasurement{4, "r", 4, PriorKind::kPosition2, core::Point2(4, 3), Noise(2, 1)}, 0});
  m.push_back({LoopClosureMeasurement{
                   5, "r", 5, "r", 1, Pose2(-3, 0.5, -0.6), Noise(3, 0.2),
                   core::RobustKernel::Create(core::RobustKernel::Kind::kCauchy, 1.0).value()},
               0});
  m.push_back(
      {LoopClosureMeasurement{5, "r", 5, "r", 2, Pose2(-2, 0.3, -0.4), Noise(3, 0.2), {}}, 0});
  m.push_back({PriorMeasurement{6, "s", 0, PriorKind::kPose3, P3(0, 0.1), Noise(6, 0.01)}, 0});
  m.push_back({OdometryMeasurement{7, "s", 0, 1, P3(1, 0.2), Noise(6, 0.1)}, 0});
  m.push_back({LandmarkMeasurement{8, "s", 1, 2, LandmarkKind::kRelativePoint3,
                                   core::Point3(1, 2, 3), Noise(3, 0.1)},
               0});
  m.push_back(
      {PriorMeasurement{9, "s", 1, PriorKind::kPosition3, core::Point3(1, 0, 0), Noise(3, 2)}, 0});
  m.push_back({RemoveFactorRequest{10, RemoveTarget::kLoopClosure, "r", 5, "r", 2, 0}, 0});
  m.push_back({OdometryMeasurement{11, "r", 7, 8, Pose2(1, 0, 0), Noise(3, 0.1)}, 0});  // held
  return m;
}

TEST(StateCodecTest, RoundTripRestoresAnEquivalentEstimator) {
  core::Isam2Params isam2;
  auto original = Estimator::Create({}, isam2).value();
  ASSERT_TRUE(original->Process(Messages()).status.ok());
  ASSERT_EQ(original->held_messages(), 1);
  const EstimatorState state = original->ExportState();
  ASSERT_EQ(state.applied.size(), 15u);  // 16 measurements applied, one removed

  const std::string bytes = EncodeState(state, {.last_message_sequence = 42, .journal_offset = 7});
  JournalPosition position;
  core::Result<EstimatorState> decoded = DecodeState(bytes, &position);
  ASSERT_TRUE(decoded.ok()) << decoded.status().ToString();
  EXPECT_EQ(position.last_message_sequence, 42);
  EXPECT_EQ(position.journal_offset, 7);
  const EstimatorState& d = decoded.value();
  ASSERT_EQ(d.factors.size(), state.factors.size());
  // Factors: same types, keys, and errors at the same values (bit for bit: the geometry is
  // stored exactly; the noise model is re-factored, so its whitening to rounding).
  for (size_t i = 0; i < state.factors.size(); ++i) {
    EXPECT_STREQ(d.factors[i]->Name(), state.factors[i]->Name());
    EXPECT_EQ(core::ToKeyVector(d.factors[i]->keys()), core::ToKeyVector(state.factors[i]->keys()));
    EXPECT_EQ(d.factors[i]->robust_kernel().kind(), state.factors[i]->robust_kernel().kind());
    const auto e0 = state.factors[i]->Error(state.linearization_point);
    const auto e1 = d.factors[i]->Error(state.linearization_point);
    EXPECT_LT((e0 - e1).norm(), 1e-15) << d.factors[i]->Name();
    const auto& R0 = state.factors[i]->noise_model().sqrt_information();
    const auto& R1 = d.factors[i]->noise_model().sqrt_information();
    EXPECT_LT((R0.transpose() * R0 - R1.transpose() * R1).norm(), 1e-9 * R0.squaredNorm());
  }
  ASSERT_EQ(d.linearization_point.size(), state.linearization_point.size());
  for (core::Key k : state.linearization_point.keys()) {
    EXPECT_LT(core::LocalCoordinates(state.linearization_point.Get(k), d.linearization_point.Get(k))
                  .norm(),
              1e-15);
  }
  EXPECT_EQ(d.robots.size(), 2u);
  EXPECT_EQ(d.held.size(), 1u);
  EXPECT_EQ(d.counters.applied, state.counters.applied);
  EXPECT_EQ(d.num_factors, state.num_factors);

  auto restored = Estimator::Restore({}, isam2, d).value();
  EXPECT_EQ(restored->snapshot()->update_sequence, original->snapshot()->update_sequence);
  EXPECT_EQ(restored->snapshot()->num_factors, original->snapshot()->num_factors);
  EXPECT_EQ(restored->held_messages(), 1);
  ASSERT_EQ(restored->snapshot()->robots.size(), 2u);
  // The same further messages on both: the held odometry is released, a duplicate is refused,
  // a removal finds its measurement, and both settle to the same estimate.
  const std::vector<Inbound> more = {
      {OdometryMeasurement{12, "r", 6, 7, Pose2(1, 0, 0.1), Noise(3, 0.1)}, 0},
      {OdometryMeasurement{12, "r", 5, 6, Pose2(1, 0, 0.1), Noise(3, 0.1)}, 0},
      {OdometryMeasurement{13, "r", 0, 1, Pose2(1, 0.1, 0.2), Noise(3, 0.1)}, 0},  // held
      {OdometryMeasurement{13, "r", 0, 1, Pose2(1, 0.1, 0.3), Noise(3, 0.1)}, 0},  // differs
      {RemoveFactorRequest{14, RemoveTarget::kLoopClosure, "r", 5, "r", 1, 0}, 0}};
  for (Estimator* e : {original.get(), restored.get()}) {
    const std::int64_t held_before = e->snapshot()->counters.already_held;
    const ProcessResult r = e->Process(more);
    ASSERT_TRUE(r.status.ok()) << r.status.ToString();
    EXPECT_EQ(r.applied, 4);
    ASSERT_EQ(r.rejections.size(), 1u);
    EXPECT_EQ(r.rejections[0].verdict.reason, RejectReason::kDuplicate);
    // The restored solver's factor (R re-factored from the snapshot) is the same measurement.
    EXPECT_EQ(e->snapshot()->counters.already_held, held_before + 1);
    EXPECT_EQ(e->held_messages(), 0);
    ASSERT_TRUE(e->Refine(5.0).converged);
  }
  const core::Values a = original->solver().CalculateEstimate();
  const core::Values b = restored->solver().CalculateEstimate();
  ASSERT_EQ(a.size(), b.size());
  for (core::Key k : a.keys()) {
    EXPECT_LT(core::LocalCoordinates(a.Get(k), b.Get(k)).norm(), 1e-7) << core::KeyToString(k);
  }
  EXPECT_NEAR(original->snapshot()->chi2, restored->snapshot()->chi2, 1e-9);
  // Both export the same retractable measurements (the factor positions differ).
  using Row = std::tuple<char, core::Key, core::Key, int, core::Key, int>;
  std::vector<Row> rows[2];
  for (int k = 0; k < 2; ++k) {
    for (const EstimatorState::Applied& m : (k == 0 ? original : restored)->ExportState().applied) {
      rows[k].emplace_back(m.type, m.a, m.b, m.kind, m.first, m.dim);
    }
    std::sort(rows[k].begin(), rows[k].end());
  }
  EXPECT_EQ(rows[0].size(), 17u);  // 15, three more odometry, one more removed
  EXPECT_EQ(rows[0], rows[1]);
}

// A robot anchored at the origin has a prior no message made, so no measurement to retract: a
// restored estimator numbers that factor too, and its export must not list it.
TEST(StateCodecTest, FactorsWithoutAMeasurementAreNotExportedAsOne) {
  core::Isam2Params isam2;
  const EstimatorParams params{.new_robot_anchor = AnchorPolicy::kAnchorAtOrigin};
  auto original = Estimator::Create(params, isam2).value();
  std::vector<Inbound> odometry;
  for (std::uint64_t i = 0; i < 4; ++i) {
    odometry.push_back({OdometryMeasurement{2, "r", i, i + 1, Pose2(1, 0, 0.1), Noise(3, 0.1)}, 0});
  }
  ASSERT_EQ(original->Process(odometry).applied, 4);
  const EstimatorState state = original->ExportState();
  ASSERT_EQ(state.factors.size(), 5u);  // the anchor and four odometry factors
  ASSERT_EQ(state.applied.size(), 4u);
  auto restored = Estimator::Restore(params, isam2, state).value();
  EXPECT_EQ(restored->ExportState().applied.size(), 4u);
}

TEST(StateCodecTest, CorruptBytesGiveDataLossNamingThePart) {
  JournalPosition position;
  core::Result<EstimatorState> r = DecodeState("\xff\xff\xff garbage", &position);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), core::StatusCode::kDataLoss);

  core::Isam2Params isam2;
  auto e = Estimator::Create({}, isam2).value();
  ASSERT_TRUE(e->Process(Messages()).status.ok());
  EstimatorState state = e->ExportState();
  state.applied[0].factor = 1000;
  core::Result<EstimatorState> d = DecodeState(EncodeState(state, {}), &position);
  ASSERT_TRUE(d.ok());
  core::Result<std::unique_ptr<Estimator>> bad = Estimator::Restore({}, isam2, d.value());
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("factor 1000"), std::string::npos)
      << bad.status().ToString();

  // Two measurements on one factor, or one of no dimension.
  for (int variant = 0; variant < 2; ++variant) {
    EstimatorState twice = e->ExportState();
    ASSERT_GE(twice.applied.size(), 2u);
    if (variant == 0) twice.applied[1].factor = twice.applied[0].factor;
    if (variant == 1) twice.applied[1].dim = 0;
    bad = Estimator::Restore({}, isam2, twice);
    ASSERT_FALSE(bad.ok());
    EXPECT_EQ(bad.status().code(), core::StatusCode::kDataLoss);
    EXPECT_NE(bad.status().message().find("not the only one"), std::string::npos)
        << bad.status().ToString();
  }

  // An anchored robot whose newest pose is not in the graph (found by fuzz_state: the next
  // update read that pose and aborted).
  EstimatorState missing = e->ExportState();
  ASSERT_FALSE(missing.robots.empty());
  missing.robots[0].state.newest = 1000;
  bad = Estimator::Restore({}, isam2, missing);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().code(), core::StatusCode::kDataLoss);
  EXPECT_NE(bad.status().message().find("newest pose 1000"), std::string::npos)
      << bad.status().ToString();
}

// Snapshots store a factor by its registered type name (core/factors/factor_registry.h): every
// type, including the dense linear container, reads back as the same factor.
TEST(StateCodecTest, EveryRegisteredFactorTypeRoundTrips) {
  for (const testing::FactorExample& e : testing::EveryFactorTypeExample(11)) {
    SCOPED_TRACE(e.factor->Name());
    EstimatorState state;
    state.factors.push_back(e.factor);
    state.linearization_point = e.values;
    JournalPosition position;
    core::Result<EstimatorState> back = DecodeState(EncodeState(state, {}), &position);
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    ASSERT_EQ(back->factors.size(), 1u);
    const core::FactorRecord a = core::EncodeFactor(*e.factor);
    const core::FactorRecord b = core::EncodeFactor(*back->factors[0]);
    EXPECT_EQ(a.type, b.type);
    EXPECT_EQ(a.keys, b.keys);
    EXPECT_EQ(a.measured, b.measured);
    EXPECT_LT((a.sqrt_information - b.sqrt_information).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_EQ(a.values.size(), b.values.size());
    for (core::Key key : e.values.keys()) {  // bit for bit
      std::vector<double> a_values, b_values;
      core::EncodeVariable(e.values.Get(key), &a_values);
      core::EncodeVariable(back->linearization_point.Get(key), &b_values);
      EXPECT_EQ(a_values, b_values) << core::KeyToString(key);
    }
  }
}

// Merged measurements are written as their digest (with the reduced graph's counters); older
// snapshots, which hold the factor, load as the factor's digest.
TEST(StateCodecTest, MergedMeasurementsAreDigests) {
  const core::FactorPtr factor = std::make_shared<const core::BetweenFactor<Pose2>>(
      core::MakeKey('x', 3), core::MakeKey('x', 4), Pose2(1, 0.5, 0.2), Noise(3, 0.1));
  EstimatorState state;
  state.merged.push_back(
      {'o', factor->keys()[0], factor->keys()[1], 0, core::MeasurementDigest(*factor)});
  state.counters.merged_poses = 7;
  state.counters.reduced_left_out = 5;
  snapshot::EstimatorState written;
  ASSERT_TRUE(written.ParseFromString(EncodeState(state, {})));
  ASSERT_EQ(written.merged_size(), 1);
  EXPECT_FALSE(written.merged(0).has_factor());
  EXPECT_EQ(written.merged(0).digest(), core::MeasurementDigest(*factor));

  // The older layout: the factor (as WriteFactor wrote it), no digest.
  snapshot::MergedMeasurement* old = written.mutable_merged(0);
  old->clear_digest();
  const core::FactorRecord r = core::EncodeFactor(*factor);
  old->mutable_factor()->set_type_name(r.type);
  for (core::Key k : r.keys) old->mutable_factor()->add_keys(k);
  for (double x : r.measured) old->mutable_factor()->add_measured(x);
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) {
      old->mutable_factor()->add_sqrt_information(r.sqrt_information(row, col));
    }
  }
  JournalPosition position;
  core::Result<EstimatorState> back = DecodeState(written.SerializeAsString(), &position);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  ASSERT_EQ(back->merged.size(), 1u);
  EXPECT_EQ(back->merged[0].digest, core::MeasurementDigest(*factor));
  EXPECT_EQ(back->counters.merged_poses, 7);
  EXPECT_EQ(back->counters.reduced_left_out, 5);
  EXPECT_EQ(back->merged[0].b, core::MakeKey('x', 4));
  // A corrupt older factor is refused as the other parts are.
  old->mutable_factor()->set_type_name("NoSuchFactor");
  EXPECT_EQ(DecodeState(written.SerializeAsString(), &position).status().code(),
            core::StatusCode::kDataLoss);
}

// A state larger than the encoder's chunks (it writes the big repeated fields a thousand or so
// elements at a time): every element comes back, in order.
TEST(StateCodecTest, LargeStatesRoundTripInOrder) {
  constexpr int kPoses = 2500, kMerged = 3100, kAliases = 1500;
  EstimatorState state;
  for (int i = 0; i < kPoses; ++i) {
    ASSERT_TRUE(
        state.linearization_point.Insert(core::MakeKey('x', i), Pose2(i, 0.5, 0.01 * i)).ok());
  }
  for (int i = 0; i + 1 < kPoses; ++i) {
    const core::Key a = core::MakeKey('x', i), b = core::MakeKey('x', i + 1);
    state.factors.push_back(
        std::make_shared<const core::BetweenFactor<Pose2>>(a, b, Pose2(1, 0, i), Noise(3, 0.1)));
    state.applied.push_back({'o', a, b, 0, i, a, 3});
  }
  for (int i = 0; i < kMerged; ++i) {
    state.merged.push_back(
        {'l', core::MakeKey('x', i % kPoses), core::MakeKey('l', i), 1, 977u * i + 1});
  }
  for (int i = 0; i < kAliases; ++i) {
    state.aliases.push_back(
        {core::MakeKey('x', kPoses + i),
         {core::MakeKey('x', i), Pose2(0.5, 0, 0.1), (i + 1) * Eigen::Matrix3d::Identity()}});
  }
  JournalPosition position;
  const core::Result<EstimatorState> back = DecodeState(
      EncodeState(state, {.last_message_sequence = 9, .journal_offset = 99}), &position);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(position.last_message_sequence, 9);
  EXPECT_EQ(position.journal_offset, 99);
  ASSERT_EQ(back->linearization_point.size(), static_cast<size_t>(kPoses));
  ASSERT_EQ(back->factors.size(), state.factors.size());
  ASSERT_EQ(back->applied.size(), state.applied.size());
  ASSERT_EQ(back->merged.size(), state.merged.size());
  ASSERT_EQ(back->aliases.size(), state.aliases.size());
  for (int i = 0; i < kPoses; ++i) {
    ASSERT_EQ(back->linearization_point.KeyAt(i), state.linearization_point.KeyAt(i));
  }
  for (size_t i = 0; i < state.factors.size(); ++i) {
    ASSERT_EQ(core::ToKeyVector(back->factors[i]->keys()),
              core::ToKeyVector(state.factors[i]->keys()));
    ASSERT_EQ(core::MeasurementDigest(*back->factors[i]),
              core::MeasurementDigest(*state.factors[i]));
    ASSERT_EQ(back->applied[i].factor, state.applied[i].factor);
  }
  for (size_t i = 0; i < state.merged.size(); ++i) {
    ASSERT_EQ(back->merged[i].b, state.merged[i].b);
    ASSERT_EQ(back->merged[i].digest, state.merged[i].digest);
  }
  for (size_t i = 0; i < state.aliases.size(); ++i) {
    ASSERT_EQ(back->aliases[i].first, state.aliases[i].first);
    ASSERT_EQ(back->aliases[i].second.covariance, state.aliases[i].second.covariance);
  }
}

// A snapshot written before factors and variables were stored by type name (the enums) loads.
TEST(StateCodecTest, SnapshotsWrittenBeforeTypeNamesLoad) {
  snapshot::EstimatorState old;
  snapshot::KeyedVariable* v = old.add_linearization_point();
  v->set_key(core::MakeKey('x', 0));
  v->mutable_value()->set_type(snapshot::Variable::POSE2);
  for (double x : {1.0, 2.0, std::cos(0.3), std::sin(0.3)}) v->mutable_value()->add_values(x);
  v = old.add_linearization_point();
  v->set_key(core::MakeKey('l', 0));
  v->mutable_value()->set_type(snapshot::Variable::POINT2);
  for (double x : {4.0, 5.0}) v->mutable_value()->add_values(x);
  snapshot::Factor* f = old.add_factors();
  f->set_type(snapshot::Factor::BEARING_RANGE);
  f->add_keys(core::MakeKey('x', 0));
  f->add_keys(core::MakeKey('l', 0));
  f->add_measured(0.25);
  f->add_measured(3.5);
  for (double r : {10.0, 0.0, 0.0, 20.0}) f->add_sqrt_information(r);
  JournalPosition position;
  core::Result<EstimatorState> state = DecodeState(old.SerializeAsString(), &position);
  ASSERT_TRUE(state.ok()) << state.status().ToString();
  ASSERT_EQ(state->factors.size(), 1u);
  EXPECT_STREQ(state->factors[0]->Name(), "BearingRange2");
  EXPECT_EQ(core::EncodeFactor(*state->factors[0]).measured, (std::vector<double>{0.25, 3.5}));
  EXPECT_NEAR(state->linearization_point.At<Pose2>(core::MakeKey('x', 0)).theta(), 0.3, 1e-15);
  EXPECT_EQ(state->linearization_point.At<core::Point2>(core::MakeKey('l', 0)).y(), 5.0);

  // A type this build does not know is refused by name.
  f->set_type_name("TrifocalTensor");
  state = DecodeState(old.SerializeAsString(), &position);
  ASSERT_FALSE(state.ok());
  EXPECT_EQ(state.status().code(), core::StatusCode::kDataLoss);
  EXPECT_NE(state.status().message().find("TrifocalTensor"), std::string::npos)
      << state.status().ToString();
}

}  // namespace
}  // namespace slamd::server
