// Options and report of the finite-difference check of the derivatives
// (SPEC §6 criterion; `meshgauge gradcheck`). The check is
// lib/embree/gradcheck.h; these plain types are shared with the wire
// conversion (a server runs the check for a remote client).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "lib/core/penalty.h"

namespace meshgauge {

struct GradCheckOptions {
  int samples = 12;   // vertices sampled (with a face), >= 1.
  uint64_t seed = 1;  // sampling seed.
  // Explicit vertices to perturb; when not empty, samples and seed are
  // ignored.
  std::vector<int32_t> vertices = {};
  // Also check dP/dx (or dG/dx for the KS form) against central differences.
  std::optional<PenaltyParams> penalty = std::nullopt;
  double relative_step = 1e-7;
  double tolerance = 1e-5;
  double min_clean_fraction = 0.9;
};

enum class GradCheckVerdict { kPass, kFail, kInconclusive };

struct GradCheckRow {
  int32_t row = -1;     // the SDF of this vertex; -1 for the penalty.
  int32_t vertex = -1;  // the vertex moved.
  int coordinate = 0;   // 0, 1, 2 = x, y, z.
  double analytic = 0, fd = 0, relative_error = 0;
  bool clean = false;  // false: an event (hit or kept set changed).
  double step = 0;     // the step of the attempt kept (mesh units).
  // Penalty rows: the explicit element-measure part of `analytic`.
  double measure_part = 0;
};

struct GradCheckReport {
  std::vector<GradCheckRow> rows;          // SDF entries with a nonzero side.
  std::vector<GradCheckRow> penalty_rows;  // one per (vertex, coordinate).
  // One per probe whose entries were all clean at one of its steps (row -1):
  // analytic (g^T J)_j[coordinate] against fd = sum_p g_p fd_p.
  std::vector<GradCheckRow> vjp_rows;
  int64_t clean = 0, passed = 0;
  double worst = 0;  // largest relative error of a clean row.
  int64_t vjp_checks = 0, vjp_passed = 0;  // g^T J against sum_p g_p FD_p.
  int64_t penalty_clean = 0, penalty_passed = 0;
  // Norms |dSDF_p/dx_j| over the Jacobian's nonzero entries.
  double max_abs_derivative = 0, median_abs_derivative = 0;
  int64_t world_frame_vertices = 0;
  double min_clean_fraction = 0.9;
  // Rays traced by all passes (each probe reuses the base pass's rays
  // where the probed vertex cannot change them) and by one full pass.
  int64_t rays_traced = 0, full_pass_rays = 0;

  // Probe repeats with a smaller step (up to 2 per probe) because a sample
  // crossed an event.
  int64_t retried = 0;

  // SPEC §6: every clean sample (and every VJP and clean penalty row)
  // within tolerance, and enough clean samples.
  GradCheckVerdict Verdict() const;
  bool Passed() const { return Verdict() == GradCheckVerdict::kPass; }
};

// |fd - analytic| / max(|analytic|, |fd|, floor). The default floor, 1e-2,
// makes the criterion 1e-7 absolute for small derivatives at the default
// step, above the central difference's round-off (about eps * SDF / step);
// at a step k times smaller the round-off, and the floor, are k times
// larger (GradCheckFloor).
double GradCheckRelativeError(double fd, double analytic, double floor = 1e-2);

// The floor of GradCheckRelativeError for a difference at `step` when the
// check's first step is `first_step`, of a sum of central differences
// weighted by g whose Euclidean norm is `weights_norm` (1 for one entry):
// independent round-off errors add in quadrature.
double GradCheckFloor(double first_step, double step, double weights_norm = 1);

}  // namespace meshgauge
