// Central finite-difference verification of the SDF Jacobian (SPEC §6):
// perturb one coordinate of one vertex by +-step (1e-7 x bbox diagonal),
// recompute, and compare dSDF_p/dx_j for every vertex p whose hit primitives
// and kept set are identical at x, x+step and x-step.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "lib/sdf.h"
#include "lib/sensitivity.h"

namespace meshgauge::testing {

struct FdReport {
  int64_t samples = 0;  // (p, j, coordinate) triples with a nonzero entry.
  int64_t clean = 0;    // of those, with identical hits and kept sets.
  int64_t passed = 0;   // of those, relative error <= 1e-5.
  double worst = 0;     // largest relative error among clean samples.
  int64_t vjp_checks = 0, vjp_passed = 0;
};

// Relative error, with the magnitude floored at 1e-2: derivatives of a
// length by a length are O(1), and central differences in double with step
// 1e-7 x diagonal carry a round-off of about eps * SDF * (conditioning) /
// step, measured up to 2.4e-8 on grazing hits (torus). Entries below 1% of
// the O(1) scale are therefore compared to 1e-7 absolutely; all others to
// 1e-5 relatively (docs/sensitivities.md).
inline double RelativeError(double fd, double an) {
  return std::abs(fd - an) / std::max({std::abs(an), std::abs(fd), 1e-2});
}

struct Snapshot {
  std::vector<double> values;
  std::vector<int32_t> prims;
  std::vector<uint8_t> kept;
  HitTable hits;
};

inline Snapshot Take(SdfEvaluator& ev, const SdfParams& params) {
  HitTable hits;
  auto r = ev.Compute(params, {}, &hits);
  EXPECT_TRUE(r.ok()) << r.status();
  Snapshot s{r->values, hits.primitives, hits.kept, {}};
  s.hits = std::move(hits);
  return s;
}

inline bool SameRow(const Snapshot& a, const Snapshot& b, int64_t p, size_t k) {
  return std::equal(a.prims.begin() + p * k, a.prims.begin() + (p + 1) * k,
                    b.prims.begin() + p * k) &&
         std::equal(a.kept.begin() + p * k, a.kept.begin() + (p + 1) * k,
                    b.kept.begin() + p * k);
}

// Checks `columns` vertices (spread evenly over the mesh) in every coordinate;
// also checks the VJP for a fixed pseudo-random g against sum_p g_p * FD_p
// where every affected vertex is clean. Returns the report; callers assert.
inline FdReport CheckJacobian(const Mesh& mesh, const SdfParams& params,
                              int columns, const std::string& label) {
  FdReport rep;
  auto evr = SdfEvaluator::Create(mesh);
  EXPECT_TRUE(evr.ok()) << evr.status();
  SdfEvaluator& ev = **evr;
  const Snapshot base = Take(ev, params);
  auto jac = ComputeJacobian(ev, base.hits);
  EXPECT_TRUE(jac.ok()) << jac.status();
  const int64_t nv = mesh.num_vertices();
  std::vector<double> g(nv);
  for (int64_t i = 0; i < nv; ++i) g[i] = std::sin(1.0 + 7.3 * i);
  auto vjp = ComputeVjp(ev, base.hits, g);
  EXPECT_TRUE(vjp.ok()) << vjp.status();
  const size_t k = base.hits.cone.size();
  const double step = 1e-7 * BoundingBoxDiagonal(mesh);
  const int dims = mesh.dimension;
  // Row sums vanish (translation invariance).
  for (int64_t p = 0; p < nv; ++p) {
    Vec3 sum, mag;
    for (int64_t e = jac->row_offsets[p]; e < jac->row_offsets[p + 1]; ++e) {
      sum += jac->values[e];
      for (int c = 0; c < 3; ++c) mag[c] += std::abs(jac->values[e][c]);
    }
    for (int c = 0; c < 3; ++c)
      EXPECT_LE(std::abs(sum[c]), 1e-9 * (1 + mag[c])) << p;
  }
  for (int col = 0; col < columns; ++col) {
    const int32_t j = static_cast<int32_t>((col * 7919LL + 13) % nv);
    for (int c = 0; c < dims; ++c) {
      Snapshot plus, minus;
      for (int sign : {+1, -1}) {
        Vec3 x = mesh.positions[j];
        x[c] += sign * step;
        EXPECT_TRUE(
            ev.UpdatePositions(std::vector<int32_t>{j}, std::vector<Vec3>{x})
                .ok());
        (sign > 0 ? plus : minus) = Take(ev, params);
      }
      EXPECT_TRUE(ev.UpdatePositions(std::vector<int32_t>{j},
                                     std::vector<Vec3>{mesh.positions[j]})
                      .ok());
      bool all_clean = true;
      double fd_dot = 0;
      for (int64_t p = 0; p < nv; ++p) {
        double an = 0;
        for (int64_t e = jac->row_offsets[p]; e < jac->row_offsets[p + 1];
             ++e) {
          if (jac->columns[e] == j) an = jac->values[e][c];
        }
        const bool finite = std::isfinite(plus.values[p]) &&
                            std::isfinite(minus.values[p]) &&
                            std::isfinite(base.values[p]);
        const double fd =
            finite ? (plus.values[p] - minus.values[p]) / (2 * step) : 0;
        const bool clean =
            SameRow(base, plus, p, k) && SameRow(base, minus, p, k);
        if (an == 0 && (fd == 0 || !finite)) continue;
        if (clean && finite) fd_dot += g[p] * fd;
        ++rep.samples;
        if (!clean) {
          if (std::getenv("MESHGAUGE_FD_VERBOSE") &&
              rep.samples - rep.clean < 6) {
            const bool prims_same = std::equal(base.prims.begin() + p * k,
                                               base.prims.begin() + (p + 1) * k,
                                               plus.prims.begin() + p * k) &&
                                    std::equal(base.prims.begin() + p * k,
                                               base.prims.begin() + (p + 1) * k,
                                               minus.prims.begin() + p * k);
            std::printf("  unclean p=%lld j=%d c=%d prims_same=%d\n",
                        static_cast<long long>(p), j, c, prims_same);
            for (size_t r = 0; r < k; ++r) {
              const size_t i = p * k + r;
              if (base.prims[i] != plus.prims[i] ||
                  base.prims[i] != minus.prims[i] ||
                  base.kept[i] != plus.kept[i] || base.kept[i] != minus.kept[i])
                std::printf("    ray %zu prim %d/%d/%d kept %d/%d/%d\n", r,
                            base.prims[i], plus.prims[i], minus.prims[i],
                            base.kept[i], plus.kept[i], minus.kept[i]);
            }
          }
          all_clean = false;
          continue;
        }
        ++rep.clean;
        const double err = RelativeError(fd, an);
        rep.worst = std::max(rep.worst, err);
        rep.passed += err <= 1e-5;
        if (err > 1e-5 && std::getenv("MESHGAUGE_FD_VERBOSE")) {
          std::printf("  p=%lld j=%d c=%d an=%.10g fd=%.10g base=%.10g\n",
                      static_cast<long long>(p), j, c, an, fd, base.values[p]);
        }
      }
      if (all_clean) {
        ++rep.vjp_checks;
        rep.vjp_passed += RelativeError(fd_dot, (*vjp)[j][c]) <= 1e-5;
      }
    }
  }
  std::printf(
      "%-28s samples %6lld clean %6lld (%.1f%%) passed %6lld worst rel err "
      "%.2e  vjp %lld/%lld\n",
      label.c_str(), static_cast<long long>(rep.samples),
      static_cast<long long>(rep.clean),
      100.0 * rep.clean / std::max<int64_t>(1, rep.samples),
      static_cast<long long>(rep.passed), rep.worst,
      static_cast<long long>(rep.vjp_passed),
      static_cast<long long>(rep.vjp_checks));
  return rep;
}

inline void ExpectFdAgreement(const FdReport& rep) {
  EXPECT_GT(rep.samples, 0);
  EXPECT_GE(rep.clean, 0.9 * rep.samples) << "too few clean samples";
  EXPECT_EQ(rep.passed, rep.clean) << "worst relative error " << rep.worst;
  EXPECT_GT(rep.vjp_checks, 0);
  EXPECT_EQ(rep.vjp_passed, rep.vjp_checks);
}

}  // namespace meshgauge::testing
