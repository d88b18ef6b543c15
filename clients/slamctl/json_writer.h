// JsonWriter: builds one flat-or-nested JSON object in insertion order, for `--json` output.
// Numbers are written with 17 significant digits (round-trippable); non-finite numbers as null.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace slamd::clients {

class JsonWriter {
 public:
  JsonWriter& Add(std::string_view key, double value);
  JsonWriter& Add(std::string_view key, long long value);
  JsonWriter& Add(std::string_view key, int value) {
    return Add(key, static_cast<long long>(value));
  }
  JsonWriter& Add(std::string_view key, std::size_t value) {
    return Add(key, static_cast<long long>(value));
  }
  JsonWriter& Add(std::string_view key, bool value);
  JsonWriter& Add(std::string_view key, std::string_view value);
  JsonWriter& Add(std::string_view key, const char* value) {
    return Add(key, std::string_view(value));
  }
  // Adds a nested object written by another JsonWriter.
  JsonWriter& Add(std::string_view key, const JsonWriter& object);
  // Adds an array of objects.
  JsonWriter& Add(std::string_view key, const std::vector<JsonWriter>& objects);

  std::string str() const { return "{" + body_ + "}"; }

 private:
  void Key(std::string_view key);
  std::string body_;
};

// The JSON string literal for `s` (quoted, escaped).
std::string JsonQuote(std::string_view s);

}  // namespace slamd::clients
