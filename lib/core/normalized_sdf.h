// Shapira's normalised SDF (SPEC §5).
#pragma once

#include <vector>

namespace meshgauge {

// N_p = log((SDF_p - min) / (max - min) * 4 + 1) / log 5 over the finite
// values; NaN stays NaN. All finite values equal (max == min): 0.
std::vector<double> NormalizedSdf(const std::vector<double>& values);

}  // namespace meshgauge
