// Receiver-grid images for `visgate render`: per-receiver visible fractions in a colour
// map with a legend, scale bar and the lights' outlines, and method-versus-oracle
// mismatches marked over them, written as PNG through stb_image_write.
// Receiver (a, b) of a grid (index b*nu + a, DESIGN section 6) is pixel column a and
// row nv-1-b, so +v points up in the image; each receiver is a `scale` x `scale` block.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "lib/base/result.h"
#include "lib/scene/scene.h"
#include "lib/solver.h"

namespace visgate::bench {

struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
};

struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;  // row-major, top row first, 3 bytes per pixel
  Rgb at(int x, int y) const {
    size_t i = (size_t(y) * size_t(width) + size_t(x)) * 3;
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

// Writes an 8-bit RGB PNG; the error names the file.
Status write_png(const std::string& path, const Image& img);

// Gray level of a value in [0, 1] (clamped): round(255 v).
Rgb gray(double v);

// The image of one colour per receiver of `grid` (colors.size() == nu*nv).
Image grid_image(const ReceiverGrid& grid, const std::vector<Rgb>& colors, int scale);
// The smallest scale giving at least `min_side` pixels on the longer side (>= 1).
int auto_scale(const ReceiverGrid& grid, int min_side = 512);

// Per receiver: the sum over lights of the visible fraction divided by the number of
// lights (so 1 is fully lit by every light), from a method's result.
std::vector<double> mean_visible_fraction(const Scene& scene, const SolveResult& result);
// The same from relation classes ('v', 'b', 'd' per relation, light-major): the share
// of visible relations per light, a degenerate relation counting one half (it lies
// exactly on a shadow boundary: neither answer is wrong), averaged over lights.
std::vector<double> mean_class_fraction(const Scene& scene, const std::vector<std::string>& classes);

// Per receiver: relations where the method's bit disagrees with a non-degenerate class,
// split by margin (>= tau: mismatches, DESIGN section 5; < tau: below-tau disagreements).
struct ReceiverDiff {
  size_t mismatches = 0, below_tau = 0;
};
std::vector<ReceiverDiff> diff_receivers(const Scene& scene, const SolveResult& result,
                                         const std::vector<std::string>& classes,
                                         const std::vector<std::vector<double>>& margins, double tau);

// The viridis colour map (matplotlib's; perceptually uniform, readable in gray and by
// colour-blind viewers) at v in [0, 1], clamped, NaN as 0: dark purple (0, fully
// shadowed) through blue and green to yellow (1, fully lit). Linear between the map's
// values at tenths.
Rgb viridis(double v);

// Marks drawn over a receiver's block: a mismatch (margin >= tau, DESIGN section 5) in
// red, only below-tau disagreements in orange; neither colour is in viridis.
extern const Rgb kMismatchColor, kBelowTauColor;

// What `visgate render` draws: the fraction per receiver in viridis with a legend (the
// colour bar, 0 to 1) and a scale bar (a round length along the grid's u side), the
// lights' outlines projected along the grid normal onto the grid's plane (white on a
// black rim) and, when `diff` is given, each receiver's mismatch mark over its block.
struct Picture {
  std::vector<double> fraction;            // per receiver (nu*nv), in [0, 1]
  std::vector<ReceiverDiff> diff;          // empty, or per receiver
  std::vector<std::vector<Vec3f>> lights;  // light polygons, world coordinates
};
// Where the parts of a picture are, in pixels (x right, y down from the top-left).
struct PictureLayout {
  int width = 0, height = 0;
  int grid_x = 0, grid_y = 0, grid_w = 0, grid_h = 0;  // the receivers
  int bar_x = 0, bar_y = 0, bar_w = 0, bar_h = 0;      // colour bar: top row 1, bottom row 0
  int scale_x = 0, scale_y = 0, scale_w = 0;           // scale bar (3 pixels high)
  double scale_length = 0.0;                           // world length the scale bar stands for
  int marks_y = 0;                                     // the diff legend's swatches
};
PictureLayout picture_layout(const ReceiverGrid& grid, int scale);
Image render_picture(const ReceiverGrid& grid, const Picture& p, int scale);

}  // namespace visgate::bench
