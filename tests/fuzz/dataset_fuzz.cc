// Fuzz target: the dataset readers (core/io/dataset.h ReadDataset) for g2o, TORO and iSAM text.
// ReadDataset takes a path, so the input is written to a scratch file first.
//
// Input: byte 0 selects the format (bits 0-1: auto, g2o, TORO, iSAM), the file name (bit 2:
// "*.graph", which makes EDGE2 mean TORO under auto detection), the iSAM noise convention
// (bit 3: covariance) and compose_initial_from_odometry (bit 4); the rest is the file text.
// Property: ReadDataset never crashes and reports any problem with the content as a Status
// (dataset.h: "no exception, no abort, whatever the input").
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "core/io/dataset.h"
#include "tests/fuzz/fuzz_util.h"

namespace slamd::fuzz {

void FuzzDataset(const std::uint8_t* data, std::size_t size) {
  using slamd::core::DatasetFormat;
  using slamd::core::ReadOptions;
  if (size < 1) return;
  const std::uint8_t selector = data[0];
  constexpr DatasetFormat kFormats[] = {DatasetFormat::kAuto, DatasetFormat::kG2o,
                                        DatasetFormat::kToro, DatasetFormat::kIsam};
  ReadOptions options;
  options.format = kFormats[selector & 3];
  options.isam_noise = (selector & 8) != 0 ? ReadOptions::IsamNoise::kCovariance
                                           : ReadOptions::IsamNoise::kSqrtInformation;
  options.compose_initial_from_odometry = (selector & 16) != 0;
  static const std::string kTxt = slamd::fuzz::ScratchPath("dataset", ".txt");
  static const std::string kGraph = slamd::fuzz::ScratchPath("dataset", ".graph");
  const std::string& path = (selector & 4) != 0 ? kGraph : kTxt;
  slamd::fuzz::WriteFileOrDie(path,
                              std::string_view(reinterpret_cast<const char*>(data) + 1, size - 1));
  (void)slamd::core::ReadDataset(path, options);
}

}  // namespace slamd::fuzz

SLAMD_FUZZ_ENTRY_POINT(slamd::fuzz::FuzzDataset)
