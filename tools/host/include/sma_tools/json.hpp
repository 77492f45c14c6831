// A small strict JSON reader and writer for the host tools (RFC 8259: objects, arrays, strings,
// numbers, true/false/null). Every value remembers the line it started on, so that errors can
// name the file, the line and the key. Duplicate keys are an error (a file that says h twice is
// ambiguous). No dependency beyond the C++ standard library.
#ifndef SMA_TOOLS_JSON_HPP
#define SMA_TOOLS_JSON_HPP

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>
#include "error.hpp"

namespace sma_tools {
namespace json {

struct Value {
  enum class Type { Null, Bool, Number, String, Array, Object };
  Type type = Type::Null;
  bool b = false;
  double num = 0.0;
  std::string str;
  std::vector<Value> arr;
  std::vector<std::pair<std::string, Value>> obj;  // in file order
  int line = 0;

  bool is_number() const { return type == Type::Number; }
  bool is_object() const { return type == Type::Object; }
  bool is_array() const { return type == Type::Array; }
  const Value* find(const std::string& key) const {
    for (const auto& kv : obj)
      if (kv.first == key) return &kv.second;
    return nullptr;
  }
  static const char* type_name(Type t) {
    switch (t) {
      case Type::Null: return "null";
      case Type::Bool: return "a boolean";
      case Type::Number: return "a number";
      case Type::String: return "a string";
      case Type::Array: return "a list";
      default: return "an object";
    }
  }
};

class Parser {
 public:
  Parser(const std::string& text, const std::string& name) : s_(text), name_(name) {}

  Value parse() {
    skip_ws();
    Value v = value(0);
    skip_ws();
    if (i_ < s_.size()) fail("unexpected text after the JSON value");
    return v;
  }

