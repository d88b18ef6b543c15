#include "clients/slamctl/json_writer.h"

#include <gtest/gtest.h>

#include <cmath>

namespace slamd::clients {
namespace {

TEST(JsonWriterTest, WritesTypedFieldsInOrder) {
  JsonWriter inner;
  inner.Add("p50", 0.5);
  JsonWriter w;
  w.Add("name", "a\"b\\c\n")
      .Add("n", 3)
      .Add("ok", true)
      .Add("x", 0.1)
      .Add("nan", std::nan(""))
      .Add("inner", inner);
  EXPECT_EQ(w.str(),
            "{\"name\": \"a\\\"b\\\\c\\n\", \"n\": 3, \"ok\": true, \"x\": 0.10000000000000001, "
            "\"nan\": null, \"inner\": {\"p50\": 0.5}}");
}

TEST(JsonWriterTest, WritesArraysOfObjects) {
  JsonWriter a, b;
  a.Add("cost", 2.0);
  b.Add("cost", 1.0);
  JsonWriter w;
  w.Add("empty", std::vector<JsonWriter>{}).Add("iterations", std::vector<JsonWriter>{a, b});
  EXPECT_EQ(w.str(), "{\"empty\": [], \"iterations\": [{\"cost\": 2}, {\"cost\": 1}]}");
}

TEST(JsonWriterTest, QuotesControlCharacters) { EXPECT_EQ(JsonQuote("\x01"), "\"\\u0001\""); }

}  // namespace
}  // namespace slamd::clients
