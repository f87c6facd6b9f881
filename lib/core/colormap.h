// The thickness colour map: perceptually uniform, dark violet (thin) through
// blue and green to light yellow (thick), readable in grey and by the
// common colour-vision deficiencies. Built in the OKLab space: lightness
// rises linearly from 0.30 to 0.93 while the hue turns from 300 to 105
// degrees at chroma 0.13 (less where sRGB cannot show it), so equal steps of
// the value are close to equal perceived steps (no false edges) and lightness
// alone orders them.
#pragma once

#include "lib/core/image.h"

namespace meshgauge {

// The colour of s in [0, 1] (clamped; NaN gives kNoValueGrey).
Rgb ThicknessColor(double s);

// Faces whose thickness is unknown (a vertex without a value).
inline constexpr Rgb kNoValueGrey = {150, 150, 150};
// Outlines of thin regions and the t_min mark (no colour of the map is red).
inline constexpr Rgb kThinOutline = {230, 20, 20};

// Maps a thickness to [0, 1] over [lo, hi] (values outside are clamped).
struct ColorScale {
  double lo = 0, hi = 1;
  double Position(double t) const {
    return hi > lo ? (t - lo) / (hi - lo) : 0.5;
  }
  Rgb operator()(double t) const { return ThicknessColor(Position(t)); }
};

// OKLab lightness (0..1) of an sRGB colour; used to check the map.
double OkLightness(Rgb c);

}  // namespace meshgauge
