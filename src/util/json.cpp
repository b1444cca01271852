// JSON text -> JsonValue tree with positions (RFC 8259, no extensions).
#include "polyrad/util/json.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <unordered_set>

namespace polyrad {

namespace {

constexpr int kMaxDepth = 256;  // deeper nesting is refused rather than overflowing the stack

class Parser {
 public:
  Parser(std::string_view text, const std::string& file) : text_(text), file_(file) {}

  JsonValue parse_document() {
    skip_space();
    JsonValue v = parse_value(0);
    skip_space();
    if (pos_ != text_.size()) fail("unexpected text after the JSON value");
    return v;
  }

 private:
  [[noreturn]] void fail(const std::string& message) const {
    throw InputError(
        here(), at_end() ? "JSON: unexpected end of file (" + message + ")" : "JSON: " + message);
  }

  SourceLocation here() const { return SourceLocation{file_, line_, column()}; }
  int column() const { return static_cast<int>(pos_ - line_start_) + 1; }

  bool at_end() const { return pos_ >= text_.size(); }
  char peek() const { return at_end() ? '\0' : text_[pos_]; }

  void advance() {
    if (text_[pos_] == '\n') {
      ++line_;
      line_start_ = pos_ + 1;
    }
    ++pos_;
  }

  void skip_space() {
    while (!at_end()) {
      char c = text_[pos_];
      if (c != ' ' && c != '\t' && c != '\n' && c != '\r') break;
      advance();
    }
  }

  void expect_word(std::string_view word) {
    if (text_.substr(pos_, word.size()) != word) fail("invalid literal");
    for (size_t n = 0; n < word.size(); ++n) advance();
  }

  JsonValue parse_value(int depth) {
    if (depth > kMaxDepth) fail("nesting deeper than 256 levels");
    JsonValue v;
    v.where = here();
    switch (peek()) {
      case '{':
        parse_object(v, depth);
        break;
      case '[':
        parse_array(v, depth);
        break;
      case '"':
        v.kind = JsonValue::Kind::kString;
        v.string = parse_string();
        break;
      case 't':
        expect_word("true");
        v.kind = JsonValue::Kind::kBool;
        v.boolean = true;
        break;
      case 'f':
        expect_word("false");
        v.kind = JsonValue::Kind::kBool;
        break;
      case 'n':
        expect_word("null");
        break;
      case '\0':
        if (at_end()) fail("unexpected end of file");
        [[fallthrough]];
      default:
        if (peek() == '-' || (peek() >= '0' && peek() <= '9')) {
          v.kind = JsonValue::Kind::kNumber;
          v.number = parse_number();
        } else {
          fail(std::string("unexpected character '") + peek() + "'");
        }
    }
    return v;
  }

  void parse_object(JsonValue& v, int depth) {
    v.kind = JsonValue::Kind::kObject;
    advance();  // '{'
    skip_space();
    if (peek() == '}') {
      advance();
      return;
    }
    // A set, not a scan of the members read so far: that was quadratic, and a hostile file of
    // 100k keys (1 MB) took half a minute.
    std::unordered_set<std::string> keys;
    while (true) {
      skip_space();
      if (peek() != '"') fail("expected a quoted key");
      SourceLocation key_at = here();
      std::string key = parse_string();
      if (!keys.insert(key).second) throw InputError(key_at, "JSON: duplicate key '" + key + "'");
      skip_space();
      if (peek() != ':') fail("expected ':' after key");
      advance();
      skip_space();
      v.object.emplace_back(std::move(key), parse_value(depth + 1));
      skip_space();
      if (peek() == ',') {
        advance();
        continue;
      }
      if (peek() == '}') {
        advance();
        return;
      }
      fail("expected ',' or '}' in object");
    }
  }

  void parse_array(JsonValue& v, int depth) {
    v.kind = JsonValue::Kind::kArray;
    advance();  // '['
    skip_space();
    if (peek() == ']') {
      advance();
      return;
    }
    while (true) {
      skip_space();
      v.array.push_back(parse_value(depth + 1));
      skip_space();
      if (peek() == ',') {
        advance();
        continue;
      }
      if (peek() == ']') {
        advance();
        return;
      }
      fail("expected ',' or ']' in array");
    }
  }

  double parse_number() {
    size_t start = pos_;
    if (peek() == '-') advance();
    if (peek() == '0') {
      advance();
    } else if (peek() >= '1' && peek() <= '9') {
      while (peek() >= '0' && peek() <= '9') advance();
    } else {
      fail("invalid number");
    }
    if (peek() == '.') {
      advance();
      if (!(peek() >= '0' && peek() <= '9')) fail("invalid number: digits expected after '.'");
      while (peek() >= '0' && peek() <= '9') advance();
    }
    if (peek() == 'e' || peek() == 'E') {
      advance();
      if (peek() == '+' || peek() == '-') advance();
      if (!(peek() >= '0' && peek() <= '9')) fail("invalid number: digits expected in exponent");
      while (peek() >= '0' && peek() <= '9') advance();
    }
    double value = 0.0;
    auto [end, ec] = std::from_chars(text_.data() + start, text_.data() + pos_, value);
    if (ec != std::errc() || end != text_.data() + pos_ || !std::isfinite(value))
      throw InputError(SourceLocation{file_, line_, static_cast<int>(start - line_start_) + 1},
                       "JSON: number out of range");
    return value;
  }