 private:
  [[noreturn]] void fail(const std::string& msg) const {
    throw Error(name_ + ":" + std::to_string(line_) + ": invalid JSON: " + msg);
  }
  void skip_ws() {
    while (i_ < s_.size()) {
      const char c = s_[i_];
      if (c == '\n') ++line_;
      if (c == ' ' || c == '\t' || c == '\n' || c == '\r') ++i_;
      else break;
    }
  }
  char peek() const { return i_ < s_.size() ? s_[i_] : '\0'; }
  void expect(char c) {
    if (peek() != c) {
      if (i_ >= s_.size()) fail(std::string("expected '") + c + "' but the file ended");
      fail(std::string("expected '") + c + "' but found '" + s_[i_] + "'");
    }
    ++i_;
  }
  Value value(int depth) {
    if (depth > 64) fail("nested too deeply");
    Value v;
    v.line = line_;
    const char c = peek();
    if (c == '{') {
      v.type = Value::Type::Object;
      ++i_;
      skip_ws();
      if (peek() == '}') {
        ++i_;
        return v;
      }
      for (;;) {
        skip_ws();
        if (peek() != '"') fail("expected a key in double quotes");
        const int key_line = line_;
        std::string key = string();
        for (const auto& kv : v.obj)
          if (kv.first == key) {
            line_ = key_line;
            fail("key '" + key + "' appears twice");
          }
        skip_ws();
        expect(':');
        skip_ws();
        Value item = value(depth + 1);
        v.obj.emplace_back(std::move(key), std::move(item));
        skip_ws();
        if (peek() == ',') {
          ++i_;
          continue;
        }
        expect('}');
        return v;
      }
    }
    if (c == '[') {
      v.type = Value::Type::Array;
      ++i_;
      skip_ws();
      if (peek() == ']') {
        ++i_;
        return v;
      }
      for (;;) {
        skip_ws();
        v.arr.push_back(value(depth + 1));
        skip_ws();
        if (peek() == ',') {
          ++i_;
          continue;
        }
        expect(']');
        return v;
      }
    }
    if (c == '"') {
      v.type = Value::Type::String;
      v.str = string();
      return v;
    }
    if (literal("true")) {
      v.type = Value::Type::Bool;
      v.b = true;
      return v;
    }
    if (literal("false")) {
      v.type = Value::Type::Bool;
      return v;
    }
    if (literal("null")) return v;
    if (c == '-' || (c >= '0' && c <= '9')) {
      v.type = Value::Type::Number;
      v.num = number();
      return v;
    }
    if (i_ >= s_.size()) fail("the file ended where a value was expected");
    fail(std::string("unexpected character '") + c + "'");
  }
  bool literal(const char* w) {
    const std::string word(w);
    if (s_.compare(i_, word.size(), word) == 0) {
      i_ += word.size();
      return true;
    }
    return false;
  }
  double number() {
    const size_t start = i_;
    if (peek() == '-') ++i_;
    if (!(peek() >= '0' && peek() <= '9')) fail("bad number");
    if (peek() == '0') {
      ++i_;
    } else {
      while (peek() >= '0' && peek() <= '9') ++i_;
    }
    if (peek() == '.') {
      ++i_;
      if (!(peek() >= '0' && peek() <= '9')) fail("bad number: digits expected after '.'");
      while (peek() >= '0' && peek() <= '9') ++i_;
    }
    if (peek() == 'e' || peek() == 'E') {
      ++i_;
      if (peek() == '+' || peek() == '-') ++i_;
      if (!(peek() >= '0' && peek() <= '9')) fail("bad number: digits expected in the exponent");
      while (peek() >= '0' && peek() <= '9') ++i_;
    }
    const std::string tok = s_.substr(start, i_ - start);
    const double x = std::strtod(tok.c_str(), nullptr);
    if (!std::isfinite(x)) fail("number out of range: " + tok);
    return x;
  }
  std::string string() {
    expect('"');
    std::string out;
    for (;;) {
      if (i_ >= s_.size()) fail("unterminated string");
      const char c = s_[i_++];
      if (c == '"') return out;
      if (c == '\n') fail("newline inside a string");
      if (c != '\\') {
        out += c;
        continue;
      }
      if (i_ >= s_.size()) fail("unterminated string");
      const char e = s_[i_++];
      switch (e) {
        case '"': out += '"'; break;
        case '\\': out += '\\'; break;
        case '/': out += '/'; break;
        case 'b': out += '\b'; break;
        case 'f': out += '\f'; break;
        case 'n': out += '\n'; break;
        case 'r': out += '\r'; break;
        case 't': out += '\t'; break;
        case 'u': {
          if (i_ + 4 > s_.size()) fail("bad \\u escape");
          for (size_t h = i_; h < i_ + 4; ++h)  // exactly 4 hex digits (strtoul would stop early)
            if (!std::isxdigit(static_cast<unsigned char>(s_[h]))) fail("bad \\u escape");
          const unsigned long cp = std::strtoul(s_.substr(i_, 4).c_str(), nullptr, 16);
          i_ += 4;
          if (cp < 0x80) out += static_cast<char>(cp);
          else out += '?';  // keys and values of the tools are ASCII
          break;
        }
        default: fail(std::string("bad escape '\\") + e + "'");
      }
    }
  }

  const std::string& s_;
  std::string name_;
  size_t i_ = 0;
  int line_ = 1;
};

inline Value parse(const std::string& text, const std::string& name) {
  return Parser(text, name).parse();
}

// ---- writing ----------------------------------------------------------------------------------
// Shortest text that reads back to the same double (up to 17 significant digits).
inline std::string number(double x) {
  if (!std::isfinite(x)) return "null";
  char buf[40];
  for (int prec = 6; prec <= 17; ++prec) {
    std::snprintf(buf, sizeof buf, "%.*g", prec, x);
    if (std::strtod(buf, nullptr) == x) break;
  }
  return buf;
}

inline std::string quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (c == '\n') {
      out += "\\n";
    } else if (static_cast<unsigned char>(c) < 0x20) {
      out += ' ';
    } else {
      out += c;
    }
  }
  return out + "\"";
}

}  // namespace json
}  // namespace sma_tools

#endif  // SMA_TOOLS_JSON_HPP
