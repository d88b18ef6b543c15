// The registry of factor types: every factor type slamd can store, export and read back, by its
// type name. The list is written once, in factor_registry.cc; what each type stores is declared
// in its own files (Factor::EncodeMeasured, a static Decode, Factor::Formats).
//
// A FactorRecord (factor_record.h) is a factor as plain data; EncodeFactor and DecodeFactor are
// exact inverses (the noise model's R may be re-factored to the same information).
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

#include "core/factors/factor.h"

namespace slamd::core {

// The factor as data: type name, keys, measurement, noise, kernel and carried values.
FactorRecord EncodeFactor(const Factor& factor);

// Rebuilds a factor. NotFound for a type name not in the registry; InvalidArgument naming the
// type and what is wrong for a wrong key count, measurement size or noise model, or invalid
// values.
Result<FactorPtr> DecodeFactor(const FactorRecord& record);

// The same factor with another robust kernel (an encode/decode round trip).
Result<FactorPtr> WithRobustKernel(const Factor& factor, const RobustKernel& kernel);

// Whether two factors are the same measurement: the same type, keys and robust kernel, and
// measured values and square-root information equal to `tolerance` relative to their size (a
// re-sent message; a snapshot may have re-factored R to the same information).
bool SameMeasurement(const Factor& a, const Factor& b, double tolerance = 1e-9);

// A 64-bit digest of the measurement, for remembering one without keeping its factor (the
// reduced pose graph's merged measurements): the type, keys and robust kernel, and the measured
// values, square-root information and carried values each rounded to 2^-30 of their largest
// entry (at least 1), so that factors SameMeasurement calls equal have the same digest but for
// a value within round-off of a rounding boundary (about 1e-6 odds per entry).
std::uint64_t MeasurementDigest(const Factor& factor);

// The registered type names, in list order.
std::vector<std::string_view> FactorTypeNames();

}  // namespace slamd::core