  unsigned parse_hex4() {
    unsigned code = 0;
    for (int n = 0; n < 4; ++n) {
      char c = peek();
      unsigned digit;
      if (c >= '0' && c <= '9')
        digit = c - '0';
      else if (c >= 'a' && c <= 'f')
        digit = c - 'a' + 10;
      else if (c >= 'A' && c <= 'F')
        digit = c - 'A' + 10;
      else
        fail("invalid \\u escape");
      code = code * 16 + digit;
      advance();
    }
    return code;
  }

  static void append_utf8(std::string& out, unsigned code) {
    if (code < 0x80) {
      out += static_cast<char>(code);
    } else if (code < 0x800) {
      out += static_cast<char>(0xC0 | (code >> 6));
      out += static_cast<char>(0x80 | (code & 0x3F));
    } else if (code < 0x10000) {
      out += static_cast<char>(0xE0 | (code >> 12));
      out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (code & 0x3F));
    } else {
      out += static_cast<char>(0xF0 | (code >> 18));
      out += static_cast<char>(0x80 | ((code >> 12) & 0x3F));
      out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (code & 0x3F));
    }
  }

  std::string parse_string() {
    advance();  // opening quote
    std::string out;
    while (true) {
      if (at_end()) fail("unterminated string");
      char c = peek();
      if (c == '"') {
        advance();
        return out;
      }
      if (static_cast<unsigned char>(c) < 0x20) fail("control character in string");
      if (c != '\\') {
        out += c;
        advance();
        continue;
      }
      advance();
      char e = peek();
      if (at_end()) fail("unterminated string");
      advance();
      switch (e) {
        case '"':
          out += '"';
          break;
        case '\\':
          out += '\\';
          break;
        case '/':
          out += '/';
          break;
        case 'b':
          out += '\b';
          break;
        case 'f':
          out += '\f';
          break;
        case 'n':
          out += '\n';
          break;
        case 'r':
          out += '\r';
          break;
        case 't':
          out += '\t';
          break;
        case 'u': {
          unsigned code = parse_hex4();
          if (code >= 0xD800 && code < 0xDC00) {  // surrogate pair
            if (peek() != '\\') fail("unpaired surrogate in \\u escape");
            advance();
            if (peek() != 'u') fail("unpaired surrogate in \\u escape");
            advance();
            unsigned low = parse_hex4();
            if (low < 0xDC00 || low >= 0xE000) fail("invalid surrogate pair");
            code = 0x10000 + ((code - 0xD800) << 10) + (low - 0xDC00);
          } else if (code >= 0xDC00 && code < 0xE000) {
            fail("unpaired surrogate in \\u escape");
          }
          append_utf8(out, code);
          break;
        }
        default:
          fail("invalid escape in string");
      }
    }
  }

  std::string_view text_;
  const std::string& file_;
  size_t pos_ = 0;
  size_t line_start_ = 0;
  int line_ = 1;
};

}  // namespace

const JsonValue* JsonValue::find(std::string_view key) const {
  for (const auto& m : object)
    if (m.first == key) return &m.second;
  return nullptr;
}

const char* JsonValue::kind_name(Kind k) {
  switch (k) {
    case Kind::kNull:
      return "null";
    case Kind::kBool:
      return "a boolean";
    case Kind::kNumber:
      return "a number";
    case Kind::kString:
      return "a string";
    case Kind::kArray:
      return "an array";
    case Kind::kObject:
      return "an object";
  }
  return "?";
}

JsonValue parse_json(std::string_view text, const std::string& file_name) {
  return Parser(text, file_name).parse_document();
}

ObjectReader::ObjectReader(const JsonValue& value, std::string what)
    : value_(value), what_(std::move(what)) {
  if (!value.is(JsonValue::Kind::kObject))
    throw InputError(value.where,
                     what_ + " must be an object, not " + JsonValue::kind_name(value.kind));
}

const JsonValue* ObjectReader::optional(std::string_view key) {
  const JsonValue* v = value_.find(key);
  if (v) used_.emplace_back(key);
  return v;
}

const JsonValue& ObjectReader::get(std::string_view key) {
  const JsonValue* v = optional(key);
  if (!v) throw InputError(value_.where, what_ + " needs the key '" + std::string(key) + "'");
  return *v;
}

