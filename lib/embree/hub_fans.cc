#include "lib/embree/hub_fans.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace meshgauge {
namespace {

constexpr int32_t kLeafSize = 4;

// Whether p lies in the box b enlarged by `pad` on every side.
bool Inside(const Box& b, double pad, const Vec3& p) {
  return p.x >= b.lo.x - pad && p.x <= b.hi.x + pad && p.y >= b.lo.y - pad &&
         p.y <= b.hi.y + pad && p.z >= b.lo.z - pad && p.z <= b.hi.z + pad;
}

// How far a neighbour is reported around its corners in the fan, for a ray
// from `reach` (the largest coordinate of its origin) hitting at t: as
// HitCandidates' window, 2^-16 of the coordinates' magnitude, far more
// than single-precision rounding there (about 2^-23 of it).
double NeighbourPad(double reach, double t) { return 0x1p-16 * (reach + t); }

// The next float above t (a float): where a hit whose single-precision
// distance is t can lie in double precision.
double Beyond(double t) {
  return std::nextafter(static_cast<float>(t),
                        std::numeric_limits<float>::infinity());
}

}  // namespace

HubFans HubFans::Find(const MeshTopology& topo, size_t num_vertices) {
  HubFans out;
  const size_t np = topo.primitives.size();
  if (np == 0 || topo.primitives[0].v[2] < 0) return out;  // 2D segments.
  std::vector<int32_t> hub_of(np, -1);
  for (size_t p = 0; p < np; ++p) {
    int hubs = 0;
    for (int32_t v : topo.primitives[p].v) {
      if (topo.PrimitivesOf(v).size() > kHubValence) {
        ++hubs;
        hub_of[p] = v;
      }
    }
    if (hubs != 1) hub_of[p] = -1;
  }
  std::vector<int32_t> fan_of_hub(num_vertices, -1);
  for (size_t p = 0; p < np; ++p) {
    const int32_t h = hub_of[p];
    if (h < 0) continue;
    if (fan_of_hub[h] < 0) {
      fan_of_hub[h] = static_cast<int32_t>(out.fans_.size());
      out.fans_.emplace_back();
      out.fans_.back().hub = h;
    }
    out.fans_[fan_of_hub[h]].prims.push_back(static_cast<int32_t>(p));
  }
  if (out.fans_.empty()) return out;
  // Neighbours: the primitives Embree traces that have a corner in a fan
  // (every primitive around a fan's vertices is then in its tree near them).
  // A primitive of another fan needs no copy: both are traced here.
  std::vector<int32_t> marked(num_vertices, -1), corners;
  std::vector<std::pair<int32_t, int>> neighbours;  // (primitive, corner).
  for (size_t f = 0; f < out.fans_.size(); ++f) {
    Fan& fan = out.fans_[f];
    corners.clear();
    for (int32_t p : fan.prims) {
      for (int32_t v : topo.primitives[p].v) {
        if (marked[v] == static_cast<int32_t>(f)) continue;
        marked[v] = static_cast<int32_t>(f);
        corners.push_back(v);
      }
    }
    neighbours.clear();
    for (int32_t v : corners) {
      for (int32_t q : topo.PrimitivesOf(v)) {
        if (hub_of[q] >= 0) continue;
        const auto& w = topo.primitives[q].v;
        neighbours.emplace_back(q, w[0] == v ? 0 : w[1] == v ? 1 : 2);
      }
    }
    fan.owned = static_cast<int32_t>(fan.prims.size());
    std::sort(neighbours.begin(), neighbours.end());
    std::vector<uint8_t> shared;
    for (const auto& [q, k] : neighbours) {
      if (fan.prims.size() == static_cast<size_t>(fan.owned) ||
          fan.prims.back() != q) {
        fan.prims.push_back(q);
        shared.push_back(0);
      }
      shared.back() |= static_cast<uint8_t>(1 << k);
    }
    fan.prims.shrink_to_fit();
    fan.triangles.resize(fan.prims.size());
    for (size_t i = 0; i < fan.prims.size(); ++i) {
      Triangle& t = fan.triangles[i];
      t.prim = fan.prims[i];
      for (int k = 0; k < 3; ++k) t.v[k] = topo.primitives[t.prim].v[k];
      if (i >= static_cast<size_t>(fan.owned)) {
        t.shared = shared[i - fan.owned];
      }
    }
  }
  out.fans_.shrink_to_fit();
  out.hub_of_ = std::move(hub_of);
  return out;
}

