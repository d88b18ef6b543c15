// Test helpers to locate dataset files.
//  * SharedDatasetPath("manhattan.g2o"): a file of the development datasets in ../shared/datasets
//    (the CMake cache variable SLAMD_SHARED_DATASETS). Tests that need one start with
//    SLAMD_SKIP_IF_NO_SHARED_DATASET(path), which skips them with a message when it is absent,
//    since the datasets live outside the repository.
//  * TestDataPath("small.g2o"): a small file committed under tests/data.
//  * WriteTempFile("bad.g2o", text): writes `text` to a fresh file in the test temp directory
//    (prefixed to be unique per process and call; the extension is kept) and returns its path.
//    The files are removed when the test binary exits. Not thread-safe.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace slamd::testing {

inline std::string SharedDatasetPath(const std::string& name) {
  return std::string(SLAMD_SHARED_DATASETS) + "/" + name;
}

inline std::string TestDataPath(const std::string& name) {
  return std::string(SLAMD_TEST_DATA "/") + name;
}

inline std::string WriteTempFile(const std::string& name, const std::string& text) {
  // Removes the files when the test binary exits.
  struct Cleanup {
    std::vector<std::string> paths;
    ~Cleanup() {
      std::error_code ec;
      for (const std::string& p : paths) std::filesystem::remove(p, ec);
    }
  };
  static Cleanup cleanup;
  static std::atomic<int> counter{0};
  const std::string path = ::testing::TempDir() + "slamd_" + std::to_string(::getpid()) + "_" +
                           std::to_string(counter++) + "_" + name;
  std::ofstream(path, std::ios::binary) << text;
  cleanup.paths.push_back(path);
  return path;
}

}  // namespace slamd::testing

// GTEST_SKIP()s the current test when `path` does not exist.
#define SLAMD_SKIP_IF_NO_SHARED_DATASET(path)                                                    \
  do {                                                                                           \
    const std::string slamd_dataset_path_ = (path);                                              \
    if (!std::filesystem::exists(slamd_dataset_path_)) {                                         \
      GTEST_SKIP() << "../shared/datasets not found at " << slamd_dataset_path_ << ": skipping"; \
    }                                                                                            \
  } while (false)
