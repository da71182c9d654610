// Streaming JSON text for big answer files (visgate solve's results): appends
// straight into one string instead of building an nlohmann document and dumping it. The
// caller writes the structure (braces, commas, keys that need no escaping) as raw text;
// every scalar and every key that may need escaping goes through nlohmann's own
// serializer, so the text is byte-identical to ordered_json::dump() of the same document
// (compact, ensure_ascii off, strict UTF-8: invalid UTF-8 throws type_error 316 as dump()
// does; doubles shortest round-trip, non-finite ones as null).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace visgate {

class JsonWriter {
 public:
  // Appends to `out`, which must outlive the writer.
  explicit JsonWriter(std::string& out)
      : out_(out), serializer_(nlohmann::detail::output_adapter<char, std::string>(out), ' ') {}

  // Text written as is: structure, and keys or strings known to need no escaping.
  void raw(std::string_view text) { out_.append(text); }
  void raw(char c) { out_.push_back(c); }

  // One scalar as dump() writes a document node built from `v` (the same conversion as
  // doc[key] = v: int and uint64 as integers, float types as doubles, strings escaped).
  template <class T>
  void value(const T& v) {
    serializer_.dump(Json(v), false, false, 0);
  }
  // An object key, escaped like a string, then ':'.
  void key(std::string_view k) {
    value(std::string(k));
    out_.push_back(':');
  }
  // {"k":v,...} from (key, value) pairs, in their order (unique keys: a document built by
  // doc[k] = v would keep only the last value of a repeated key).
  template <class Pairs>
  void object(const Pairs& pairs) {
    out_.push_back('{');
    bool first = true;
    for (const auto& [k, v] : pairs) {
      if (!first) out_.push_back(',');
      first = false;
      key(k);
      value(v);
    }
    out_.push_back('}');
  }
  // "[x,y,z]": a point as a three-number array.
  void point(double x, double y, double z) {
    out_.push_back('[');
    value(x);
    out_.push_back(',');
    value(y);
    out_.push_back(',');
    value(z);
    out_.push_back(']');
  }

  // Upper bound of the characters value() writes for one double: sign, 17 significant
  // digits, point, "e-308". Used to reserve the output once.
  static constexpr size_t kMaxDoubleChars = 25;

 private:
  using Json = nlohmann::ordered_json;
  std::string& out_;
  nlohmann::detail::serializer<Json> serializer_;
};

}  // namespace visgate
