#include "clients/slamctl/json_writer.h"

#include <cmath>
#include <cstdio>

namespace slamd::clients {

std::string JsonQuote(std::string_view s) {
  std::string out = "\"";
  for (char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof(buf), "\\u%04x", c);
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

void JsonWriter::Key(std::string_view key) {
  if (!body_.empty()) body_ += ", ";
  body_ += JsonQuote(key) + ": ";
}

JsonWriter& JsonWriter::Add(std::string_view key, double value) {
  Key(key);
  if (!std::isfinite(value)) {
    body_ += "null";
  } else {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.17g", value);
    body_ += buf;
  }
  return *this;
}

JsonWriter& JsonWriter::Add(std::string_view key, long long value) {
  Key(key);
  body_ += std::to_string(value);
  return *this;
}

JsonWriter& JsonWriter::Add(std::string_view key, bool value) {
  Key(key);
  body_ += value ? "true" : "false";
  return *this;
}

JsonWriter& JsonWriter::Add(std::string_view key, std::string_view value) {
  Key(key);
  body_ += JsonQuote(value);
  return *this;
}

JsonWriter& JsonWriter::Add(std::string_view key, const JsonWriter& object) {
  Key(key);
  body_ += object.str();
  return *this;
}

JsonWriter& JsonWriter::Add(std::string_view key, const std::vector<JsonWriter>& objects) {
  Key(key);
  body_ += "[";
  for (size_t k = 0; k < objects.size(); ++k) body_ += (k ? ", " : "") + objects[k].str();
  body_ += "]";
  return *this;
}

}  // namespace slamd::clients
