// Text output shared by the writers of `slamctl sim`'s worlds (sim_world_io.cc,
// sim_camera_world_io.cc): fields appended to a line and whole files written at once.
#pragma once

#include <charconv>
#include <fstream>
#include <string>

#include "core/base/status.h"

namespace slamd::clients::sim {

// Appends " <x>" in the shortest form that reads back to the same double.
inline void Append(std::string* out, double x) {
  char buf[32];
  const auto result = std::to_chars(buf, buf + sizeof(buf), x);
  out->push_back(' ');
  out->append(buf, result.ptr);
}
inline void Append(std::string* out, const std::string& word) {
  out->push_back(' ');
  out->append(word);
}
// x in the same form, alone.
inline std::string Num(double x) {
  std::string s;
  Append(&s, x);
  return s.substr(1);
}

// Replaces the file's contents with `text`; kIoError naming the path on failure.
inline core::Status WriteText(const std::string& path, const std::string& text) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) return core::IoError("cannot open '" + path + "' for writing");
  file.write(text.data(), static_cast<std::streamsize>(text.size()));
  file.close();
  if (!file) return core::IoError("writing '" + path + "' failed");
  return core::Status::Ok();
}

}  // namespace slamd::clients::sim
