// Receiver-grid images and the PNG writer (see image.h). The one translation unit that
// holds the stb_image_write implementation.
#include "tools/bench/image.h"

#include <algorithm>
#include <cmath>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wcast-align"
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#include <stb_image_write.h>
#pragma GCC diagnostic pop

namespace visgate::bench {

const Rgb kMismatchColor{230, 30, 30};
const Rgb kBelowTauColor{40, 120, 255};

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

std::vector<Rgb> diff_colors(const std::vector<ReceiverDiff>& diff, const std::vector<double>& exact_fraction,
                             size_t relations_per_receiver) {
  VG_CHECK(diff.size() == exact_fraction.size());
  std::vector<Rgb> out(diff.size());
  double per = double(std::max<size_t>(1, relations_per_receiver));
  for (size_t i = 0; i < diff.size(); ++i) {
    if (diff[i].mismatches) {
      // Brightness 0.6..1 with the share of mismatching relations.
      double k = 0.6 + 0.4 * std::min(1.0, double(diff[i].mismatches) / per);
      out[i] = {uint8_t(std::lround(kMismatchColor.r * k)), uint8_t(std::lround(kMismatchColor.g * k)),
                uint8_t(std::lround(kMismatchColor.b * k))};
    } else if (diff[i].below_tau) {
      out[i] = kBelowTauColor;
    } else {
      out[i] = gray(0.4 * exact_fraction[i]);
    }
  }
  return out;
}

}  // namespace visgate::bench
