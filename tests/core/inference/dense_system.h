// A dense oracle for the node-removal tests (node_removal_test.cc, chow_liu_test.cc): the
// information matrix H = JᵀJ and gradient Jᵀb of factors linearised at θ, in a given key order.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <vector>

#include "core/factors/factor.h"
#include "core/factors/linearized_factor.h"
#include "core/factors/values.h"

namespace slamd::core::testing {

struct DenseSystem {
  Eigen::MatrixXd H;
  Eigen::VectorXd g;
  std::vector<int> column;  // first column of keys[i]; column.back() = total
};

inline DenseSystem Dense(const std::vector<FactorPtr>& factors, const Values& theta,
                         const KeyVector& keys) {
  DenseSystem s;
  s.column.push_back(0);
  for (Key k : keys) s.column.push_back(s.column.back() + theta.DimAt(theta.SlotOf(k)));
  const int n = s.column.back();
  s.H = Eigen::MatrixXd::Zero(n, n);
  s.g = Eigen::VectorXd::Zero(n);
  LinearizedFactor lf;
  for (const FactorPtr& f : factors) {
    f->Linearize(theta, &lf);
    Eigen::MatrixXd j = Eigen::MatrixXd::Zero(lf.rows(), n);
    for (int k = 0; k < lf.num_keys(); ++k) {
      const auto at = std::find(keys.begin(), keys.end(), f->keys()[k]) - keys.begin();
      j.middleCols(s.column[at], lf.dim(k)) = lf.Block(k);
    }
    s.H += j.transpose() * j;
    s.g += j.transpose() * lf.Rhs();
  }
  return s;
}

}  // namespace slamd::core::testing
