// Helpers shared by the libFuzzer targets: the readers under test take file paths, so the fuzz
// input is written to a per-process scratch file (in /dev/shm when it exists: no disk I/O per
// execution). Not thread-safe (libFuzzer runs one input at a time per process).
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

namespace slamd::fuzz {

// Directory for scratch files: /dev/shm if writable, else $TMPDIR or /tmp.
inline std::string ScratchDir() {
  if (access("/dev/shm", W_OK) == 0) return "/dev/shm";
  const char* tmp = std::getenv("TMPDIR");
  return tmp != nullptr ? tmp : "/tmp";
}

// A scratch path unique to this process and `tag`; `suffix` matters where the reader looks at
// the file name (dataset format detection: "*.graph").
inline std::string ScratchPath(std::string_view tag, std::string_view suffix) {
  return ScratchDir() + "/slamd_fuzz_" + std::to_string(getpid()) + "_" + std::string(tag) +
         std::string(suffix);
}

// Replaces the file at `path` with `bytes`; aborts if it cannot (a broken harness, not a finding).
inline void WriteFileOrDie(const std::string& path, std::string_view bytes) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr || std::fwrite(bytes.data(), 1, bytes.size(), f) != bytes.size() ||
      std::fclose(f) != 0) {
    std::fprintf(stderr, "fuzz harness: cannot write %s\n", path.c_str());
    std::abort();
  }
}

// A failed property of the code under test: print and abort, so libFuzzer saves the input.
[[noreturn]] inline void Fail(const std::string& what) {
  std::fprintf(stderr, "FUZZ PROPERTY VIOLATED: %s\n", what.c_str());
  std::abort();
}

// The fuzz targets, one per *_fuzz.cc: run one input; abort (via a sanitizer, a SLAMD_CHECK or
// Fail) on a finding. regressions_test.cc runs the saved crash inputs through the same functions.
void FuzzConfig(const std::uint8_t* data, std::size_t size);
void FuzzDataset(const std::uint8_t* data, std::size_t size);
void FuzzInbound(const std::uint8_t* data, std::size_t size);
void FuzzJournal(const std::uint8_t* data, std::size_t size);
void FuzzState(const std::uint8_t* data, std::size_t size);

}  // namespace slamd::fuzz

// Defines libFuzzer's entry point as a call of `function`; nothing in the regression test build
// (SLAMD_FUZZ_REGRESSION), which links every target into one GoogleTest executable.
#ifdef SLAMD_FUZZ_REGRESSION
#define SLAMD_FUZZ_ENTRY_POINT(function)
#else
#define SLAMD_FUZZ_ENTRY_POINT(function)                                              \
  extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) { \
    function(data, size);                                                             \
    return 0;                                                                         \
  }
#endif
