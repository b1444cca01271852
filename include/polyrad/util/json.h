// A small JSON reader that remembers where every value sits in its file, and a writer.
//
// Scene files are read through it so that an error can name file:line:column, and so that every
// key has to be consumed by the parser: ObjectReader::finish() rejects keys nobody asked for.
// Cost: one pass over the text; the tree holds every value once.
//
//   JsonValue root = parse_json(text, "scene.json");
//   ObjectReader r(root, "scene");
//   double s = r.number("patch_size");
//   r.finish();  // throws InputError naming any unknown key
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "polyrad/util/error.h"

namespace polyrad {

class JsonValue {
 public:
  enum class Kind { kNull, kBool, kNumber, kString, kArray, kObject };
  using Member = std::pair<std::string, JsonValue>;

  // Declared so that clang with libstdc++ need not define the implicit constructor while
  // std::pair<std::string, JsonValue> is still incomplete (it rejects the header otherwise).
  JsonValue() = default;

  Kind kind = Kind::kNull;
  bool boolean = false;
  double number = 0.0;
  std::string string;
  std::vector<JsonValue> array;
  std::vector<Member> object;  // in file order; keys are unique
  SourceLocation where;        // position of the value's first character

  bool is(Kind k) const { return kind == k; }
  const JsonValue* find(std::string_view key) const;
  static const char* kind_name(Kind k);
};

// Parses a whole document. Throws InputError at the first syntax error, at duplicate keys,
// and at numbers that are not finite doubles.
JsonValue parse_json(std::string_view text, const std::string& file_name);

// Reads the members of one object, checking kinds; finish() reports keys never read.
class ObjectReader {
 public:
  ObjectReader(const JsonValue& value, std::string what);
  bool has(std::string_view key) const { return value_.find(key) != nullptr; }
  const JsonValue& get(std::string_view key);  // required, any kind
  const JsonValue* optional(std::string_view key);
  double number(std::string_view key);
  std::optional<double> optional_number(std::string_view key);
  std::string string(std::string_view key);
  bool boolean(std::string_view key);
  // A whole number in [lo, hi].
  long long integer(std::string_view key, double lo, double hi);
  // A number, or null read as +infinity (the writer's form of a non-finite bound).
  double number_or_infinity(std::string_view key);
  const JsonValue& array(std::string_view key);
  const JsonValue& object(std::string_view key);
  void finish() const;
  const SourceLocation& where() const { return value_.where; }

 private:
  const JsonValue& expect(const JsonValue& v, JsonValue::Kind kind, std::string_view key) const;
  const JsonValue& value_;
  std::string what_;
  std::vector<std::string> used_;
};

// Number helpers that throw InputError at the value's location.
double json_number(const JsonValue& v, std::string_view what);
std::vector<double> json_numbers(const JsonValue& v, std::string_view what, size_t count);

// Streaming writer for reports: nested objects and arrays, numbers written so they read back
// exactly, non-finite numbers as null.
class JsonWriter {
 public:
  JsonWriter& begin_object(std::string_view key = {});
  JsonWriter& end_object();
  JsonWriter& begin_array(std::string_view key = {});
  JsonWriter& end_array();
  JsonWriter& value(std::string_view key, double v);
  JsonWriter& value(std::string_view key, long long v);
  JsonWriter& value(std::string_view key, int v) { return value(key, static_cast<long long>(v)); }
  JsonWriter& value(std::string_view key, size_t v) {
    return value(key, static_cast<long long>(v));
  }
  JsonWriter& value(std::string_view key, bool v);
  JsonWriter& value(std::string_view key, std::string_view v);
  JsonWriter& value(std::string_view key, const char* v) { return value(key, std::string_view(v)); }
  JsonWriter& element(double v) { return value({}, v); }
  JsonWriter& element(std::string_view v) { return value({}, v); }
  const std::string& str() const { return out_; }

 private:
  void key(std::string_view k);
  void newline();
  std::string out_;
  std::vector<bool> first_;  // per open container: nothing written yet
};

std::string json_escape(std::string_view s);

}  // namespace polyrad
