// Test helper: MustReadDataset(path, options) reads a dataset with core::ReadDataset and fails the
// test (EXPECT) when that fails, returning an empty dataset then.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "core/io/dataset.h"

namespace slamd::testing {

inline core::Dataset MustReadDataset(const std::string& path,
                                     const core::ReadOptions& options = {}) {
  core::Result<core::Dataset> d = core::ReadDataset(path, options);
  EXPECT_TRUE(d.ok()) << d.status().ToString();
  return d.ok() ? std::move(d).value() : core::Dataset{};
}

}  // namespace slamd::testing
