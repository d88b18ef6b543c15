#include "clients/slamctl/robustify.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <memory>

#include "core/factors/factor_registry.h"

namespace slamd::clients {
namespace {

using core::RobustKernel;

bool IsOdometryPair(core::Key a, core::Key b) {
  if (core::KeyRobot(a) != core::KeyRobot(b) || core::KeySymbol(a) != core::KeySymbol(b)) return false;
  const std::uint64_t i = core::KeyIndex(a), j = core::KeyIndex(b);
  return (i > j ? i - j : j - i) == 1;
}

}  // namespace

bool IsLoopClosure(const core::Factor& factor) {
  return core::MeasuredRelativePose(factor).has_value() &&
         !IsOdometryPair(factor.keys()[0], factor.keys()[1]);
}

core::FactorGraph RobustifyLoopClosures(const core::FactorGraph& graph, const RobustKernel& kernel,
                                        std::size_t* loop_closures) {
  core::FactorGraph out;
  std::size_t count = 0;
  for (const core::FactorPtr& factor : graph) {
    if (!IsLoopClosure(*factor)) {
      out.Add(factor);
      continue;
    }
    ++count;
    core::Result<core::FactorPtr> rebuilt = core::WithRobustKernel(*factor, kernel);
    SLAMD_CHECK(rebuilt.ok()) << rebuilt.status().ToString();  // a valid factor re-encoded
    out.Add(std::move(rebuilt).value());
  }
  if (loop_closures != nullptr) *loop_closures = count;
  return out;
}

double DefaultRobustParameter(RobustKernel::Kind kind) {
  switch (kind) {
    case RobustKernel::Kind::kNone: return 0.0;
    case RobustKernel::Kind::kHuber: return 3.0;
    case RobustKernel::Kind::kCauchy: return 3.0;
    case RobustKernel::Kind::kGemanMcClure: return 3.0;
    case RobustKernel::Kind::kDcs: return 9.0;
  }
  return 0.0;
}

core::Result<RobustKernel> ParseRobustSpec(std::string_view spec) {
  const std::size_t colon = spec.find(':');
  const std::string_view name = spec.substr(0, colon);
  core::Result<RobustKernel::Kind> kind = RobustKernel::ParseKind(name);
  if (!kind.ok()) return kind.status();
  double parameter = DefaultRobustParameter(*kind);
  if (colon != std::string_view::npos) {
    const std::string_view text = spec.substr(colon + 1);
    if (*kind == RobustKernel::Kind::kNone) {
      return core::InvalidArgument("robust kernel '" + std::string(spec) + "': none takes no parameter");
    }
    const char* end = text.data() + text.size();
    const std::from_chars_result r = std::from_chars(text.data(), end, parameter);
    if (text.empty() || r.ec != std::errc() || r.ptr != end) {
      return core::InvalidArgument("robust kernel '" + std::string(spec) + "': parameter '" +
                                   std::string(text) + "' is not a number");
    }
  }
  return RobustKernel::Create(*kind, parameter);
}

std::string RobustSpecString(const RobustKernel& kernel) {
  if (kernel.is_none()) return "none";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s:%g", RobustKernel::KindName(kernel.kind()), kernel.parameter());
  return buf;
}

}  // namespace slamd::clients
