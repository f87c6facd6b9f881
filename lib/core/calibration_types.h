// Parameters and report of the calibration of SPEC §8 (thesis §3.3.5): the
// SDF (CONE) against the physical thickness (NORMAL_RAY) per vertex, and
// the inscribed ball (SPHERE, SPEC v2 §5b) as a third column. The
// computation is lib/embree/calibration.h; these plain types are shared
// with the wire conversion (a remote report carries no per-vertex arrays).
#pragma once

#include <cstdint>
#include <vector>

#include "lib/core/sdf_types.h"

namespace meshgauge {

struct CalibrationParams {
  double t_min = 0;               // minimum thickness, mesh units, > 0.
  double equal_tolerance = 0.01;  // |SDF - t| <= tol * t counts as equal.
  int bins = 20;                  // histogram bins, 1..1000.
  SdfParams sdf = {};  // cone and ball parameters (method is ignored).
};

struct Histogram {
  double lo = 0, hi = 0;        // common range of both histograms.
  std::vector<int64_t> counts;  // `bins` counts over [lo, hi].
};

struct CalibrationReport {
  std::vector<double> sdf;        // per vertex, CONE; NaN without value.
  std::vector<double> thickness;  // per vertex, NORMAL_RAY; NaN without.
  int64_t compared = 0;           // vertices with both values.
  int64_t lower = 0, equal = 0, higher = 0;  // SDF vs thickness.
  double alpha1 = 0;                         // max(thickness) / t_min.
  double alpha2 = 0;                         // min(SDF) / t_min.
  // The inscribed ball's diameter per vertex (NaN without value), against
  // the thickness: vertices with both, lower / equal / higher, and
  // min(ball) / t_min.
  std::vector<double> ball;
  int64_t ball_compared = 0, ball_lower = 0, ball_equal = 0, ball_higher = 0;
  double ball_alpha = 0;
  // Over one range for the three columns.
  Histogram sdf_histogram, thickness_histogram, ball_histogram;
};

}  // namespace meshgauge
