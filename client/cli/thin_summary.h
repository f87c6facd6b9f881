// The answer to "where is it too thin, and how much of it?" for the CLI:
// one sentence and the JSON of a ThinSurface (report.json's thin regions).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "lib/core/thin_regions.h"

namespace meshgauge::cli {

// 100 * share with 3 significant digits, more where those would round a
// share below 1 up to "100".
std::string Percent(double share);

// "12.4 % of the surface (area 3.1 of 25) is thinner than 1; thinnest 0.42
// at (x, y, z)", plus the share without a value when there is one; `curve`
// says length instead of area.
std::string ThinSentence(const ThinSurface& thin, bool curve);

// t_min, total/thin/missing area, thin_fraction, thinnest {value, vertex,
// point} and regions [{faces, area, min_thickness, min_vertex, min_point,
// centroid, box_min, box_max, speck}] (17 significant digits in the JSON).
nlohmann::json ThinJson(const ThinSurface& thin);

}  // namespace meshgauge::cli
