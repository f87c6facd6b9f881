#include "lib/core/spatial_order.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <utility>

namespace meshgauge {
namespace {

// The low 21 bits of v spread to every third bit.
uint64_t Spread(uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffull;
  v = (v | v << 16) & 0x1f0000ff0000ffull;
  v = (v | v << 8) & 0x100f00f00f00f00full;
  v = (v | v << 4) & 0x10c30c30c30c30c3ull;
  v = (v | v << 2) & 0x1249249249249249ull;
  return v;
}

}  // namespace

std::vector<int32_t> MortonOrder(absl::Span<const Vec3> points) {
  Vec3 lo = points.empty() ? Vec3() : points[0], hi = lo;
  for (const Vec3& p : points) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  constexpr double kCells = (1 << 21) - 1;
  auto cell = [&](double v, double a, double b) {
    return b > a ? static_cast<uint64_t>((v - a) / (b - a) * kCells) : 0;
  };
  // Keys are unique (the index breaks ties): one order for any thread count.
  std::vector<std::pair<uint64_t, int32_t>> keyed(points.size());
  tbb::parallel_for(size_t{0}, points.size(), [&](size_t i) {
    const Vec3& p = points[i];
    keyed[i] = {Spread(cell(p.x, lo.x, hi.x)) |
                    Spread(cell(p.y, lo.y, hi.y)) << 1 |
                    Spread(cell(p.z, lo.z, hi.z)) << 2,
                static_cast<int32_t>(i)};
  });
  tbb::parallel_sort(keyed.begin(), keyed.end());
  std::vector<int32_t> order(points.size());
  for (size_t i = 0; i < keyed.size(); ++i) order[i] = keyed[i].second;
  return order;
}

}  // namespace meshgauge
