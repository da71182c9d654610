// tools/bench/image: receiver-grid images, the PNG writer (round trip through stb_image)
// and the per-receiver fractions and diffs `visgate render` draws.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "tools/bench/image.h"

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wcast-align"
#pragma GCC diagnostic ignored "-Wshadow"
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#include <stb_image.h>
#pragma GCC diagnostic pop

namespace visgate::bench {
namespace {

TEST(BenchImage, GridOrientationAndScale) {
  // Receiver (a, b) has index b*nu + a and is drawn at column a, row nv-1-b.
  ReceiverGrid g;
  g.nu = 2;
  g.nv = 2;
  std::vector<Rgb> c = {{1, 0, 0}, {2, 0, 0}, {3, 0, 0}, {4, 0, 0}};
  Image img = grid_image(g, c, 2);
  ASSERT_EQ(img.width, 4);
  ASSERT_EQ(img.height, 4);
  EXPECT_EQ(img.at(0, 0).r, 3);  // top-left: a = 0, b = 1
  EXPECT_EQ(img.at(3, 0).r, 4);
  EXPECT_EQ(img.at(1, 3).r, 1);  // bottom-left: a = 0, b = 0
  EXPECT_EQ(img.at(2, 2).r, 2);
  EXPECT_EQ(auto_scale(g, 512), 256);
}

TEST(BenchImage, GrayClampsAndRounds) {
  EXPECT_EQ(gray(0.5).g, 128);  // round(127.5)
  EXPECT_EQ(gray(-1).r, 0);
  EXPECT_EQ(gray(2).b, 255);
  EXPECT_EQ(gray(std::nan("")).r, 0);
}

TEST(BenchPng, RoundTripThroughStbImage) {
  Image img;
  img.width = 3;
  img.height = 2;
  for (int i = 0; i < 6; ++i)
    for (int k = 0; k < 3; ++k) img.rgb.push_back(uint8_t(i * 40 + k * 7 + 1));
  std::string path = (std::filesystem::temp_directory_path() / ("vg_bench_test_" + std::to_string(::getpid()) + ".png")).string();
  ASSERT_TRUE(write_png(path, img).ok());
  int w = 0, h = 0, n = 0;
  unsigned char* data = stbi_load(path.c_str(), &w, &h, &n, 3);
  ASSERT_NE(data, nullptr);
  EXPECT_EQ(w, 3);
  EXPECT_EQ(h, 2);
  EXPECT_EQ(std::vector<uint8_t>(data, data + 18), img.rgb);
  stbi_image_free(data);
  std::filesystem::remove(path);
}

TEST(BenchPng, BadPathAndEmptyImageAreErrorsNamingTheFile) {
  Image img{1, 1, {1, 2, 3}};
  Status st = write_png("/nonexistent-dir/x.png", img);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("/nonexistent-dir/x.png"), std::string::npos);
  EXPECT_FALSE(write_png("/tmp/never.png", Image{}).ok());
}

// A scene of two lights with 2 and 1 samples (3 relations per receiver) and 2 receivers;
// only the counts matter to the fraction and diff helpers.
Scene two_light_scene() {
  Scene s;
  s.lights.resize(2);
  s.lights[0].samples = 2;
  s.lights[1].samples = 1;
  s.receivers.resize(2);
  return s;
}

TEST(BenchRender, ClassFractionCountsDegenerateAsHalf) {
  Scene s = two_light_scene();
  // Receiver 0: light 0 "vd" -> 0.75, light 1 "b" -> 0: mean 0.375.
  // Receiver 1: light 0 "vv" -> 1, light 1 "v" -> 1: mean 1.
  auto f = mean_class_fraction(s, {"vdb", "vvv"});
  ASSERT_EQ(f.size(), 2u);
  EXPECT_DOUBLE_EQ(f[0], 0.375);
  EXPECT_DOUBLE_EQ(f[1], 1.0);
}

TEST(BenchRender, MethodFractionIsTheMeanOverLights) {
  Scene s = two_light_scene();
  SolveResult r = make_empty_result(s);
  r.receivers[0].visible_fraction = {0.5f, 1.0f};
  r.receivers[1].visible_fraction = {0.0f, 0.25f};
  auto f = mean_visible_fraction(s, r);
  EXPECT_DOUBLE_EQ(f[0], 0.75);
  EXPECT_DOUBLE_EQ(f[1], 0.125);
}

TEST(BenchRender, DiffSplitsByTauAndSkipsDegenerate) {
  Scene s = two_light_scene();
  SolveResult r = make_empty_result(s);
  // Receiver 0 answers visible, visible, blocked; receiver 1 blocked everywhere.
  r.receivers[0].set_visible(0, true);
  r.receivers[0].set_visible(1, true);
  std::vector<std::string> classes = {"bdb", "vbv"};
  std::vector<std::vector<double>> margins = {{1e-3, 0.0, 0.5}, {1e-7, 0.2, 1e-5}};
  auto d = diff_receivers(s, r, classes, margins, 1e-5);
  // Receiver 0: relation 0 disagrees with margin 1e-3 >= tau (mismatch); relation 1 is
  // degenerate (ignored); relation 2 agrees.
  EXPECT_EQ(d[0].mismatches, 1u);
  EXPECT_EQ(d[0].below_tau, 0u);
  // Receiver 1: relation 0 disagrees below tau, relation 1 agrees, relation 2 disagrees
  // with margin exactly tau: a mismatch (margin >= tau).
  EXPECT_EQ(d[1].mismatches, 1u);
  EXPECT_EQ(d[1].below_tau, 1u);
}

bool same(Rgb a, Rgb b) { return a.r == b.r && a.g == b.g && a.b == b.b; }

TEST(BenchRender, ViridisEndsAndTenthsAreMatplotlibs) {
  EXPECT_TRUE(same(viridis(0.0), Rgb{68, 1, 84}));
  EXPECT_TRUE(same(viridis(0.5), Rgb{33, 145, 140}));
  EXPECT_TRUE(same(viridis(1.0), Rgb{253, 231, 37}));
  EXPECT_TRUE(same(viridis(-3), viridis(0.0)));
  EXPECT_TRUE(same(viridis(7), viridis(1.0)));
  EXPECT_TRUE(same(viridis(std::nan("")), viridis(0.0)));
  // Lightness (the green channel here) grows with the fraction, so it reads in gray.
  for (int k = 0; k < 100; ++k) EXPECT_LE(viridis(k / 100.0).g, viridis((k + 1) / 100.0).g) << k;
}

// A 4 x 2 grid of unit receivers: fractions 0, 1/7, ..., 1 and a 2 x 2 light square over
// the grid's middle.
ReceiverGrid picture_grid() {
  ReceiverGrid g;
  g.origin = Vec3f(0, 0, 0);
  g.u = Vec3f(4, 0, 0);
  g.v = Vec3f(0, 2, 0);
  g.nu = 4;
  g.nv = 2;
  return g;
}
Picture picture() {
  Picture p;
  for (int i = 0; i < 8; ++i) p.fraction.push_back(i / 7.0);
  p.lights = {{Vec3f(1, 0.5f, 3), Vec3f(3, 0.5f, 3), Vec3f(3, 1.5f, 3), Vec3f(1, 1.5f, 3)}};
  return p;
}

TEST(BenchRender, PictureHasTheFractionsLegendScaleBarAndLightOutline) {
  const ReceiverGrid g = picture_grid();
  const int scale = 40;
  Image img = render_picture(g, picture(), scale);
  PictureLayout l = picture_layout(g, scale);
  ASSERT_EQ(img.width, l.width);
  ASSERT_EQ(img.height, l.height);
  ASSERT_EQ(l.grid_w, 160);
  ASSERT_EQ(l.grid_h, 80);
  // Receiver (a, b) = index b*4 + a at column a, row 1 - b; a block corner off the outline.
  for (int b = 0; b < 2; ++b)
    for (int a = 0; a < 4; ++a)
      EXPECT_TRUE(same(img.at(l.grid_x + a * scale + 2, l.grid_y + (1 - b) * scale + 2), viridis((b * 4 + a) / 7.0)))
          << a << " " << b;
  // The colour bar: 1 at the top, 0 at the bottom.
  EXPECT_TRUE(same(img.at(l.bar_x + l.bar_w / 2, l.bar_y), viridis(1.0)));
  EXPECT_TRUE(same(img.at(l.bar_x + l.bar_w / 2, l.bar_y + l.bar_h - 1), viridis(0.0)));
  // Scale bar: u is 4 long, a quarter is 1: one unit = 40 pixels, black.
  EXPECT_DOUBLE_EQ(l.scale_length, 1.0);
  EXPECT_EQ(l.scale_w, 40);
  EXPECT_TRUE(same(img.at(l.scale_x + 20, l.scale_y + 1), Rgb{0, 0, 0}));
  EXPECT_TRUE(same(img.at(l.scale_x + 60, l.scale_y + 1), Rgb{255, 255, 255}));
  // The light's outline: its left edge at s = 1/4 (x = 40), t from 1/4 to 3/4, white.
  EXPECT_TRUE(same(img.at(l.grid_x + 40, l.grid_y + 40), Rgb{255, 255, 255}));
  EXPECT_TRUE(same(img.at(l.grid_x + 39, l.grid_y + 40), Rgb{0, 0, 0}));  // its rim
  EXPECT_TRUE(same(img.at(l.grid_x + 100, l.grid_y + 20), Rgb{255, 255, 255}));  // top edge, t = 3/4
}

TEST(BenchRender, DiffMarksSitOnTheirReceiversOverTheFraction) {
  const ReceiverGrid g = picture_grid();
  Picture p = picture();
  p.lights.clear();
  p.diff.resize(8);
  p.diff[1].mismatches = 2;  // receiver (1, 0)
  p.diff[6].below_tau = 1;   // receiver (2, 1)
  p.diff[5].mismatches = 1, p.diff[5].below_tau = 3;  // a mismatch wins
  const int scale = 40;
  Image img = render_picture(g, p, scale);
  PictureLayout l = picture_layout(g, scale);
  for (int b = 0; b < 2; ++b)
    for (int a = 0; a < 4; ++a) {
      const size_t i = size_t(b * 4 + a);
      const int x = l.grid_x + a * scale, y = l.grid_y + (1 - b) * scale;
      const Rgb centre = img.at(x + scale / 2, y + scale / 2), corner = img.at(x + 2, y + 2);
      EXPECT_TRUE(same(corner, viridis(double(i) / 7.0))) << i;  // the fraction around the mark
      const Rgb want = p.diff[i].mismatches ? kMismatchColor : p.diff[i].below_tau ? kBelowTauColor : viridis(double(i) / 7.0);
      EXPECT_TRUE(same(centre, want)) << i;
    }
  // The legend names both marks with a swatch of each colour.
  EXPECT_TRUE(same(img.at(l.bar_x + 2, l.marks_y + 2), kMismatchColor));
  EXPECT_TRUE(same(img.at(l.bar_x + 2, l.marks_y + 16 + 8 + 2), kBelowTauColor));
  // Below 4 pixels per receiver the mark fills the whole block.
  Image small = render_picture(g, p, 3);
  PictureLayout ls = picture_layout(g, 3);
  EXPECT_TRUE(same(small.at(ls.grid_x + 3, ls.grid_y + 3), kMismatchColor));  // receiver (1, 0), row 1
}

}  // namespace
}  // namespace visgate::bench
