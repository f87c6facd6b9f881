// Central finite-difference verification of the SDF Jacobian (SPEC §6) in
// tests: lib/gradcheck's check on `columns` vertices spread evenly over the
// mesh, printed, with the SPEC criterion as assertions.
#pragma once

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "lib/embree/gradcheck.h"

namespace meshgauge::testing {

inline double RelativeError(double fd, double an) {
  return GradCheckRelativeError(fd, an);
}

// Vertices (col * 7919 + offset) mod #V for col < columns.
inline std::vector<int32_t> SpreadVertices(const Mesh& mesh, int columns,
                                           int offset = 13) {
  std::vector<int32_t> out;
  for (int col = 0; col < columns; ++col) {
    const int32_t j =
        static_cast<int32_t>((col * 7919LL + offset) % mesh.num_vertices());
    if (std::find(out.begin(), out.end(), j) == out.end()) out.push_back(j);
  }
  return out;
}

inline void PrintReport(const GradCheckReport& rep, const std::string& label) {
  const int64_t samples = std::ssize(rep.rows);
  std::printf(
      "%-28s samples %6lld clean %6lld (%.1f%%) passed %6lld worst rel err "
      "%.2e  vjp %lld/%lld  max|dSDF/dx| %.3g median %.3g  world frames "
      "%lld\n",
      label.c_str(), static_cast<long long>(samples),
      static_cast<long long>(rep.clean),
      100.0 * rep.clean / std::max<int64_t>(1, samples),
      static_cast<long long>(rep.passed), rep.worst,
      static_cast<long long>(rep.vjp_passed),
      static_cast<long long>(rep.vjp_checks), rep.max_abs_derivative,
      rep.median_abs_derivative,
      static_cast<long long>(rep.world_frame_vertices));
}

inline GradCheckReport CheckJacobian(const Mesh& mesh, const SdfParams& params,
                                     int columns, const std::string& label,
                                     GradCheckOptions options = {}) {
  if (options.vertices.empty())
    options.vertices = SpreadVertices(mesh, columns);
  auto rep = RunGradCheck(mesh, params, options);
  EXPECT_TRUE(rep.ok()) << rep.status();
  if (!rep.ok()) return {};
  PrintReport(*rep, label);
  return *rep;
}

inline void ExpectFdAgreement(const GradCheckReport& rep) {
  const int64_t samples = std::ssize(rep.rows);
  EXPECT_GT(samples, 0);
  EXPECT_GE(rep.clean, 0.9 * samples) << "too few clean samples";
  EXPECT_EQ(rep.passed, rep.clean) << "worst relative error " << rep.worst;
  EXPECT_GT(rep.vjp_checks, 0);
  EXPECT_EQ(rep.vjp_passed, rep.vjp_checks);
  EXPECT_TRUE(rep.Passed());
}

}  // namespace meshgauge::testing
