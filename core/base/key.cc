#include "core/base/key.h"

#include <cctype>
#include <cstdio>

#include "core/base/check.h"

namespace slamd::core {

Key MakeKey(unsigned char symbol, std::uint64_t index, unsigned char robot) {
  SLAMD_CHECK(index <= kMaxKeyIndex) << "key index " << index << " exceeds 2^48-1";
  return (static_cast<Key>(robot) << 56) | (static_cast<Key>(symbol) << 48) | index;
}

std::string KeyToString(Key key) {
  // snprintf rather than string concatenation: short and free of GCC 12's -Wrestrict false alarm.
  char robot[8] = "";
  const unsigned char r = KeyRobot(key);
  if (r != 0 && std::isalnum(r)) {
    std::snprintf(robot, sizeof(robot), "%c:", r);
  } else if (r != 0) {
    std::snprintf(robot, sizeof(robot), "r%u:", static_cast<unsigned>(r));
  }
  char symbol[8];
  const unsigned char c = KeySymbol(key);
  if (std::isgraph(c)) {
    std::snprintf(symbol, sizeof(symbol), "%c", c);
  } else {
    std::snprintf(symbol, sizeof(symbol), "s%u_", static_cast<unsigned>(c));
  }
  char out[48];
  std::snprintf(out, sizeof(out), "%s%s%llu", robot, symbol,
                static_cast<unsigned long long>(KeyIndex(key)));
  return out;
}

}  // namespace slamd::core
