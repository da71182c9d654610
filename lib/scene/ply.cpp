// The PLY parser (see ply.h).
#include "lib/scene/ply.h"

#include <cctype>
#include <cmath>
#include <cstring>
#include <sstream>

#include "lib/scene/mesh_text.h"

namespace visgate::ply {

const Type* find_type(const std::string& name) {
  static const Type kTypes[] = {
      {"char", 1, true, true},     {"int8", 1, true, true},      {"uchar", 1, true, false},
      {"uint8", 1, true, false},   {"short", 2, true, true},     {"int16", 2, true, true},
      {"ushort", 2, true, false},  {"uint16", 2, true, false},   {"int", 4, true, true},
      {"int32", 4, true, true},    {"uint", 4, true, false},     {"uint32", 4, true, false},
      {"float", 4, false, true},   {"float32", 4, false, true},  {"double", 8, false, true},
      {"float64", 8, false, true}};
  for (const auto& t : kTypes)
    if (name == t.name) return &t;
  return nullptr;
}

namespace {

bool parse_count(const std::string& tok, uint64_t& out) {
  if (tok.empty() || tok.size() > 18) return false;  // <= 10^18 - 1: no overflow below
  out = 0;
  for (char c : tok) {
    if (c < '0' || c > '9') return false;
    out = out * 10 + uint64_t(c - '0');
  }
  return true;
}

// Reads an integer of `t` (little- or big-endian) at p.
int64_t read_int(const unsigned char* p, const Type& t, bool big_endian) {
  uint64_t u = 0;
  for (int k = 0; k < t.size; ++k) u |= uint64_t(p[big_endian ? t.size - 1 - k : k]) << (8 * k);
  if (t.is_signed && t.size < 8 && (u >> (8 * t.size - 1)) & 1u) u |= ~uint64_t(0) << (8 * t.size);
  return int64_t(u);
}

// Integer range of an integer type.
bool int_in_range(double v, const Type& t) {
  const double bits = 8.0 * t.size;
  const double lo = t.is_signed ? -std::ldexp(1.0, int(bits) - 1) : 0.0;
  const double hi = t.is_signed ? std::ldexp(1.0, int(bits) - 1) - 1.0 : std::ldexp(1.0, int(bits)) - 1.0;
  return v == std::floor(v) && v >= lo && v <= hi;
}

// A binary value of type `t` at p as a double (exact for every PLY type).
double read_value(const unsigned char* p, const Type& t, bool big_endian) {
  if (t.integer) return double(read_int(p, t, big_endian));
  unsigned char b[8];
  for (int k = 0; k < t.size; ++k) b[k] = p[big_endian ? t.size - 1 - k : k];
  if (t.size == 4) {
    float f;
    std::memcpy(&f, b, 4);
    return f;
  }
  double d;
  std::memcpy(&d, b, 8);
  return d;
}

// Binary: walk every item so that each list's entries lie inside the file.
std::string read_binary_body(const std::string& data, const Header& h, const ScalarVisitor& visit) {
  const auto* bytes = reinterpret_cast<const unsigned char*>(data.data());
  const bool big = h.format == Format::BinaryBigEndian;
  uint64_t at_byte = h.body;
  const uint64_t end = data.size();
  for (size_t ei = 0; ei < h.elements.size(); ++ei) {
    const Element& e = h.elements[ei];
    for (uint64_t i = 0; i < e.count; ++i)
      for (size_t pi = 0; pi < e.props.size(); ++pi) {
        const Property& p = e.props[pi];
        const uint64_t head = uint64_t(p.count ? p.count->size : p.type->size);
        if (at_byte + head > end)
          return "element '" + e.name.substr(0, 32) + "' item " + std::to_string(i) + ": file ends early";
        if (!p.count) {
          if (visit)
            if (auto err = visit(Scalar{ei, pi, i, read_value(bytes + at_byte, *p.type, big), {}, 0}); !err.empty())
              return err;
          at_byte += head;
          continue;
        }
        const int64_t n = read_int(bytes + at_byte, *p.count, big);
        at_byte += head;
        if (n < 0 || uint64_t(n) > (end - at_byte) / uint64_t(p.type->size))
          return "element '" + e.name.substr(0, 32) + "' item " + std::to_string(i) + ": list '" +
                 p.name.substr(0, 32) + "' of " + std::to_string(n) + " entries does not fit in the file";
        at_byte += uint64_t(n) * uint64_t(p.type->size);
      }
  }
  return {};
}

// ASCII: every token in place, finite, integers in range.
std::string read_ascii_body(const std::string& data, const Header& h, const ScalarVisitor& visit) {
  size_t pos = h.body;
  size_t tline = h.lines + 1;
  auto next_token = [&](std::string& tok) -> bool {
    while (pos < data.size() && std::isspace(static_cast<unsigned char>(data[pos]))) {
      if (data[pos] == '\n') ++tline;
      ++pos;
    }
    if (pos >= data.size()) return false;
    size_t b = pos;
    while (pos < data.size() && !std::isspace(static_cast<unsigned char>(data[pos]))) ++pos;
    tok.assign(data, b, pos - b);
    return true;
  };
  std::string tok;
  for (size_t ei = 0; ei < h.elements.size(); ++ei) {
    const Element& e = h.elements[ei];
    for (uint64_t i = 0; i < e.count; ++i)
      for (size_t pi = 0; pi < e.props.size(); ++pi) {
        const Property& p = e.props[pi];
        auto what = [&] {
          return "element '" + e.name.substr(0, 32) + "' item " + std::to_string(i) + " property '" +
                 p.name.substr(0, 32) + "'";
        };
        auto value = [&](const Type& t, double& v) -> std::string {
          if (!next_token(tok)) return what() + ": file ends early";
          // A float property is read into a float, any other into a double or an integer.
          const bool ok = !t.integer && t.size == 4 ? float_number(tok, v) : finite_number(tok, v);
          if (!ok) return number_error(tok, tline, what());
          // Integers as plain digits: OpenMesh reads them with operator>> on an integer,
          // which stops at '.', 'e' or 'x' and leaves the rest for the next value.
          if (t.integer && (tok.find_first_not_of("+-0123456789") != std::string::npos || !int_in_range(v, t)))
            return "line " + std::to_string(tline) + ": " + what() + ": '" + tok.substr(0, 32) +
                   "' is not an integer of type " + t.name;
          return {};
        };
        double v = 0;
        if (!p.count) {
          if (auto err = value(*p.type, v); !err.empty()) return err;
          if (visit)
            if (auto err = visit(Scalar{ei, pi, i, v, tok, tline}); !err.empty()) return err;
          continue;
        }
        if (auto err = value(*p.count, v); !err.empty()) return err;
        if (v < 0) return "line " + std::to_string(tline) + ": " + what() + ": negative list length";
        // Each entry needs at least two bytes: bounded by the rest of the file.
        if (v > double(data.size() - pos))
          return "line " + std::to_string(tline) + ": " + what() + ": list of " + tok.substr(0, 32) +
                 " entries does not fit in the file";
        for (uint64_t k = 0; k < uint64_t(v); ++k) {
          double x = 0;
          if (auto err = value(*p.type, x); !err.empty()) return err;
        }
      }
  }
  return {};
}

}  // namespace

std::string read_header(const std::string& data, Header& h) {
  size_t pos = 0, lineno = 0;
  std::vector<std::string> toks;
  auto next_line = [&]() -> bool {
    if (pos >= data.size()) return false;
    size_t nl = data.find('\n', pos);
    std::string line = data.substr(pos, nl == std::string::npos ? std::string::npos : nl - pos);
    pos = nl == std::string::npos ? data.size() : nl + 1;
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ss(line);
    toks.clear();
    for (std::string t; ss >> t;) toks.push_back(t);
    return true;
  };
  auto at = [&](const std::string& msg) { return "line " + std::to_string(lineno) + ": " + msg; };
  if (!next_line() || toks.size() != 1 || toks[0] != "ply") return "line 1: missing 'ply' magic";
  int format = -1;  // 0 ascii, 1 binary little-endian, 2 binary big-endian
  std::vector<Element> elements;
  size_t props = 0;
  bool ended = false;
  while (!ended) {
    if (!next_line()) return at("file ends before 'end_header'");
    if (lineno > kMaxHeaderLines) return at("header longer than " + std::to_string(kMaxHeaderLines) + " lines");
    if (toks.empty()) return at("empty header line");
    const std::string& kw = toks[0];
    if (kw == "comment" || kw == "obj_info") continue;
    if (kw == "format") {
      if (format >= 0) return at("second 'format' line");
      if (toks.size() != 3 || toks[2] != "1.0") return at("expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
      if (toks[1] == "ascii") format = 0;
      else if (toks[1] == "binary_little_endian") format = 1;
      else if (toks[1] == "binary_big_endian") format = 2;
      else return at("unknown format '" + toks[1].substr(0, 32) + "'");
      continue;
    }
    if (format < 0) return at("'" + kw.substr(0, 32) + "' before the 'format' line");
    if (kw == "element") {
      Element e;
      if (toks.size() != 3 || !parse_count(toks[2], e.count)) return at("expected 'element NAME COUNT'");
      e.name = toks[1];
      e.line = lineno;
      elements.push_back(std::move(e));
    } else if (kw == "property") {
      if (elements.empty()) return at("property before any element");
      if (++props > kMaxProperties) return at("more than " + std::to_string(kMaxProperties) + " properties");
      Property p;
      if (toks.size() == 3 && toks[1] != "list") {
        p.type = find_type(toks[1]);
        if (!p.type) return at("property '" + toks[2].substr(0, 32) + "': unknown type '" + toks[1].substr(0, 32) + "'");
        p.name = toks[2];
      } else if (toks.size() == 5 && toks[1] == "list") {
        p.count = find_type(toks[2]);
        p.type = find_type(toks[3]);
        p.name = toks[4];
        if (!p.count || !p.count->integer)
          return at("list '" + p.name.substr(0, 32) + "': count type '" + toks[2].substr(0, 32) + "' is not an integer type");
        if (!p.type) return at("list '" + p.name.substr(0, 32) + "': unknown item type '" + toks[3].substr(0, 32) + "'");
      } else {
        return at("expected 'property TYPE NAME' or 'property list COUNT_TYPE ITEM_TYPE NAME'");
      }
      elements.back().props.push_back(std::move(p));
    } else if (kw == "end_header") {
      if (toks.size() != 1) return at("'end_header' followed by text");
      ended = true;
    } else {
      return at("unknown header keyword '" + kw.substr(0, 32) + "'");
    }
  }
  if (format < 0) return "missing 'format' line";
  const uint64_t body = data.size() - pos;

  // Counts against the body size.
  for (const auto& e : elements) {
    if (e.count == 0) continue;
    if (e.props.empty())
      return "line " + std::to_string(e.line) + ": element '" + e.name.substr(0, 32) + "' has items but no properties";
    uint64_t min_item = 0;
    for (const auto& p : e.props) min_item += format == 0 ? 2 : uint64_t(p.count ? p.count->size : p.type->size);
    // ASCII: the last token of the file needs no separator.
    const uint64_t room = (body + (format == 0 ? 1 : 0)) / min_item;
    if (e.count > room)
      return "line " + std::to_string(e.line) + ": element '" + e.name.substr(0, 32) + "' announces " +
             std::to_string(e.count) + " items, the file has room for at most " + std::to_string(room);
  }
  h.format = format == 0 ? Format::Ascii : (format == 1 ? Format::BinaryLittleEndian : Format::BinaryBigEndian);
  h.elements = std::move(elements);
  h.lines = lineno;
  h.body = pos;
  return {};
}

std::string read_body(const std::string& data, const Header& h, const ScalarVisitor& visit) {
  return h.format == Format::Ascii ? read_ascii_body(data, h, visit) : read_binary_body(data, h, visit);
}

}  // namespace visgate::ply
