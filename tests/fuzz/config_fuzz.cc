// Fuzz target: the server config parser (server/config/config_loader.h ParseConfigText), the
// protobuf text format converted into ServerParams and validated. Property: it never crashes
// or throws ("never throws" is its contract); any problem is an InvalidArgument.
#include <cstddef>
#include <cstdint>
#include <string>

#include "server/config/config_loader.h"
#include "tests/fuzz/fuzz_util.h"

namespace slamd::fuzz {

void FuzzConfig(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  (void)server::ParseConfigText(text, "fuzz.textproto");
}

}  // namespace slamd::fuzz

SLAMD_FUZZ_ENTRY_POINT(slamd::fuzz::FuzzConfig)
