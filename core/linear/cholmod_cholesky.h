// Factory of the CHOLMOD backend of SparseCholesky (internal: use SparseCholesky::Create).
// This header deliberately does not include cholmod.h; only cholmod_cholesky.cc does.
#pragma once

#include <memory>

#include "core/linear/sparse_cholesky.h"

namespace slamd::core::internal {

std::unique_ptr<SparseCholesky> CreateCholmodCholesky(const SparseCholesky::Options& options);

}  // namespace slamd::core::internal
