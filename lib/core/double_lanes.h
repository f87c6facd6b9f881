// Vectors of doubles for the kernels that give the scalar code's bits lane
// by lane (hit_batch.cc, exact_sums_rows.cc), and the CPU check that picks
// their AVX build.
#pragma once

namespace meshgauge {

// Four or two doubles (GCC's and clang's vector extension): AVX registers in
// a function built for AVX, SSE2 registers (a pair for four) otherwise.
using V4 = double __attribute__((vector_size(32)));
using V2 = double __attribute__((vector_size(16)));

// Whether this CPU runs functions built with __attribute__((target("avx")));
// false off x86-64. Asked of the CPU once.
inline bool CpuHasAvx() {
#if defined(__x86_64__)
  static const bool has_avx = __builtin_cpu_supports("avx");
  return has_avx;
#else
  return false;
#endif
}

}  // namespace meshgauge
