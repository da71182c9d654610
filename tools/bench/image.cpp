// Receiver-grid images and the PNG writer (see image.h). The one translation unit that
// holds the stb_image_write implementation.
#include "tools/bench/image.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wcast-align"
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#include <stb_image_write.h>
#pragma GCC diagnostic pop

namespace visgate::bench {

const Rgb kMismatchColor{230, 20, 20};
const Rgb kBelowTauColor{255, 150, 0};

Status write_png(const std::string& path, const Image& img) {
  if (img.width <= 0 || img.height <= 0 || img.rgb.size() != size_t(img.width) * size_t(img.height) * 3)
    return Error{path + ": empty or inconsistent image"};
  if (!stbi_write_png(path.c_str(), img.width, img.height, 3, img.rgb.data(), img.width * 3))
    return Error{path + ": cannot write the PNG file"};
  return {};
}

Rgb gray(double v) {
  if (!(v > 0)) v = 0;  // NaN -> 0
  if (v > 1) v = 1;
  auto g = uint8_t(std::lround(255.0 * v));
  return {g, g, g};
}

Image grid_image(const ReceiverGrid& grid, const std::vector<Rgb>& colors, int scale) {
  VG_CHECK(colors.size() == size_t(grid.nu) * size_t(grid.nv));
  scale = std::max(1, scale);
  Image img;
  img.width = grid.nu * scale;
  img.height = grid.nv * scale;
  img.rgb.resize(size_t(img.width) * size_t(img.height) * 3);
  for (int y = 0; y < img.height; ++y) {
    int b = grid.nv - 1 - y / scale;
    for (int x = 0; x < img.width; ++x) {
      const Rgb& c = colors[size_t(b) * size_t(grid.nu) + size_t(x / scale)];
      size_t i = (size_t(y) * size_t(img.width) + size_t(x)) * 3;
      img.rgb[i] = c.r;
      img.rgb[i + 1] = c.g;
      img.rgb[i + 2] = c.b;
    }
  }
  return img;
}

int auto_scale(const ReceiverGrid& grid, int min_side) {
  int side = std::max(1, std::max(grid.nu, grid.nv));
  return std::max(1, (min_side + side - 1) / side);
}

std::vector<double> mean_visible_fraction(const Scene& scene, const SolveResult& result) {
  std::vector<double> out(result.receivers.size(), 0.0);
  double lights = double(std::max<size_t>(1, scene.lights.size()));
  for (size_t i = 0; i < result.receivers.size(); ++i) {
    double s = 0;
    for (float f : result.receivers[i].visible_fraction) s += double(f);
    out[i] = s / lights;
  }
  return out;
}

std::vector<double> mean_class_fraction(const Scene& scene, const std::vector<std::string>& classes) {
  std::vector<double> out(classes.size(), 0.0);
  double lights = double(std::max<size_t>(1, scene.lights.size()));
  for (size_t i = 0; i < classes.size(); ++i) {
    double s = 0;
    for (size_t l = 0; l < scene.lights.size(); ++l) {
      size_t off = scene.light_offset(l), n = size_t(scene.lights[l].samples);
      double vis = 0;
      for (size_t j = 0; j < n && off + j < classes[i].size(); ++j) {
        char c = classes[i][off + j];
        vis += c == 'v' ? 1.0 : c == 'd' ? 0.5 : 0.0;
      }
      s += n ? vis / double(n) : 0.0;
    }
    out[i] = s / lights;
  }
  return out;
}

std::vector<ReceiverDiff> diff_receivers(const Scene& scene, const SolveResult& result,
                                         const std::vector<std::string>& classes,
                                         const std::vector<std::vector<double>>& margins, double tau) {
  VG_CHECK(classes.size() == result.receivers.size() && margins.size() == classes.size());
  std::vector<ReceiverDiff> out(classes.size());
  size_t bits = scene.samples_per_receiver();
  for (size_t i = 0; i < classes.size(); ++i) {
    VG_CHECK(classes[i].size() == bits && margins[i].size() == bits);
    for (size_t b = 0; b < bits; ++b) {
      char c = classes[i][b];
      if (c == 'd') continue;
      if (result.receivers[i].visible(b) == (c == 'v')) continue;
      if (margins[i][b] >= tau) ++out[i].mismatches;
      else ++out[i].below_tau;
    }
  }
  return out;
}

Rgb viridis(double v) {
  // matplotlib's viridis at 0, 0.1, ..., 1.
  static constexpr uint8_t kMap[11][3] = {{68, 1, 84},    {72, 36, 117},  {65, 68, 135},  {53, 95, 141},
                                          {42, 120, 142}, {33, 145, 140}, {34, 168, 132}, {68, 191, 112},
                                          {122, 209, 81}, {189, 223, 38}, {253, 231, 37}};
  if (!(v > 0)) v = 0;  // NaN -> 0
  if (v > 1) v = 1;
  const double x = v * 10.0;
  const int k = std::min(9, int(x));
  const double t = x - k;
  auto mix = [&](int c) { return uint8_t(std::lround(kMap[k][c] + (kMap[k + 1][c] - kMap[k][c]) * t)); };
  return {mix(0), mix(1), mix(2)};
}

namespace {

constexpr Rgb kBackground{255, 255, 255}, kInk{0, 0, 0}, kOutline{255, 255, 255};
constexpr int kPad = 16;        // margin around the grid
constexpr int kTextScale = 2;   // glyph pixels per font pixel
constexpr int kGlyphW = 6 * kTextScale, kGlyphH = 8 * kTextScale;  // advance and line height

// A 5 x 7 font of the characters the labels use (rows top first, bit 4 the left column).
const uint8_t* glyph(char c) {
  struct G {
    char c;
    uint8_t rows[7];
  };
  static constexpr G kFont[] = {
      {'0', {14, 17, 19, 21, 25, 17, 14}}, {'1', {4, 12, 4, 4, 4, 4, 14}},     {'2', {14, 17, 1, 2, 4, 8, 31}},
      {'3', {31, 2, 4, 2, 1, 17, 14}},     {'4', {2, 6, 10, 18, 31, 2, 2}},    {'5', {31, 16, 30, 1, 1, 17, 14}},
      {'6', {6, 8, 16, 30, 17, 17, 14}},   {'7', {31, 1, 2, 4, 8, 8, 8}},      {'8', {14, 17, 17, 14, 17, 17, 14}},
      {'9', {14, 17, 17, 15, 1, 2, 12}},   {'.', {0, 0, 0, 0, 0, 12, 12}},     {'-', {0, 0, 0, 31, 0, 0, 0}},
      {'+', {0, 4, 4, 31, 4, 4, 0}},       {'e', {0, 0, 14, 17, 31, 16, 14}},  {'A', {14, 17, 17, 31, 17, 17, 17}},
      {'B', {30, 17, 17, 30, 17, 17, 30}}, {'C', {14, 17, 16, 16, 16, 17, 14}}, {'E', {31, 16, 16, 30, 16, 16, 31}},
      {'F', {31, 16, 16, 30, 16, 16, 16}}, {'G', {14, 17, 16, 23, 17, 17, 15}}, {'H', {17, 17, 17, 31, 17, 17, 17}},
      {'I', {14, 4, 4, 4, 4, 4, 14}},      {'L', {16, 16, 16, 16, 16, 16, 31}}, {'M', {17, 27, 21, 21, 17, 17, 17}},
      {'N', {17, 17, 25, 21, 19, 17, 17}}, {'O', {14, 17, 17, 17, 17, 17, 14}}, {'R', {30, 17, 17, 30, 20, 18, 17}},
      {'S', {15, 16, 16, 14, 1, 1, 30}},   {'T', {31, 4, 4, 4, 4, 4, 4}},      {'U', {17, 17, 17, 17, 17, 17, 14}},
      {'V', {17, 17, 17, 17, 17, 10, 4}},  {'W', {17, 17, 17, 21, 21, 21, 10}},
  };
  for (const G& g : kFont)
    if (g.c == c) return g.rows;
  return nullptr;  // drawn as a space
}

struct Canvas {
  Image& img;
  void put(int x, int y, Rgb c) {
    if (x < 0 || y < 0 || x >= img.width || y >= img.height) return;
    size_t i = (size_t(y) * size_t(img.width) + size_t(x)) * 3;
    img.rgb[i] = c.r, img.rgb[i + 1] = c.g, img.rgb[i + 2] = c.b;
  }
  void fill(int x0, int y0, int w, int h, Rgb c) {
    for (int y = y0; y < y0 + h; ++y)
      for (int x = x0; x < x0 + w; ++x) put(x, y, c);
  }
  void text(int x, int y, const std::string& s, Rgb c) {
    for (char ch : s) {
      if (const uint8_t* rows = glyph(ch))
        for (int r = 0; r < 7; ++r)
          for (int col = 0; col < 5; ++col)
            if (rows[r] & (16 >> col)) fill(x + col * kTextScale, y + r * kTextScale, kTextScale, kTextScale, c);
      x += kGlyphW;
    }
  }
  // A square pen of side 2*r+1 along the segment, clipped to the box [x0, x1) x [y0, y1).
  void line(double ax, double ay, double bx, double by, int r, Rgb c, int x0, int y0, int x1, int y1) {
    const int steps = int(std::ceil(std::max(std::abs(bx - ax), std::abs(by - ay)))) + 1;
    if (!(steps > 0) || steps > (1 << 20)) return;  // NaN or far off the image
    for (int k = 0; k <= steps; ++k) {
      const double t = double(k) / steps;
      const int x = int(std::floor(ax + (bx - ax) * t)), y = int(std::floor(ay + (by - ay) * t));
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx)
          if (x + dx >= x0 && x + dx < x1 && y + dy >= y0 && y + dy < y1) put(x + dx, y + dy, c);
    }
  }
};

std::string number_label(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

}  // namespace

PictureLayout picture_layout(const ReceiverGrid& grid, int scale) {
  scale = std::max(1, scale);
  PictureLayout l;
  l.grid_x = kPad, l.grid_y = kPad;
  l.grid_w = grid.nu * scale, l.grid_h = grid.nv * scale;
  // Colour bar right of the grid: title "FRACTION" above, tick labels right of it.
  l.bar_w = 20;
  l.bar_x = l.grid_x + l.grid_w + 3 * kPad;
  l.bar_y = l.grid_y + kGlyphH + 8;
  l.bar_h = std::max(128, std::min(l.grid_h - kGlyphH - 8, 512));
  // The diff legend below the bar: two swatches with their labels.
  l.marks_y = l.bar_y + l.bar_h + kPad;
  // Scale bar below the grid: a round length (1, 2 or 5 times a power of ten) of at most
  // a quarter of the grid's u side.
  const double u_len = length(to_double(grid.u));
  if (u_len > 0 && std::isfinite(u_len)) {
    double p = std::pow(10.0, std::floor(std::log10(u_len / 4)));
    l.scale_length = p;
    for (double m : {2.0, 5.0})
      if (m * p <= u_len / 4) l.scale_length = m * p;
    l.scale_w = std::max(1, int(std::lround(l.scale_length / u_len * l.grid_w)));
  }
  l.scale_x = l.grid_x;
  l.scale_y = l.grid_y + l.grid_h + kPad;
  l.width = l.bar_x + l.bar_w + 8 + 9 * kGlyphW + kPad;  // room for "BELOW TAU" beside a swatch
  l.width = std::max(l.width, l.bar_x + l.bar_w + 8 + 3 * kGlyphW + kPad);
  l.height = std::max(l.scale_y + 3 + 8 + kGlyphH + kPad, l.marks_y + 2 * (kGlyphH + 8) + kPad);
  return l;
}

Image render_picture(const ReceiverGrid& grid, const Picture& p, int scale) {
  scale = std::max(1, scale);
  const size_t n = size_t(grid.nu) * size_t(grid.nv);
  VG_CHECK(p.fraction.size() == n && (p.diff.empty() || p.diff.size() == n));
  const PictureLayout l = picture_layout(grid, scale);
  Image img;
  img.width = l.width, img.height = l.height;
  img.rgb.assign(size_t(img.width) * size_t(img.height) * 3, 0);
  Canvas cv{img};
  cv.fill(0, 0, img.width, img.height, kBackground);

  // The receivers, +v up; marks inset by a quarter block so the fraction stays visible
  // around them (whole blocks below 4 pixels per receiver).
  const int inset = scale >= 4 ? scale / 4 : 0;
  for (int b = 0; b < grid.nv; ++b)
    for (int a = 0; a < grid.nu; ++a) {
      const size_t i = size_t(b) * size_t(grid.nu) + size_t(a);
      const int x = l.grid_x + a * scale, y = l.grid_y + (grid.nv - 1 - b) * scale;
      cv.fill(x, y, scale, scale, viridis(p.fraction[i]));
      if (p.diff.empty() || (!p.diff[i].mismatches && !p.diff[i].below_tau)) continue;
      cv.fill(x + inset, y + inset, scale - 2 * inset, scale - 2 * inset,
              p.diff[i].mismatches ? kMismatchColor : kBelowTauColor);
    }

  // The lights' outlines: each vertex projected along the grid normal, as grid
  // parameters (s, t) with p - origin = s u + t v + w n (least squares in s, t).
  const Vec3d o = to_double(grid.origin), u = to_double(grid.u), v = to_double(grid.v);
  const double uu = dot(u, u), uv = dot(u, v), vv = dot(v, v), det = uu * vv - uv * uv;
  if (det > 0)
    for (const auto& poly : p.lights) {
      std::vector<std::pair<double, double>> px;
      for (const Vec3f& q : poly) {
        const Vec3d d = to_double(q) - o;
        const double du = dot(d, u), dv = dot(d, v);
        const double s = (du * vv - dv * uv) / det, t = (dv * uu - du * uv) / det;
        px.push_back({l.grid_x + s * l.grid_w, l.grid_y + (1.0 - t) * l.grid_h});
      }
      for (int pass = 0; pass < 2; ++pass)  // black rim, then white
        for (size_t k = 0; k < px.size(); ++k) {
          const auto& [ax, ay] = px[k];
          const auto& [bx, by] = px[(k + 1) % px.size()];
          cv.line(ax, ay, bx, by, pass == 0 ? 1 : 0, pass == 0 ? kInk : kOutline, l.grid_x, l.grid_y,
                  l.grid_x + l.grid_w, l.grid_y + l.grid_h);
        }
    }

  // Legend: the colour bar (1 at the top) with ticks 0, 0.5 and 1.
  cv.text(l.bar_x, l.grid_y, "FRACTION", kInk);
  for (int y = 0; y < l.bar_h; ++y) cv.fill(l.bar_x, l.bar_y + y, l.bar_w, 1, viridis(1.0 - double(y) / (l.bar_h - 1)));
  for (double tick : {0.0, 0.5, 1.0}) {
    const int y = l.bar_y + int(std::lround((1.0 - tick) * (l.bar_h - 1)));
    cv.fill(l.bar_x - 5, y, 4, 1, kInk);  // left of the bar, so "1" does not read "-1"
    cv.text(l.bar_x + l.bar_w + 6, y - kGlyphH / 2 + 1, number_label(tick), kInk);
  }
  if (!p.diff.empty()) {
    cv.fill(l.bar_x, l.marks_y, l.bar_w, kGlyphH - 2, kMismatchColor);
    cv.text(l.bar_x + l.bar_w + 8, l.marks_y, "MISMATCH", kInk);
    cv.fill(l.bar_x, l.marks_y + kGlyphH + 8, l.bar_w, kGlyphH - 2, kBelowTauColor);
    cv.text(l.bar_x + l.bar_w + 8, l.marks_y + kGlyphH + 8, "BELOW TAU", kInk);
  }
  // Scale bar with end ticks and its length in scene units.
  if (l.scale_w > 0) {
    cv.fill(l.scale_x, l.scale_y, l.scale_w, 3, kInk);
    cv.fill(l.scale_x, l.scale_y - 4, 1, 7, kInk);
    cv.fill(l.scale_x + l.scale_w - 1, l.scale_y - 4, 1, 7, kInk);
    cv.text(l.scale_x, l.scale_y + 8, number_label(l.scale_length), kInk);
  }
  return img;
}

}  // namespace visgate::bench
