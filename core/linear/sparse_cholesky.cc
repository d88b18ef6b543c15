#include "core/linear/sparse_cholesky.h"

#include <cmath>
#include <string>

#include "core/linear/cholmod_cholesky.h"

namespace slamd::core {

const char* LinearSolverTerminationName(LinearSolverTermination termination) {
  switch (termination) {
    case LinearSolverTermination::kSuccess: return "Success";
    case LinearSolverTermination::kNumericalFailure: return "NumericalFailure";
    case LinearSolverTermination::kFatal: return "Fatal";
  }
  return "Unknown";
}

Status SparseCholesky::Options::Validate() const {
  if (!std::isfinite(supernodal_switch) || supernodal_switch < 0.0) {
    return InvalidArgument("SparseCholesky::Options::supernodal_switch = " +
                           std::to_string(supernodal_switch) + "; violates finite and >= 0");
  }
  return Status::Ok();
}

std::unique_ptr<SparseCholesky> SparseCholesky::Create(const Options& options) {
  const Status status = options.Validate();
  SLAMD_CHECK(status.ok()) << status.ToString();
  return internal::CreateCholmodCholesky(options);
}

SparseCholesky::~SparseCholesky() = default;

}  // namespace slamd::core
