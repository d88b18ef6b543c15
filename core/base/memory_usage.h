// The process's memory use, as the kernel counts it (Linux /proc): what status_t reports and
// what the lifelong benchmarks watch.
#pragma once

#include <cstdint>

namespace slamd::core {

// Resident set size now [bytes] (/proc/self/statm); 0 if it cannot be read.
std::int64_t ResidentBytes();

// What the allocator holds from the kernel [bytes]: glibc's arenas and the blocks it mapped one
// by one (0 without glibc). After KeepFreedMemoryForReuse no arena shrinks until a malloc_trim
// (Isam2::TrimMemory), so until then this is the heap's high-water mark: unlike the peak RSS,
// it does not move with the pages of code a run happens to touch (the kernel maps pages around
// each fault on a file, so a rebuild alone moved slamctl's peak RSS by ~0.3 MB).
std::int64_t AllocatorBytes();

// What the allocator has handed out and not had back [bytes] (glibc's arenas and the blocks it
// mapped one by one; 0 without glibc): the live heap. The resident set less this is code,
// stacks, and freed memory kept for reuse (KeepFreedMemoryForReuse).
std::int64_t AllocatorInUseBytes();

// Keeps freed memory in the process for reuse instead of giving it back to the kernel at once
// (glibc: blocks up to 32 MiB from the heap, not mapped one by one; the heap's free top kept up
// to 1 GiB). Re-eliminating the top of a Bayes tree with large cliques (cameras sharing long
// point tracks) frees and allocates megabytes per update, and the kernel's page faults on the
// fresh pages took a quarter of a visual stream's time. Memory goes back when the solver trims
// itself at rest (Isam2::TrimMemory: malloc_trim). For executables, once at start-up.
void KeepFreedMemoryForReuse();

// For a process that never rests (a lifelong stream leaves Isam2::TrimMemory no idle time):
// gives freed memory back to the kernel (malloc_trim) when the resident set exceeds what the
// allocator has in use by more than half of that and `slack_bytes`, so that what
// KeepFreedMemoryForReuse keeps stays in proportion to the live heap. Returns whether it
// trimmed. Takes the allocator's locks: for a thread off the hot path.
bool TrimFreedMemoryBeyondUse(std::int64_t slack_bytes = std::int64_t{64} << 20);

}  // namespace slamd::core
