// Test helpers for files:
//  * ReadFileBytes(path): the whole file as bytes ("" when it cannot be read).
//  * WriteFileBytes(path, bytes): replaces the file's contents with `bytes`.
//  * TempDir dir("slamd_sim_"): a fresh directory in the test temp directory (the prefix, by
//    default "slamd_", then unique per process and object), removed with everything in it at the
//    end of the scope; dir.path(), dir.File("a.g2o") for a path inside it.
//    TempDir("slamd_x_", false) only names the directory, for a command under test to create.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <system_error>

namespace slamd::testing {

inline std::string ReadFileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

inline void WriteFileBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

class TempDir {
 public:
  explicit TempDir(const std::string& prefix = "slamd_", bool create = true) {
    static std::atomic<int> counter{0};
    path_ = ::testing::TempDir() + prefix + std::to_string(::getpid()) + "_" +
            std::to_string(counter++);
    if (create) std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::string& path() const { return path_; }
  std::string File(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

}  // namespace slamd::testing
