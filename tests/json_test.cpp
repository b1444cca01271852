#include "polyrad/util/json.h"

#include <gtest/gtest.h>

#include <cmath>

namespace polyrad {
namespace {

TEST(Json, ParsesValuesWithPositions) {
  JsonValue v =
      parse_json("{\n  \"a\": [1, -2.5e3, true, null],\n  \"b\": \"x\\u00e9\"\n}", "f.json");
  ASSERT_TRUE(v.is(JsonValue::Kind::kObject));
  const JsonValue* a = v.find("a");
  ASSERT_NE(a, nullptr);
  EXPECT_EQ(a->where.line, 2);
  EXPECT_EQ(a->where.column, 8);
  EXPECT_EQ(a->array[1].number, -2500.0);
  EXPECT_TRUE(a->array[2].boolean);
  EXPECT_TRUE(a->array[3].is(JsonValue::Kind::kNull));
  EXPECT_EQ(v.find("b")->string, "x\xc3\xa9");
}

void expect_error_at(const std::string& text, int line, int column, const std::string& words) {
  try {
    parse_json(text, "bad.json");
    FAIL() << "no error for " << text;
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().file, "bad.json");
    EXPECT_EQ(e.where().line, line) << e.what();
    EXPECT_EQ(e.where().column, column) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(Json, SyntaxErrorsNameLineAndColumn) {
  expect_error_at("{\"a\": 1,}", 1, 9, "quoted key");
  expect_error_at("{\n\"a\" 1}", 2, 5, "':'");
  expect_error_at("[1, 2", 1, 6, "end of file");
  expect_error_at("{\"a\": 01}", 1, 8, "expected ','");
  expect_error_at("{\"a\": \"x}", 1, 10, "unterminated");
  expect_error_at("{\"a\": 1} x", 1, 10, "after the JSON");
  expect_error_at("{\"a\": 1, \"a\": 2}", 1, 10, "duplicate key");
  expect_error_at("[1e999]", 1, 2, "out of range");
  expect_error_at("[tru]", 1, 2, "literal");
  expect_error_at(std::string(300, '[') + std::string(300, ']'), 1, 258, "nesting");
}

TEST(Json, ObjectReaderRejectsUnknownKeys) {
  JsonValue v = parse_json("{\"size\": 2, \"colour\": 3}", "f.json");
  ObjectReader r(v, "thing");
  EXPECT_EQ(r.number("size"), 2.0);
  try {
    r.finish();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'colour'"), std::string::npos);
    EXPECT_EQ(e.where().column, 23);
  }
}

TEST(Json, WriterRoundTrips) {
  JsonWriter w;
  w.begin_object().value("pi", 3.141592653589793).value("name", "a\"b").begin_array("xs");
  w.element(1.0).element(0.1);
  w.end_array().value("nan", std::nan("")).end_object();
  JsonValue v = parse_json(w.str(), "out.json");
  EXPECT_EQ(v.find("pi")->number, 3.141592653589793);
  EXPECT_EQ(v.find("name")->string, "a\"b");
  EXPECT_EQ(v.find("xs")->array[1].number, 0.1);
  EXPECT_TRUE(v.find("nan")->is(JsonValue::Kind::kNull));
}

}  // namespace
}  // namespace polyrad
