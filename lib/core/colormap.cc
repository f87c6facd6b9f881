#include "lib/core/colormap.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace meshgauge {
namespace {

// OKLab -> linear sRGB (Ottosson's published matrices).
void OkLabToLinear(double L, double a, double b, double rgb[3]) {
  const double l = std::pow(L + 0.3963377774 * a + 0.2158037573 * b, 3);
  const double m = std::pow(L - 0.1055613458 * a - 0.0638541728 * b, 3);
  const double s = std::pow(L - 0.0894841775 * a - 1.2914855480 * b, 3);
  rgb[0] = 4.0767416621 * l - 3.3077115913 * m + 0.2309699292 * s;
  rgb[1] = -1.2684380046 * l + 2.6097574011 * m - 0.3413193965 * s;
  rgb[2] = -0.0041960863 * l - 0.7034186147 * m + 1.7076147010 * s;
}

uint8_t Encode(double linear) {
  const double x = std::clamp(linear, 0.0, 1.0);
  const double srgb =
      x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1 / 2.4) - 0.055;
  return static_cast<uint8_t>(std::lround(srgb * 255));
}

double Decode(uint8_t c) {
  const double x = c / 255.0;
  return x <= 0.04045 ? x / 12.92 : std::pow((x + 0.055) / 1.055, 2.4);
}

}  // namespace

Rgb ThicknessColor(double s) {
  if (std::isnan(s)) return kNoValueGrey;
  s = std::clamp(s, 0.0, 1.0);
  const double lightness = 0.30 + 0.63 * s;
  const double hue = (300.0 - 195.0 * s) * std::numbers::pi / 180;
  // Chroma 0.13, reduced (bisection) where the colour would leave sRGB, so
  // that clipping never changes the lightness.
  const double ca = std::cos(hue), sa = std::sin(hue);
  auto in_gamut = [&](double chroma, double rgb[3]) {
    OkLabToLinear(lightness, chroma * ca, chroma * sa, rgb);
    return std::min({rgb[0], rgb[1], rgb[2]}) >= 0 &&
           std::max({rgb[0], rgb[1], rgb[2]}) <= 1;
  };
  double rgb[3];
  double lo = 0, hi = 0.13;
  if (!in_gamut(hi, rgb)) {
    for (int i = 0; i < 30; ++i) {
      const double mid = 0.5 * (lo + hi);
      (in_gamut(mid, rgb) ? lo : hi) = mid;
    }
    in_gamut(lo, rgb);
  }
  return {Encode(rgb[0]), Encode(rgb[1]), Encode(rgb[2])};
}

std::vector<Rgb> ColorsOf(const ColorScale& scale,
                          const std::vector<double>& values) {
  std::vector<Rgb> colors(values.size());
  for (size_t i = 0; i < values.size(); ++i) colors[i] = scale(values[i]);
  return colors;
}

double OkLightness(Rgb c) {
  const double r = Decode(c.r), g = Decode(c.g), b = Decode(c.b);
  const double l =
      std::cbrt(0.4122214708 * r + 0.5363325363 * g + 0.0514459929 * b);
  const double m =
      std::cbrt(0.2119034982 * r + 0.6806995451 * g + 0.1073969566 * b);
  const double s =
      std::cbrt(0.0883024619 * r + 0.2817188376 * g + 0.6299787005 * b);
  return 0.2104542553 * l + 0.7936177850 * m - 0.0040720468 * s;
}

}  // namespace meshgauge
