// Helpers shared by the tests.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <string>
#include <vector>

namespace meshgauge::testing {

// True when both hold the same doubles, bit for bit (NaNs and signed zeros
// included).
inline bool SameBits(const std::vector<double>& a,
                     const std::vector<double>& b) {
  return a.size() == b.size() &&
         std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

// ../shared/meshes/NAME as configured at build time.
inline std::string SharedMesh(const std::string& name) {
  return std::string(MESHGAUGE_SHARED_DIR) + "/meshes/" + name;
}

// Closed form D_est(alpha, K) of SPEC §9 for diameter 1, computed here
// independently of lib/: every ray at angle theta has the chord cos(theta);
// the chords go through the median +- kappa sigma filter and the
// 1/max(theta, theta_min) weights.
inline double ClosedFormEstimate(int dimension, double alpha_degrees, int rays,
                                 double kappa = 1.0) {
  const double a = alpha_degrees * std::numbers::pi / 180;
  std::vector<double> theta(rays), chord(rays);
  for (int k = 0; k < rays; ++k) {
    theta[k] = dimension == 2
                   ? std::abs(-a / 2 + a * (k + 0.5) / rays)
                   : std::acos(1 - (k + 0.5) * (1 - std::cos(a / 2)) / rays);
    chord[k] = std::cos(theta[k]);
  }
  std::vector<double> sorted = chord;
  std::sort(sorted.begin(), sorted.end());
  const double median = rays % 2
                            ? sorted[rays / 2]
                            : (sorted[rays / 2 - 1] + sorted[rays / 2]) / 2;
  double mean = 0;
  for (double c : chord) mean += c / rays;
  double var = 0;
  for (double c : chord) var += (c - mean) * (c - mean) / rays;
  const double sigma = std::sqrt(var);
  const double theta_min = a / (2.0 * rays);
  double num = 0, den = 0;
  for (int k = 0; k < rays; ++k) {
    if (std::abs(chord[k] - median) > kappa * sigma + 1e-12 * median) continue;
    const double w = 1 / std::max(theta[k], theta_min);
    num += w * chord[k];
    den += w;
  }
  return num / den;
}

}  // namespace meshgauge::testing