int32_t HubFans::HubOf(int32_t prim) const { return hub_of_[prim]; }

int64_t HubFans::num_owned() const {
  int64_t owned = 0;
  for (const Fan& fan : fans_) owned += fan.owned;
  return owned;
}

int64_t HubFans::EstimateBytes(const Mesh& mesh) {
  if (mesh.dimension != 3) return 0;
  // Primitives per vertex: a quad's (0, 1, 2) and (0, 2, 3).
  std::vector<int32_t> valence(mesh.positions.size(), 0);
  int64_t primitives = 0;
  for (const Face& f : mesh.faces) {
    for (int k = 0; k < f.size; ++k)
      valence[f.v[k]] += f.size == 4 ? 1 + (k % 2 == 0) : 1;
    primitives += f.size == 4 ? 2 : 1;
  }
  // Fan faces (a quad's triangles may have one hub each where the quad has
  // two) and their corners.
  int64_t owned = 0;
  std::vector<uint8_t> in_fan(mesh.positions.size(), 0);
  std::vector<uint8_t> fan_face(mesh.faces.size(), 0);
  for (size_t i = 0; i < mesh.faces.size(); ++i) {
    const Face& f = mesh.faces[i];
    int hubs = 0;
    for (int k = 0; k < f.size; ++k) {
      hubs += valence[f.v[k]] > static_cast<int32_t>(kHubValence);
    }
    if (hubs != 1 && !(f.size == 4 && hubs == 2)) continue;
    fan_face[i] = 1;
    owned += f.size == 4 ? 2 : 1;
    for (int k = 0; k < f.size; ++k) in_fan[f.v[k]] = 1;
  }
  if (owned == 0) return 0;
  int64_t hub_vertices = 0;
  for (int32_t v : valence) {
    hub_vertices += v > static_cast<int32_t>(kHubValence);
  }
  // Neighbours: at most one copy per corner in a fan of every other face.
  int64_t copies = 0;
  for (size_t i = 0; i < mesh.faces.size(); ++i) {
    const Face& f = mesh.faces[i];
    if (fan_face[i]) continue;
    for (int k = 0; k < f.size; ++k)
      copies += in_fan[f.v[k]] * (f.size == 4 ? 2 : 1);
  }
  // Per triangle in a tree: a Triangle, a Node (a tree whose leaves hold 2
  // to 4 triangles has fewer nodes than triangles) and the primitive number;
  // per primitive hub_of_; per hub (a fan at most) its Fan and
  // two more nodes.
  return (owned + copies) *
             static_cast<int64_t>(sizeof(Triangle) + sizeof(Node) +
                                  sizeof(int32_t)) +
         primitives * static_cast<int64_t>(sizeof(int32_t)) +
         hub_vertices * static_cast<int64_t>(sizeof(Fan) + 2 * sizeof(Node));
}

int64_t HubFans::bytes() const {
  int64_t total = static_cast<int64_t>(hub_of_.capacity() * sizeof(int32_t) +
                                       fans_.capacity() * sizeof(Fan));
  for (const Fan& fan : fans_) {
    total += static_cast<int64_t>(fan.prims.capacity() * sizeof(int32_t) +
                                  fan.triangles.capacity() * sizeof(Triangle) +
                                  fan.nodes.capacity() * sizeof(Node));
  }
  return total;
}

void HubFans::Update(const float* vertices, double reach) {
  auto point = [vertices](int32_t v) {
    const float* p = vertices + 4 * static_cast<size_t>(v);
    return Vec3(p[0], p[1], p[2]);
  };
  region_pad_ = NeighbourPad(reach, 0);
  for (Fan& fan : fans_) {
    fan.hub_point = point(fan.hub);
    for (Triangle& t : fan.triangles) {
      for (int k = 0; k < 3; ++k) t.p[k] = point(t.v[k]);
    }
    fan.nodes.clear();
    const auto all = static_cast<int32_t>(fan.triangles.size());
    for (int32_t i = fan.owned; i < all; ++i) {
      Triangle& t = fan.triangles[i];
      t.region = Box();
      for (int k = 0; k < 3; ++k) {
        if (t.shared >> k & 1) t.region.Extend(t.p[k], t.p[k]);
      }
    }
    fan.nodes.reserve(all + 1);  // more than a tree over them needs.
    fan.box = Cover(fan, 0, all).box;
    if (fan.owned == all) {
      Build(fan, 0, all, Split::kByDirection);
      continue;
    }
    // The fan's own triangles apart from its neighbours: the plane test
    // culls the former, the boxes of a tree by position the latter.
    fan.nodes.push_back(Cover(fan, 0, all));
    Build(fan, 0, fan.owned, Split::kByDirection);
    const int32_t right =
        Build(fan, fan.owned, all - fan.owned, Split::kByPosition);
    fan.nodes[0].right = right;
  }
}

