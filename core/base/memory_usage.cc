#include "core/base/memory_usage.h"

#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace slamd::core {

std::int64_t ResidentBytes() {
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return 0;
  long long size = 0, resident = 0;
  const int read = std::fscanf(f, "%lld %lld", &size, &resident);
  std::fclose(f);
  if (read != 2) return 0;
  return static_cast<std::int64_t>(resident) * ::sysconf(_SC_PAGESIZE);
}

std::int64_t AllocatorBytes() {
#ifdef __GLIBC__
  const struct mallinfo2 info = ::mallinfo2();  // summed over the arenas
  return static_cast<std::int64_t>(info.arena + info.hblkhd);
#else
  return 0;
#endif
}

std::int64_t AllocatorInUseBytes() {
#ifdef __GLIBC__
  const struct mallinfo2 info = ::mallinfo2();
  return static_cast<std::int64_t>(info.uordblks + info.hblkhd);
#else
  return 0;
#endif
}

void KeepFreedMemoryForReuse() {
  ::mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's largest
  ::mallopt(M_TRIM_THRESHOLD, 1 << 30);
}

bool TrimFreedMemoryBeyondUse(std::int64_t slack_bytes) {
#ifdef __GLIBC__
  const std::int64_t in_use = AllocatorInUseBytes();
  if (ResidentBytes() - in_use <= std::max(in_use / 2, slack_bytes)) return false;
  ::malloc_trim(0);
  return true;
#else
  (void)slack_bytes;
  return false;
#endif
}

}  // namespace slamd::core
