#include "core/linear/blas_lock.h"

namespace slamd::core::internal {

std::unique_lock<std::mutex> LockBlas() {
  static std::mutex mutex;
  return std::unique_lock<std::mutex>(mutex);
}

}  // namespace slamd::core::internal
