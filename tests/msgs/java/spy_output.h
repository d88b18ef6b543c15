// The Java side of the spy decode test's comparison (spy_decode_netns_test.cc): what SpyDecode
// (LCM's Java decoder) printed, read back into the same flattened fields as lcm_fields.h's.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "tests/msgs/java/lcm_fields.h"

namespace slamd::spy_test {

inline std::string Unescape(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '\\' && i + 1 < s.size()) {
      const char c = s[++i];
      out += c == 't' ? '\t' : c == 'n' ? '\n' : c;
    } else {
      out += s[i];
    }
  }
  return out;
}

struct SpyOutput {
  bool ready = false;
  std::map<std::string, std::int64_t> types;  // LCM types found on the class path
  std::vector<Decoded> messages;
  std::vector<std::string> other_lines;
};

// Only messages on channels that start with `prefix` (not liblcm's LCM_SELF_TEST, say).
inline SpyOutput ReadSpyOutput(const std::string& path, const std::string& prefix = "") {
  SpyOutput out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> parts;
    for (size_t start = 0;;) {
      const size_t tab = line.find('\t', start);
      parts.push_back(line.substr(start, tab - start));
      if (tab == std::string::npos) break;
      start = tab + 1;
    }
    if (line == "ready") {
      out.ready = true;
    } else if (parts.size() == 3 && parts[0] == "lcmtype") {
      out.types[parts[1]] = std::strtoll(parts[2].c_str(), nullptr, 10);
    } else if (parts.size() >= 2 && parts[0].starts_with("@channel=") &&
               parts[1].starts_with("@type=")) {
      Decoded d{Unescape(parts[0].substr(9)), parts[1].substr(6), {}};
      if (!d.channel.starts_with(prefix)) continue;
      for (size_t i = 2; i < parts.size(); ++i) {
        const size_t eq = parts[i].find('=');
        d.fields[parts[i].substr(0, eq)] =
            eq == std::string::npos ? "" : Unescape(parts[i].substr(eq + 1));
      }
      out.messages.push_back(std::move(d));
    } else {
      out.other_lines.push_back(line);
    }
  }
  return out;
}

// Same value: equal text, or both numbers that read back to the same double (Java's
// Double.toString and C++'s %.17g print the same double differently).
inline bool SameValue(const std::string& a, const std::string& b) {
  if (a == b) return true;
  if (a.empty() || b.empty()) return false;
  char* end_a = nullptr;
  char* end_b = nullptr;
  const double x = std::strtod(a.c_str(), &end_a);
  const double y = std::strtod(b.c_str(), &end_b);
  return *end_a == '\0' && *end_b == '\0' && x == y;
}

inline double Num(const Fields& f, const std::string& key) {
  const auto it = f.find(key);
  if (it == f.end()) {
    ADD_FAILURE() << "no field " << key;
    return std::nan("");
  }
  return std::strtod(it->second.c_str(), nullptr);
}

inline std::string Str(const Fields& f, const std::string& key) {
  const auto it = f.find(key);
  return it == f.end() ? "<missing " + key + ">" : it->second;
}

// The last message SpyDecode printed on `channel` for which `pred` holds (nullptr if none).
inline const Fields* LastOn(const SpyOutput& spy, const std::string& channel,
                            const std::function<bool(const Fields&)>& pred = nullptr) {
  const Fields* found = nullptr;
  for (const Decoded& d : spy.messages) {
    if (d.channel == channel && (!pred || pred(d.fields))) found = &d.fields;
  }
  return found;
}

}  // namespace slamd::spy_test
