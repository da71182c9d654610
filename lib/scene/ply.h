// PLY (Turk's format as OpenMesh 9 reads it): the one PLY parser of the project. The mesh
// importer (mesh_io.cpp) runs it as a strict pre-scan before OpenMesh reads the file;
// repair's input audit (lib/repair/repair_input.cpp) walks the same body for the
// attributes and the exact vertex coordinates the importer does not keep.
//
// OpenMesh's PLY reader crashes on a property of an unknown type, loops allocating
// element records when the header never ends, and resizes vectors to whatever count the
// file states. So the whole file is checked: the header strictly (`ply`, one `format`
// line, `element NAME COUNT`, `property TYPE NAME` or `property list COUNT_TYPE
// ITEM_TYPE NAME` of the known types, `comment`/`obj_info`, `end_header`), every element
// count against the bytes the body has (an item takes at least the sum of its scalar
// sizes and list-count sizes in binary, at least two bytes per property in ASCII: one
// digit and a separator), then the body itself: every list fits in the file, and in
// ASCII every token is a finite number (integers in range for integer types). Errors
// name the header line, or the element and item of the body.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace visgate::ply {

struct Type {
  const char* name;
  int size;  // bytes in binary
  bool integer;
  bool is_signed;
};
// The type of that name (char, uchar, ..., float64), or nullptr.
const Type* find_type(const std::string& name);

struct Property {
  std::string name;
  const Type* type = nullptr;   // scalar type, or list item type
  const Type* count = nullptr;  // list count type; nullptr for a scalar
};

struct Element {
  std::string name;
  uint64_t count = 0;
  size_t line = 0;  // header line
  std::vector<Property> props;
};

enum class Format { Ascii, BinaryLittleEndian, BinaryBigEndian };

struct Header {
  Format format = Format::Ascii;
  std::vector<Element> elements;
  size_t lines = 0;  // header lines, end_header included
  size_t body = 0;   // byte offset of the body in the file
};

// Header limits: far above any real file (a few elements with a dozen properties each),
// low enough that a hostile header cannot make the scan itself slow.
constexpr size_t kMaxHeaderLines = 4096;
constexpr size_t kMaxProperties = 1024;

// Reads and checks the header of `data` (the whole file) and the element counts against
// the body's size. Returns an empty string, else the error.
std::string read_header(const std::string& data, Header& h);

// A scalar property value of the body. `value` is exact for every binary type; in ASCII
// it is strtod's value of `token`, the text as the file has it (empty in binary).
struct Scalar {
  size_t element, property;
  uint64_t item;
  double value;
  std::string_view token;
  size_t line;  // ASCII: the token's line; binary: 0
};
// Returns an empty string to go on, else an error that ends the walk.
using ScalarVisitor = std::function<std::string(const Scalar&)>;

// Walks and checks the body of `data` as `h` describes it, calling `visit` (when given)
// on every scalar property value in file order. Returns an empty string, else the first
// error (the body's or the visitor's).
std::string read_body(const std::string& data, const Header& h, const ScalarVisitor& visit);

}  // namespace visgate::ply