HubFans::Node HubFans::Cover(const Fan& fan, int32_t first,
                             int32_t count) const {
  Node node{};
  node.first = first;
  for (int32_t i = first; i < first + count; ++i) {
    const Triangle& t = fan.triangles[i];
    if (t.shared != 0) {
      // A neighbour: only around its region is it reported (the pad
      // bounds every ray's, see Trace); no plane test for the node.
      const Vec3 pad(region_pad_, region_pad_, region_pad_);
      node.box.Extend(t.region.lo - pad, t.region.hi + pad);
      node.neighbours = true;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      node.box.Extend(t.p[k], t.p[k]);
      if (t.v[k] == fan.hub) continue;
      const Vec3 c = t.p[k] - fan.hub_point;
      node.corners.Extend(c, c);
      node.reach = std::max(node.reach, Norm(c));
    }
  }
  return node;
}

int32_t HubFans::Build(Fan& fan, int32_t first, int32_t count, Split split) {
  const auto index = static_cast<int32_t>(fan.nodes.size());
  fan.nodes.push_back(Cover(fan, first, count));
  if (count <= kLeafSize) {
    // In primitive order, whatever the order the last update left.
    std::sort(
        fan.triangles.begin() + first, fan.triangles.begin() + first + count,
        [](const Triangle& a, const Triangle& b) { return a.prim < b.prim; });
    fan.nodes[index].count = count;
    return index;
  }
  // Split at the median of the triangles' directions from the hub (or of
  // their centroids) along the axis where they spread most.
  auto key = [&fan, split](const Triangle& t) {
    const Vec3 c = (t.p[0] + t.p[1] + t.p[2]) * (1.0 / 3);
    if (split == Split::kByPosition) return c;
    const Vec3 r = c - fan.hub_point;
    const double n = Norm(r);
    return n > 0 ? r / n : r;
  };
  Box spread;
  for (int32_t i = first; i < first + count; ++i) {
    const Vec3 k = key(fan.triangles[i]);
    spread.Extend(k, k);
  }
  const Vec3 extent = spread.hi - spread.lo;
  const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0
                   : extent.y >= extent.z                       ? 1
                                                                : 2;
  const int32_t half = count / 2;
  auto begin = fan.triangles.begin() + first;
  std::nth_element(begin, begin + half, begin + count,
                   [&](const Triangle& a, const Triangle& b) {
                     const double ka = key(a)[axis], kb = key(b)[axis];
                     return ka < kb || (ka == kb && a.prim < b.prim);
                   });
  Build(fan, first, half, split);
  const int32_t right = Build(fan, first + half, count - half, split);
  fan.nodes[index].right = right;
  return index;
}

bool HubFans::Hits(const Triangle& tri, const Vec3& o, const Vec3& d,
                   double t_near, double t_far, Hit* hit) const {
  // The Plücker value of edge a -> b: which side of it the ray passes.
  auto side = [&](int a, int b) {
    const bool swap = tri.v[a] > tri.v[b];
    const Vec3& p = tri.p[swap ? b : a];
    const Vec3& q = tri.p[swap ? a : b];
    const double s = Dot(d, Cross(p - o, q - o));
    return swap ? -s : s;
  };
  const double s0 = side(1, 2), s1 = side(2, 0), s2 = side(0, 1);
  if (!((s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0))) {
    return false;
  }
  const double sum = s0 + s1 + s2;
  if (sum == 0) return false;
  const Vec3 normal = Cross(tri.p[1] - tri.p[0], tri.p[2] - tri.p[0]);
  const double den = Dot(normal, d);
  if (den == 0) return false;
  const double t = Dot(normal, tri.p[0] - o) / den;
  // As Embree compares: the single-precision distance against the ray's
  // (single-precision) bounds, so that whether a hit is reported does not
  // depend on whether t_far was reached first by rounding up or down.
  const double t_single = static_cast<float>(t);
  if (!(t_single >= t_near && t_single <= t_far)) return false;
  *hit = {tri.prim, t, s1 / sum, s2 / sum, normal};
  return true;
}

