// lib/scene/float_text: decimal and hex float text, bit-exact both ways.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>

#include "lib/scene/float_text.h"
#include "tests/support/scene_files.h"

using namespace visgate;
using namespace visgate::test_support;
namespace fs = std::filesystem;

TEST(FloatText, DecimalAndHexRoundTripBitExact) {
  const float specials[] = {0.1f, -0.0f, 0.0f, 1.0f / 3.0f, std::numeric_limits<float>::denorm_min(),
                            std::numeric_limits<float>::min(), std::numeric_limits<float>::max(),
                            -std::numeric_limits<float>::max(), 1.17549421e-38f /* largest subnormal */,
                            123456.789f, 1e-30f};
  for (float f : specials) {
    auto d = parse_float(float_to_decimal(f));
    auto h = parse_float(float_to_hex(f));
    ASSERT_TRUE(d && h);
    EXPECT_EQ(bits(*d), bits(f)) << float_to_decimal(f);
    EXPECT_EQ(bits(*h), bits(f)) << float_to_hex(f);
  }
  EXPECT_FALSE(parse_float("1.0abc"));
  EXPECT_FALSE(parse_float(""));
  EXPECT_EQ(*parse_float("0x1.8p+1"), 3.0f);
}
