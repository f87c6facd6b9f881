// An 8-bit RGB raster (row-major, top row first) for rendered pictures.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace meshgauge {

struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
  constexpr bool operator==(const Rgb&) const = default;
};

struct Image {
  Image() = default;
  Image(int w, int h, Rgb fill = {255, 255, 255})
      : width(w), height(h), pixels(static_cast<size_t>(w) * h, fill) {}
  int width = 0, height = 0;
  std::vector<Rgb> pixels;  // width * height.

  Rgb& at(int x, int y) { return pixels[static_cast<size_t>(y) * width + x]; }
  const Rgb& at(int x, int y) const {
    return pixels[static_cast<size_t>(y) * width + x];
  }
  bool contains(int x, int y) const {
    return x >= 0 && y >= 0 && x < width && y < height;
  }
};

}  // namespace meshgauge
