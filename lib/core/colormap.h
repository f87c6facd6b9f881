// The thickness colour map: perceptually uniform, dark violet (thin) through
// blue and green to light yellow (thick), readable in grey and by the
// common colour-vision deficiencies. Built in the OKLab space: lightness
// rises linearly from 0.30 to 0.93 while the hue turns from 300 to 105
// degrees at chroma 0.13 (less where sRGB cannot show it), so equal steps of
// the value are close to equal perceived steps (no false edges) and lightness
// alone orders them.
#pragma once

#include <vector>

#include "lib/core/image.h"

namespace meshgauge {

// The colour of s in [0, 1] (clamped; NaN gives kNoValueGrey).
Rgb ThicknessColor(double s);

// Faces whose thickness is unknown (a vertex without a value).
inline constexpr Rgb kNoValueGrey = {150, 150, 150};
// Outlines of thin regions and the t_min mark (no colour of the map is red).
inline constexpr Rgb kThinOutline = {230, 20, 20};

// Values above the colour range when the scale has an overflow colour: a
// light orchid (OKLab L 0.82, hue 340 degrees), a hue the map never takes,
// neither red (the outline) nor grey (no value), and light as the thick end
// so that the picture still reads in grey.
inline constexpr Rgb kOverflowColor = {236, 174, 215};

// Maps a thickness to [0, 1] over [lo, hi]. Values below lo are clamped to
// the thin end; values above hi are clamped to the thick end, or drawn in
// kOverflowColor when `overflow` is set.
struct ColorScale {
  double lo = 0, hi = 1;
  bool overflow = false;
  double Position(double t) const {
    return hi > lo ? (t - lo) / (hi - lo) : 0.5;
  }
  bool Above(double t) const { return overflow && t > hi; }
  Rgb operator()(double t) const {
    return Above(t) ? kOverflowColor : ThicknessColor(Position(t));
  }
};

// The range a thickness report colours by default: [0, 2 t_min], so that
// t_min sits in the middle of the map and the thin values spread over its
// lower half, with values above 2 t_min in kOverflowColor (they are thick
// enough; the whole values' range would squeeze 1, 2 and 6 mm of a part
// reaching 37 mm into the same few colours). t_min > 0.
inline ColorScale CenteredOnTMin(double t_min) {
  return ColorScale{0, 2 * t_min, /*overflow=*/true};
}

// The colours of values by the scale, one per value (per vertex or per
// face alike; NaN: kNoValueGrey).
std::vector<Rgb> ColorsOf(const ColorScale& scale,
                          const std::vector<double>& values);

// OKLab lightness (0..1) of an sRGB colour; used to check the map.
double OkLightness(Rgb c);

}  // namespace meshgauge