void HubFans::Trace(int f, const Vec3& o, const Vec3& d, double t_near,
                    double t_far, absl::FunctionRef<double(const Hit&)> on_hit,
                    Counts* counts) const {
  const Fan& fan = fans_[f];
  if (fan.nodes.empty()) return;
  // The plane through the ray's line and the hub, by its normal n. A node
  // whose corners all lie on one side of it, by more than rounding, holds
  // no triangle the line meets unless the line passes through the hub; the
  // test is used when the line passes farther than 2^-20 of `scale` (the
  // fan's reach plus the origin's distance from the hub) from the hub.
  const double reach = MaxAbs(o);
  const Vec3 to_hub = fan.hub_point - o;
  const Vec3 n = Cross(d, to_hub);
  const double n_norm = Norm(n);
  const double scale = fan.nodes[0].reach + Norm(to_hub);
  const bool plane = n_norm > 0x1p-20 * Norm(d) * scale;
  // Boxes are tested enlarged by 2^-30 of the scale, well above rounding.
  const double pad = 0x1p-30 * scale;
  Vec3 inverse;
  for (int k = 0; k < 3; ++k) inverse[k] = d[k] != 0 ? 1 / d[k] : 0;
  // Whether the ray may meet a triangle of node i, and where it enters the
  // node's box.
  auto visit = [&](int32_t i, double* entry) __attribute__((always_inline)) {
    const Node& node = fan.nodes[i];
    if (counts) ++counts->nodes;
    if (plane && !node.neighbours) {
      double s_lo = 0, s_hi = 0;
      for (int k = 0; k < 3; ++k) {
        const double a = n[k] * node.corners.lo[k];
        const double b = n[k] * node.corners.hi[k];
        s_lo += std::min(a, b);
        s_hi += std::max(a, b);
      }
      const double margin = 0x1p-20 * n_norm * node.reach;
      if (s_lo > margin || s_hi < -margin) return false;
    }
    double lo = t_near, hi = Beyond(t_far);
    for (int k = 0; k < 3; ++k) {
      const double a = node.box.lo[k] - pad - o[k];
      const double b = node.box.hi[k] + pad - o[k];
      if (d[k] == 0) {
        if (a > 0 || b < 0) return false;
        continue;
      }
      const double ta = a * inverse[k], tb = b * inverse[k];
      lo = std::max(lo, std::min(ta, tb));
      hi = std::min(hi, std::max(ta, tb));
    }
    *entry = lo;
    return lo <= hi;
  };
  // Nearer child first, so that a hit found early (on_hit returns the
  // filter's window) spares the farther boxes.
  struct Pending {
    int32_t node;
    double entry;
  };
  Pending stack[64];
  int depth = 0;
  double entry = 0;
  if (!visit(0, &entry)) return;
  int32_t i = 0;
  while (true) {
    const Node& node = fan.nodes[i];
    if (node.count > 0) {
      for (int32_t j = node.first; j < node.first + node.count; ++j) {
        if (counts) ++counts->triangles;
        const Triangle& tri = fan.triangles[j];
        Hit hit;
        if (Hits(tri, o, d, t_near, t_far, &hit) &&
            (tri.shared == 0 ||
             Inside(tri.region, NeighbourPad(reach, hit.t), o + d * hit.t))) {
          t_far = on_hit(hit);
        }
      }
    } else {
      double entry_left = 0, entry_right = 0;
      const bool left = visit(i + 1, &entry_left);
      const bool right = visit(node.right, &entry_right);
      if (left && right) {
        const bool left_first = entry_left <= entry_right;
        stack[depth++] = left_first ? Pending{node.right, entry_right}
                                    : Pending{i + 1, entry_left};
        i = left_first ? i + 1 : node.right;
        continue;
      }
      if (left || right) {
        i = left ? i + 1 : node.right;
        continue;
      }
    }
    // The next pending node the ray still reaches.
    do {
      if (depth == 0) return;
      --depth;
    } while (stack[depth].entry > Beyond(t_far));
    i = stack[depth].node;
  }
}

}  // namespace meshgauge
