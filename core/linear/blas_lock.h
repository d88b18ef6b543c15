// LockBlas: one BLAS call at a time in this process. Debian's serial OpenBLAS (libopenblas0-serial,
// the libblas.so.3 of scripts/packages.txt) is not safe for concurrent calls: with two threads each
// calling dsyrk on its own matrices, about 1 call in 2,500 returned wrong numbers (its work
// buffers are shared, without a lock in that build). slamd calls the BLAS from the solver's
// elimination threads (wide clique updates, partial_cholesky.cc) and, through CHOLMOD's supernodal
// factorisation and solves (cholmod_cholesky.cc), from whichever thread runs a batch solve; every
// such call holds this lock. Kept for the duration of one BLAS (or CHOLMOD) call only.
#pragma once

#include <mutex>

namespace slamd::core::internal {

[[nodiscard]] std::unique_lock<std::mutex> LockBlas();

}  // namespace slamd::core::internal
