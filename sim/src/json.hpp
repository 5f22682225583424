// A small JSON reader and writer for the control channel's one-object-per-line messages.
// Written here rather than pulled in as a dependency: the simulator only needs objects, arrays,
// numbers, strings, booleans and null, and the build must work from Debian's packages alone.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace cart2d::json {

struct Value {
  enum class Type { kNull, kBool, kNumber, kString, kArray, kObject };
  Type type = Type::kNull;
  bool boolean = false;
  double number = 0.0;
  std::string string;
  std::vector<Value> array;
  std::vector<std::pair<std::string, Value>> object;

  bool is_null() const { return type == Type::kNull; }
  bool is_bool() const { return type == Type::kBool; }
  bool is_number() const { return type == Type::kNumber; }
  bool is_string() const { return type == Type::kString; }
  bool is_array() const { return type == Type::kArray; }
  bool is_object() const { return type == Type::kObject; }
  // Member of an object, or nullptr.
  const Value* find(std::string_view key) const;
};

// Parses one complete JSON text. On failure returns false and says why in *error.
bool parse(std::string_view text, Value* out, std::string* error);

// Serialises a value back to compact JSON (used to echo request ids).
std::string dump(const Value& v);
// A JSON string literal with escapes.
std::string quote(std::string_view s);
// A JSON number; non-finite values become null (JSON has no NaN).
std::string number(double v);

// Builds one JSON object, member by member, in insertion order.
class Object {
 public:
  Object& add(std::string_view key, double v);
  Object& add(std::string_view key, int v) { return add(key, static_cast<long long>(v)); }
  Object& add(std::string_view key, long long v);
  Object& add(std::string_view key, unsigned long long v);
  Object& add(std::string_view key, bool v);
  Object& add(std::string_view key, const char* v) { return add(key, std::string_view(v)); }
  Object& add(std::string_view key, std::string_view v);
  Object& add(std::string_view key, const std::string& v) { return add(key, std::string_view(v)); }
  // Member whose value is already JSON text (nested objects, arrays, null).
  Object& add_raw(std::string_view key, std::string_view json_text);
  std::string str() const { return text_ + "}"; }

 private:
  void key(std::string_view k);
  std::string text_ = "{";
};

}  // namespace cart2d::json
