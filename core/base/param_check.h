// SLAMD_PARAM_CHECK: one line per field in the Validate() of a params struct. Returns
// InvalidArgument naming the struct, field, value and constraint, e.g.
//   "BatchParams::max_iterations = 0; violates >= 1"   (Ceres' OPTION_GE in spirit).
#pragma once

#include <string>

#include "core/base/status.h"

#define SLAMD_PARAM_CHECK(Struct, field, op, bound)                                       \
  do {                                                                                    \
    if (!(field op bound)) {                                                              \
      return ::slamd::core::InvalidArgument(std::string(#Struct "::" #field " = ") +      \
                                            std::to_string(field) + "; violates " #op " " \
                                            #bound);                                      \
    }                                                                                     \
  } while (false)