const JsonValue& ObjectReader::expect(const JsonValue& v, JsonValue::Kind kind,
                                      std::string_view key) const {
  if (!v.is(kind))
    throw InputError(v.where, "'" + std::string(key) + "' in " + what_ + " must be " +
                                  JsonValue::kind_name(kind) + ", not " +
                                  JsonValue::kind_name(v.kind));
  return v;
}

double ObjectReader::number(std::string_view key) {
  return expect(get(key), JsonValue::Kind::kNumber, key).number;
}

std::optional<double> ObjectReader::optional_number(std::string_view key) {
  const JsonValue* v = optional(key);
  if (!v) return std::nullopt;
  return expect(*v, JsonValue::Kind::kNumber, key).number;
}

std::string ObjectReader::string(std::string_view key) {
  return expect(get(key), JsonValue::Kind::kString, key).string;
}

bool ObjectReader::boolean(std::string_view key) {
  return expect(get(key), JsonValue::Kind::kBool, key).boolean;
}

long long ObjectReader::integer(std::string_view key, double lo, double hi) {
  const JsonValue& v = expect(get(key), JsonValue::Kind::kNumber, key);
  if (!(v.number >= lo && v.number <= hi && v.number == std::floor(v.number)))
    throw InputError(v.where, "'" + std::string(key) + "' in " + what_ +
                                  " must be a whole number in [" +
                                  std::to_string(static_cast<long long>(lo)) + ", " +
                                  std::to_string(static_cast<long long>(hi)) + "]");
  return static_cast<long long>(v.number);
}

double ObjectReader::number_or_infinity(std::string_view key) {
  const JsonValue& v = get(key);
  if (v.is(JsonValue::Kind::kNull)) return INFINITY;
  return expect(v, JsonValue::Kind::kNumber, key).number;
}

const JsonValue& ObjectReader::array(std::string_view key) {
  return expect(get(key), JsonValue::Kind::kArray, key);
}

const JsonValue& ObjectReader::object(std::string_view key) {
  return expect(get(key), JsonValue::Kind::kObject, key);
}

void ObjectReader::finish() const {
  for (const auto& [key, v] : value_.object) {
    bool used = false;
    for (const auto& u : used_) used = used || (u == key);
    if (!used) throw InputError(v.where, "unknown or unused key '" + key + "' in " + what_);
  }
}

double json_number(const JsonValue& v, std::string_view what) {
  if (!v.is(JsonValue::Kind::kNumber))
    throw InputError(v.where,
                     std::string(what) + " must be a number, not " + JsonValue::kind_name(v.kind));
  return v.number;
}

std::vector<double> json_numbers(const JsonValue& v, std::string_view what, size_t count) {
  if (!v.is(JsonValue::Kind::kArray) || v.array.size() != count)
    throw InputError(
        v.where, std::string(what) + " must be an array of " + std::to_string(count) + " numbers");
  std::vector<double> out;
  for (const auto& e : v.array) out.push_back(json_number(e, what));
  return out;
}

// ---- writer ---------------------------------------------------------------------------------

std::string json_escape(std::string_view s) {
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
      case '\r':
        out += "\\r";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

void JsonWriter::newline() {
  out_ += '\n';
  out_.append(2 * first_.size(), ' ');
}

void JsonWriter::key(std::string_view k) {
  if (!first_.empty()) {
    if (!first_.back()) out_ += ',';
    first_.back() = false;
    newline();
  }
  if (!k.empty()) out_ += json_escape(k) + ": ";
}

JsonWriter& JsonWriter::begin_object(std::string_view k) {
  key(k);
  out_ += '{';
  first_.push_back(true);
  return *this;
}

JsonWriter& JsonWriter::end_object() {
  bool empty = first_.back();
  first_.pop_back();
  if (!empty) newline();
  out_ += '}';
  if (first_.empty()) out_ += '\n';
  return *this;
}

JsonWriter& JsonWriter::begin_array(std::string_view k) {
  key(k);
  out_ += '[';
  first_.push_back(true);
  return *this;
}

JsonWriter& JsonWriter::end_array() {
  bool empty = first_.back();
  first_.pop_back();
  if (!empty) newline();
  out_ += ']';
  return *this;
}

JsonWriter& JsonWriter::value(std::string_view k, double v) {
  key(k);
  if (!std::isfinite(v)) {
    out_ += "null";
  } else {
    char buf[32];
    auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
    out_.append(buf, end);
  }
  return *this;
}

JsonWriter& JsonWriter::value(std::string_view k, long long v) {
  key(k);
  out_ += std::to_string(v);
  return *this;
}

JsonWriter& JsonWriter::value(std::string_view k, bool v) {
  key(k);
  out_ += v ? "true" : "false";
  return *this;
}

JsonWriter& JsonWriter::value(std::string_view k, std::string_view v) {
  key(k);
  out_ += json_escape(v);
  return *this;
}

}  // namespace polyrad
