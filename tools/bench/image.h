// Receiver-grid images for `visgate render`: per-receiver visible fractions and
// method-versus-oracle disagreement maps, written as PNG through stb_image_write.
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

// Colours of the diff map: a receiver with a mismatch is red (brighter with a larger
// share of its relations), one with only below-tau disagreements blue, any other the
// exact fraction in dim gray (at most 40% brightness) so the scene stays readable.
extern const Rgb kMismatchColor, kBelowTauColor;
std::vector<Rgb> diff_colors(const std::vector<ReceiverDiff>& diff, const std::vector<double>& exact_fraction,
                             size_t relations_per_receiver);

}  // namespace visgate::bench
