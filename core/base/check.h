// SLAMD_CHECK: for bugs and broken invariants only (never for bad input, which gets a Status).
// On failure it prints file, line, the condition and the streamed message to stderr and aborts.
//   SLAMD_CHECK(i < n) << "index " << i << " out of range " << n;
// SLAMD_DCHECK is the same in debug builds and compiles to nothing under NDEBUG (inner loops).
#pragma once

#include <sstream>

namespace slamd::core::internal {

class CheckFailure {
 public:
  CheckFailure(const char* file, int line, const char* condition);
  [[noreturn]] ~CheckFailure();
  std::ostream& stream() { return stream_; }

 private:
  std::ostringstream stream_;
};

// Swallows the stream expression when the check passes (the `&` binds looser than `<<`).
struct CheckVoidify {
  void operator&(std::ostream&) {}
};

}  // namespace slamd::core::internal

#define SLAMD_CHECK(condition)                      \
  (condition) ? (void)0                             \
              : ::slamd::core::internal::CheckVoidify() & \
                    ::slamd::core::internal::CheckFailure(__FILE__, __LINE__, #condition).stream()

#ifdef NDEBUG
// Compiled (so it stays valid code) but never evaluated.
#define SLAMD_DCHECK(condition) \
  while (false) SLAMD_CHECK(condition)
#else
#define SLAMD_DCHECK(condition) SLAMD_CHECK(condition)
#endif
