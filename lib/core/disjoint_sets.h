// Union-find over dense int32 ids (parent[i] == i for a root), for the
// components of a mesh and its thin regions.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

namespace meshgauge {

// The root of x, halving the path on the way.
inline int32_t FindRoot(std::vector<int32_t>& parent, int32_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

// Joins the sets of a and b; the smaller root id stays the root.
inline void Unite(std::vector<int32_t>& parent, int32_t a, int32_t b) {
  a = FindRoot(parent, a);
  b = FindRoot(parent, b);
  if (a != b) parent[std::max(a, b)] = std::min(a, b);
}

}  // namespace meshgauge
