// Key: the name of one variable in the factor graph.
//
// A Key packs three parts into 64 bits so it fits LCM int64 and protobuf uint64 fields as-is:
//   bits 63..56  robot   (0 = no robot namespace; otherwise a robot id, printed as a letter when
//                         it is one, e.g. 'a', so several robots can share one graph)
//   bits 55..48  symbol  (the variable's kind by convention: 'x' poses, 'l' landmarks, ...)
//   bits 47..0   index   (0 .. 2^48-1)
// Printed as "x12" without a robot and "a:x12" with robot 'a' (robot ids that are not printable
// letters or digits print as "r200:x12").
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

namespace slamd::core {

using Key = std::uint64_t;
using KeyVector = std::vector<Key>;

// A copy of a list of keys (a factor's keys are a span): for records and comparisons.
inline KeyVector ToKeyVector(std::span<const Key> keys) { return {keys.begin(), keys.end()}; }

inline constexpr std::uint64_t kMaxKeyIndex = (std::uint64_t{1} << 48) - 1;

// Builds a key; `index` must be <= kMaxKeyIndex (checked: a larger index aborts, since it is a
// programming error to build one; input from the wire is validated before it gets here).
Key MakeKey(unsigned char symbol, std::uint64_t index, unsigned char robot = 0);

constexpr unsigned char KeySymbol(Key key) { return static_cast<unsigned char>((key >> 48) & 0xff); }
constexpr unsigned char KeyRobot(Key key) { return static_cast<unsigned char>(key >> 56); }
constexpr std::uint64_t KeyIndex(Key key) { return key & kMaxKeyIndex; }

// "x12", "a:x12".
std::string KeyToString(Key key);

}  // namespace slamd::core
