// The pictures of `meshgauge report`: the views sheet (rendered views with
// their names and a colour bar in mesh units with t_min marked) and the
// area histogram, drawn with a built-in 5x7 bitmap font (upper case, digits
// and the punctuation of numbers; other characters are left blank).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "lib/core/colormap.h"
#include "lib/core/image.h"
#include "lib/core/thin_regions.h"
#include "lib/embree/render.h"

namespace meshgauge::cli {

// Text with its top-left corner at (x, y), glyphs scaled by `scale`.
void DrawText(Image& image, int x, int y, std::string_view text, Rgb color,
              int scale);
int TextWidth(std::string_view text, int scale);

// The views in a grid of two columns, each named, and the colour bar of
// `scale` on the right with t_min marked in kThinOutline, a grey swatch for
// faces without a value and, when the scale has an overflow colour, its
// swatch above the bar named `above_label` (e.g. "> 2 T_MIN").
Image ComposeViews(const std::vector<RenderedView>& views,
                   const ColorScale& scale, double t_min,
                   std::string_view above_label = {});

// Bars of the area per bin coloured by the map, the t_min line and a title
// with the share of the whole surface below t_min (thin area / total area).
// `curve`: the measure is a length (2D). When the scale has an overflow
// colour, `above_area` (the measure above scale.hi, which the histogram's
// last bin holds too) is drawn apart, in that colour and named
// `above_label`, right of the bins.
Image DrawHistogram(const AreaHistogram& histogram, const ColorScale& scale,
                    double t_min, double thin_share, bool curve,
                    double above_area = 0, std::string_view above_label = {});

}  // namespace meshgauge::cli
