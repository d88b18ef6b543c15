# Hardens one lcm-gen (1.3.1) C++ header in place: cmake -DHEADER=<file.hpp> -P harden_lcm_decode.cmake
#
# Why: the generated decoder resizes a std::vector to the count read from the wire BEFORE checking
# that the bytes are there, so a corrupt or hostile message with count 2^31-1 makes it allocate
# (and zero) gigabytes, and a negative count throws std::length_error. Every array element takes
# at least one byte on the wire, so a count above the bytes left is malformed: return -1 (the
# decoder's error value) before resizing. Strings: LCM's length includes the NUL, so it is >= 1;
# a length of 0 would make std::string::assign throw.
#
# The script fails the build when the header contains a resize or string length it did not
# rewrite, so a different lcm-gen output format cannot silently drop the hardening.
if(NOT HEADER)
  message(FATAL_ERROR "harden_lcm_decode.cmake: pass -DHEADER=<generated .hpp>")
endif()
file(READ "${HEADER}" text)

string(REGEX REPLACE
  "this->([A-Za-z0-9_]+)\\.resize\\(this->([A-Za-z0-9_]+)\\);"
  "if (this->\\2 < 0 || this->\\2 > maxlen - pos) return -1; /* slamd: hardened */ this->\\1.resize(this->\\2);"
  text "${text}")
string(REGEX REPLACE
  "if\\((__[A-Za-z0-9_]+_len__) > maxlen - pos\\) return -1;"
  "if(\\1 < 1 || \\1 > maxlen - pos) return -1; /* slamd: hardened */"
  text "${text}")

# Every resize and every string length check must now carry the marker (counted, since the
# lines hold semicolons, which CMake lists cannot).
string(REGEX MATCHALL "\\.resize\\(" resizes "${text}")
string(REGEX MATCHALL "_len__ > maxlen - pos" lengths "${text}")
string(REGEX MATCHALL "slamd: hardened" markers "${text}")
list(LENGTH resizes num_resizes)
list(LENGTH lengths num_lengths)
list(LENGTH markers num_markers)
math(EXPR expected "${num_resizes} + ${num_lengths}")
if(NOT num_markers EQUAL expected)
  message(FATAL_ERROR "harden_lcm_decode.cmake: unrecognised lcm-gen output in ${HEADER}: "
          "${num_resizes} resizes and ${num_lengths} string lengths, ${num_markers} hardened")
endif()
file(WRITE "${HEADER}" "${text}")
