// lib/scene/ply.cpp, the one PLY parser: strict header errors name the line, counts are
// checked against the body, and the body walk hands every scalar over in file order,
// exactly (binary) or with its token (ASCII), on both byte orders.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "lib/scene/ply.h"
#include "tests/support/binary_bytes.h"

using namespace visgate;
using visgate::test::put_bin;

namespace {

std::string header_error(const std::string& data) {
  ply::Header h;
  return ply::read_header(data, h);
}

}  // namespace

TEST(Ply, HeaderErrorsNameTheLine) {
  EXPECT_EQ(header_error("plx\n"), "line 1: missing 'ply' magic");
  EXPECT_EQ(header_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n0\n"),
            "line 4: property 'x': unknown type 'quad'");
  EXPECT_EQ(header_error("ply\nelement vertex 1\n"), "line 2: 'element' before the 'format' line");
  EXPECT_EQ(header_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty list float int v\nend_header\n"),
            "line 4: list 'v': count type 'float' is not an integer type");
  EXPECT_EQ(header_error("ply\nformat ascii 1.0\nelement vertex 1000\nproperty float x\nend_header\n1 2\n"),
            "line 3: element 'vertex' announces 1000 items, the file has room for at most 2");
  EXPECT_EQ(header_error("ply\nformat ascii 1.0\n"), "line 2: file ends before 'end_header'");
}

TEST(Ply, AsciiScalarsComeWithTheirTokensInFileOrder) {
  const std::string data =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty float y\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0.1 2\n-3e2 +4.5\n2 0 1\n";
  ply::Header h;
  ASSERT_EQ(ply::read_header(data, h), "");
  EXPECT_EQ(h.format, ply::Format::Ascii);
  EXPECT_EQ(h.lines, 8u);
  std::vector<std::string> seen;
  const std::string err = ply::read_body(data, h, [&](const ply::Scalar& s) {
    seen.push_back(std::to_string(s.element) + ":" + std::to_string(s.item) + ":" + std::to_string(s.property) + ":" +
                   std::string(s.token) + "@" + std::to_string(s.line));
    return std::string();
  });
  EXPECT_EQ(err, "");
  EXPECT_EQ(seen, (std::vector<std::string>{"0:0:0:0.1@9", "0:0:1:2@9", "0:1:0:-3e2@10", "0:1:1:+4.5@10"}));
  // A bad token is refused with its line; the visitor's own error ends the walk.
  std::string bad = data;
  bad.replace(bad.find("+4.5"), 4, "nan");
  EXPECT_NE(ply::read_body(bad, h, nullptr).find("line 10"), std::string::npos);
  EXPECT_EQ(ply::read_body(data, h, [](const ply::Scalar&) { return std::string("stop"); }), "stop");
}

TEST(Ply, BinaryScalarsAreExactOnBothByteOrders) {
  for (bool big : {false, true}) {
    std::string data = std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
                       " 1.0\nelement vertex 1\nproperty double x\nproperty float y\nproperty short z\n"
                       "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    put_bin<double>(data, 0.1, big);
    put_bin<float>(data, 1.5f, big);
    put_bin<int16_t>(data, -7, big);
    put_bin<uint8_t>(data, 3, big);
    for (int32_t i : {0, 0, 0}) put_bin<int32_t>(data, i, big);
    ply::Header h;
    ASSERT_EQ(ply::read_header(data, h), "");
    std::vector<double> values;
    EXPECT_EQ(ply::read_body(data, h, [&](const ply::Scalar& s) {
      values.push_back(s.value);
      return std::string();
    }), "");
    EXPECT_EQ(values, (std::vector<double>{0.1, 1.5, -7.0})) << (big ? "big-endian" : "little-endian");
    // A list that does not fit is refused.
    data.resize(data.size() - 4);
    ply::Header h2;
    const std::string err = ply::read_header(data, h2).empty() ? ply::read_body(data, h2, nullptr) : "header";
    EXPECT_NE(err.find("does not fit"), std::string::npos) << err;
  }
}
