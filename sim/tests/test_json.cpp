#include <gtest/gtest.h>

#include "json.hpp"

namespace cart2d {
namespace {

TEST(Json, ParsesAControlMessage) {
  json::Value v;
  std::string err;
  ASSERT_TRUE(json::parse(R"({"type":"obstacles","id":7,"step":0.2,"cells":[[1,2],[3,4]],"x":-1.5e-3,"ok":true,"n":null})", &v, &err)) << err;
  ASSERT_TRUE(v.is_object());
  EXPECT_EQ(v.find("type")->string, "obstacles");
  EXPECT_EQ(v.find("id")->number, 7);
  EXPECT_EQ(v.find("cells")->array[1].array[0].number, 3);
  EXPECT_DOUBLE_EQ(v.find("x")->number, -1.5e-3);
  EXPECT_TRUE(v.find("ok")->boolean);
  EXPECT_TRUE(v.find("n")->is_null());
  EXPECT_EQ(v.find("missing"), nullptr);
}

TEST(Json, StringEscapesRoundTrip) {
  json::Value v;
  std::string err;
  ASSERT_TRUE(json::parse(R"("a\"b\\c\n\u00e9\ud83d\ude00")", &v, &err)) << err;
  EXPECT_EQ(v.string, "a\"b\\c\n\xc3\xa9\xf0\x9f\x98\x80");
  EXPECT_EQ(json::quote("a\"b\\c\n"), R"("a\"b\\c\n")");
}

TEST(Json, RejectsBadInput) {
  json::Value v;
  std::string err;
  for (const char* bad : {"", "{", "{\"a\":}", "[1,]", "{\"a\":1} x", "nul", "\"abc", "1e999", "{\"a\" 1}"}) {
    EXPECT_FALSE(json::parse(bad, &v, &err)) << bad;
    EXPECT_FALSE(err.empty());
  }
  std::string deep(100, '[');
  EXPECT_FALSE(json::parse(deep, &v, &err));
}

TEST(Json, WritesObjects) {
  const std::string s = json::Object()
                            .add("type", "ack")
                            .add("ok", true)
                            .add("n", 3)
                            .add("x", 0.5)
                            .add("nan", 0.0 / 0.0)
                            .add_raw("o", "{\"a\":1}")
                            .str();
  EXPECT_EQ(s, R"({"type":"ack","ok":true,"n":3,"x":0.5,"nan":null,"o":{"a":1}})");
  json::Value v;
  std::string err;
  ASSERT_TRUE(json::parse(s, &v, &err));
  EXPECT_EQ(json::dump(v), s);
}

}  // namespace
}  // namespace cart2d
