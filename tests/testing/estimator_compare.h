// Comparing two estimators recovered from data directories (the crash and failover tests):
// the same variables with estimates within a tolerance, and the same factors (identity and
// measured values) with none doubled.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "core/base/check.h"
#include "core/variables/variable.h"
#include "server/config/server_params.h"
#include "server/estimator/estimator.h"
#include "server/estimator/recovery.h"
#include "server/snapshot/estimator_state.h"

namespace slamd::testing {

using server::Estimator;
using server::EstimatorState;
using server::RecoveryResult;
using server::ServerParams;

// A factor's identity (type and keys) and what it measures: its unwhitened error at a fixed
// point (which determines the measured value of between factors and priors) and its chi2 there
// (the noise). Compared with a tolerance: snapshots store noise as square-root information.
using FactorSet = std::multimap<std::string, std::vector<double>>;

inline FactorSet Factors(const std::vector<core::FactorPtr>& factors, const core::Values& at) {
  FactorSet out;
  for (const core::FactorPtr& f : factors) {
    std::string id = f->Name();
    for (core::Key k : f->keys()) id.append(" ").append(core::KeyToString(k));
    const auto e = f->Error(at);
    std::vector<double> v(e.data(), e.data() + e.size());
    v.push_back(f->Chi2(at));
    out.emplace(std::move(id), std::move(v));
  }
  return out;
}

// a and b hold the same factors: same identities, none twice, values within 1e-9 relative.
inline void ExpectSameFactors(const FactorSet& a, const FactorSet& b) {
  if (a.size() != b.size()) {
    std::set<std::string> ia, ib;
    for (const auto& [id, v] : a) ia.insert(id);
    for (const auto& [id, v] : b) ib.insert(id);
    std::string only_a, only_b;
    for (const std::string& id : ia) {
      if (!ib.count(id)) only_a += " [" + id + "]";
    }
    for (const std::string& id : ib) {
      if (!ia.count(id)) only_b += " [" + id + "]";
    }
    FAIL() << "factor counts differ: " << a.size() << " vs " << b.size()
           << "; only in the first:" << only_a << "; only in the second:" << only_b;
  }
  std::set<std::string> ids;
  for (const auto& [id, v] : a) EXPECT_TRUE(ids.insert(id).second) << "doubled factor " << id;
  int differ = 0;
  for (auto ia = a.begin(), ib = b.begin(); ia != a.end(); ++ia, ++ib) {
    if (ia->first != ib->first) {
      ADD_FAILURE() << "factor " << ia->first << " vs " << ib->first;
      return;
    }
    for (size_t i = 0; i < ia->second.size(); ++i) {
      const double x = ia->second[i], y = ib->second[i];
      if (std::abs(x - y) > 1e-9 * (1.0 + std::abs(x))) ++differ;
    }
  }
  EXPECT_EQ(differ, 0) << "factors with the same keys measure different values";
}

struct Recovered {
  std::unique_ptr<Estimator> estimator;
  EstimatorState state;
};

// Recovers `dir` in-process and refines to convergence.
inline Recovered RecoverAndConverge(const std::string& dir, const ServerParams& params) {
  core::Result<RecoveryResult> r = server::Recover(dir, params.estimator, params.isam2, false);
  SLAMD_CHECK(r.ok()) << r.status().ToString();
  EXPECT_EQ(r.value().torn_tail_offset, -1) << dir;
  EXPECT_TRUE(r.value().pending.empty()) << dir;
  Recovered out{std::move(r.value().estimator), {}};
  for (int i = 0; i < 100; ++i) {
    const core::Isam2::RefineResult rr = out.estimator->Refine(30.0);
    SLAMD_CHECK(rr.status.ok()) << rr.status.ToString();
    if (rr.converged) break;
  }
  out.state = out.estimator->ExportState();
  return out;
}

// Both recovered estimators have the same variables, estimates within tol, and the same
// multiset of factors (compared at a's estimate).
inline void ExpectSameEstimators(const Recovered& a, const Recovered& b, int expected_factors,
                                 double tol) {
  const core::Values ea = a.estimator->solver().CalculateEstimate();
  const core::Values eb = b.estimator->solver().CalculateEstimate();
  ASSERT_EQ(ea.size(), eb.size());
  double worst = 0.0;
  for (core::Key k : ea.keys()) {
    ASSERT_TRUE(eb.Contains(k)) << core::KeyToString(k);
    worst = std::max(worst, core::LocalCoordinates(ea.Get(k), eb.Get(k)).lpNorm<Eigen::Infinity>());
  }
  // Both chi2: identical factors settled at different estimates are two local minima (a
  // different batching of the same updates), or one not converged.
  EXPECT_LE(worst, tol) << "largest estimate difference; chi2 " << a.estimator->solver().Chi2()
                        << " against " << b.estimator->solver().Chi2();
  std::printf("[ compare  ] %zu variables, largest estimate difference %.3g\n", ea.size(), worst);

  const FactorSet fa = Factors(a.state.factors, ea), fb = Factors(b.state.factors, ea);
  EXPECT_EQ(static_cast<int>(fa.size()), expected_factors);
  ExpectSameFactors(fa, fb);
}

}  // namespace slamd::testing
