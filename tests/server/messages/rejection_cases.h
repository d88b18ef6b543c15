// The stateless rejection cases of the inbound types' validation (validation_test.cc,
// camera_validation_test.cc): a Case builds a good message, breaks one thing and validates it;
// RejectionTest checks the reason and that the message names the field.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <ostream>
#include <string>

#include "server/messages/inbound.h"  // every spec's Validate

namespace slamd::server::rejection_cases {

using R = RejectReason;

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr std::int64_t kTooBig = std::int64_t{1} << 48;

struct Case {
  std::string name;
  std::function<Verdict()> run;  // builds a good message, breaks one thing, validates it
  R reason;
  std::string message_part;  // must appear in the message (the field, usually)
};

inline void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

template <typename Msg>
Case Make(std::string name, Msg good, std::function<void(Msg&)> mutate, R reason,
          std::string part) {
  return Case{std::move(name),
              [good, mutate] {
                Msg m = good;
                mutate(m);
                return Validate(m);
              },
              reason, std::move(part)};
}

// Row-major covariance helpers for the covariance reasons.
template <typename Msg>
void Asymmetric(Msg& m) {
  m.covariance[1] += 1e-3;  // (0, 1) differs from (1, 0) by 10 % of the largest entry
}
template <typename Msg>
void Indefinite(Msg& m) {
  const int d = static_cast<int>(std::lround(std::sqrt(m.num_covariance)));
  m.covariance[(d - 1) * d + (d - 1)] = -0.2;
}
template <typename Msg>
void IllConditioned(Msg& m) {
  const int d = static_cast<int>(std::lround(std::sqrt(m.num_covariance)));
  std::fill(m.covariance.begin(), m.covariance.end(), 0.0);
  for (int i = 0; i < d; ++i) m.covariance[i * d + i] = 1.0;
  m.covariance[0] = 1e-13;  // condition number 1e13 > 1e12 (core alone would accept up to 1e14)
}

class RejectionTest : public ::testing::TestWithParam<Case> {};

inline std::string CaseName(const ::testing::TestParamInfo<Case>& info) { return info.param.name; }

}  // namespace slamd::server::rejection_cases
