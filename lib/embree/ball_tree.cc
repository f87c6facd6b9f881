#include "lib/embree/ball_tree.h"

#include <embree3/rtcore.h>
#include <emmintrin.h>  // SSE2: Embree 3 runs on x86-64 only.

#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <vector>

#include "lib/core/inscribed_ball.h"
#include "lib/embree/moved_boxes.h"
#include "lib/embree/ray_hit.h"

namespace meshgauge {
namespace {

struct Node {
  bool leaf;
};
constexpr int kArity = 4;
// The children's boxes relative to the tree's origin, in single precision
// rounded outward, one SIMD lane per child; unused lanes are empty boxes
// (no child: every test rejects them).
struct Inner : Node {
  alignas(16) float lo[3][kArity];
  alignas(16) float hi[3][kArity];
  const Node* child[kArity];
  Box BoxOf(int i) const {
    Box b;
    b.lo = Vec3(lo[0][i], lo[1][i], lo[2][i]);
    b.hi = Vec3(hi[0][i], hi[1][i], hi[2][i]);
    return b;
  }
};
// `count` primitive indices follow the struct in the same allocation.
struct Leaf : Node {
  uint32_t count;
  int32_t* prims() { return reinterpret_cast<int32_t*>(this + 1); }
  const int32_t* prims() const {
    return reinterpret_cast<const int32_t*>(this + 1);
  }
};

void* CreateInner(RTCThreadLocalAllocator alloc, unsigned int, void*) {
  auto* n = new (rtcThreadLocalAlloc(alloc, sizeof(Inner), 16)) Inner();
  n->leaf = false;
  for (int k = 0; k < 3; ++k) {
    for (int i = 0; i < kArity; ++i) {
      n->lo[k][i] = std::numeric_limits<float>::infinity();
      n->hi[k][i] = -std::numeric_limits<float>::infinity();
    }
  }
  return n;
}

void SetChildren(void* node, void** children, unsigned int count, void*) {
  auto* n = static_cast<Inner*>(node);
  for (unsigned i = 0; i < count; ++i) {
    n->child[i] = static_cast<const Node*>(children[i]);
  }
}

void SetBounds(void* node, const RTCBounds** bounds, unsigned int count,
               void*) {
  auto* n = static_cast<Inner*>(node);
  for (unsigned i = 0; i < count; ++i) {
    const RTCBounds& b = *bounds[i];
    n->lo[0][i] = b.lower_x;
    n->lo[1][i] = b.lower_y;
    n->lo[2][i] = b.lower_z;
    n->hi[0][i] = b.upper_x;
    n->hi[1][i] = b.upper_y;
    n->hi[2][i] = b.upper_z;
  }
}

void* CreateLeaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims,
                 size_t count, void*) {
  const size_t bytes = sizeof(Leaf) + count * sizeof(int32_t);
  auto* n = new (rtcThreadLocalAlloc(alloc, bytes, 16)) Leaf();
  n->leaf = true;
  n->count = static_cast<uint32_t>(count);
  for (size_t i = 0; i < count; ++i) {
    n->prims()[i] = static_cast<int32_t>(prims[i].primID);
  }
  return n;
}

float Down(double v) {
  const float f = static_cast<float>(v);
  return f <= v ? f : std::nextafter(f, -std::numeric_limits<float>::max());
}
float Up(double v) {
  const float f = static_cast<float>(v);
  return f >= v ? f : std::nextafter(f, std::numeric_limits<float>::max());
}

// Squared distance from p to the box (0 inside).
double DistanceSquared(const Box& b, const Vec3& p) {
  double d2 = 0;
  for (int i = 0; i < 3; ++i) {
    const double d = std::max({b.lo[i] - p[i], 0.0, p[i] - b.hi[i]});
    d2 += d * d;
  }
  return d2;
}

// True, per child of a node, when its box lies strictly outside the contact
// cone at x: every corner beyond the plane through x that separates the cone
// from the box's centre (a bit per child; four at once, SSE). The
// boxes are first made relative to x in double, so that rounding is
// relative to each box's own reach (|w| + size); the plane is built only
// for boxes whose centre is off the axis by a tenth of that reach (its
// direction across the axis is then good to 1e-5), and a box is culled only
// beyond a margin of 1e-4 of its reach, far above the rounding.
struct ConeLanes {
  float axis[3], cos2, cos_beta, sin_beta, slack;
};

int ChildrenOutsideCone(const Inner& n, const Vec3& x, const ConeLanes& q) {
  const __m128 zero = _mm_setzero_ps();
  const __m128 half = _mm_set1_ps(0.5f);
  const __m128 sign = _mm_set1_ps(-0.0f);
  auto relative = [](const float* v, double origin) {
    const __m128 f = _mm_load_ps(v);
    const __m128d o = _mm_set1_pd(origin);
    const __m128d low = _mm_sub_pd(_mm_cvtps_pd(f), o);
    const __m128d high = _mm_sub_pd(_mm_cvtps_pd(_mm_movehl_ps(f, f)), o);
    return _mm_movelh_ps(_mm_cvtpd_ps(low), _mm_cvtpd_ps(high));
  };
  __m128 lo[3], hi[3], w[3], along = zero, w2 = zero, reach = zero;
  for (int k = 0; k < 3; ++k) {
    lo[k] = relative(n.lo[k], x[k]);
    hi[k] = relative(n.hi[k], x[k]);
    w[k] = _mm_mul_ps(_mm_add_ps(lo[k], hi[k]), half);
    along = _mm_add_ps(along, _mm_mul_ps(_mm_set1_ps(q.axis[k]), w[k]));
    w2 = _mm_add_ps(w2, _mm_mul_ps(w[k], w[k]));
    reach = _mm_max_ps(reach, _mm_andnot_ps(sign, w[k]));
  }
  __m128 size = zero;
  for (int k = 0; k < 3; ++k) {
    size = _mm_max_ps(size, _mm_sub_ps(hi[k], lo[k]));
  }
  reach = _mm_add_ps(reach, size);
  // A box whose centre is in the cone is not outside it.
  const __m128 inside =
      _mm_and_ps(_mm_cmpge_ps(along, zero),
                 _mm_cmpge_ps(_mm_mul_ps(along, along),
                              _mm_mul_ps(_mm_set1_ps(q.cos2), w2)));
  __m128 across[3], len2 = zero;
  for (int k = 0; k < 3; ++k) {
    across[k] = _mm_sub_ps(w[k], _mm_mul_ps(_mm_set1_ps(q.axis[k]), along));
    len2 = _mm_add_ps(len2, _mm_mul_ps(across[k], across[k]));
  }
  const __m128 off_axis = _mm_cmpge_ps(
      len2, _mm_mul_ps(_mm_set1_ps(1e-2f), _mm_mul_ps(reach, reach)));
  const __m128 scale = _mm_div_ps(_mm_set1_ps(q.cos_beta), _mm_sqrt_ps(len2));
  __m128 beyond = zero;
  for (int k = 0; k < 3; ++k) {
    const __m128 nu = _mm_sub_ps(_mm_mul_ps(across[k], scale),
                                 _mm_set1_ps(q.axis[k] * q.sin_beta));
    const __m128 low = _mm_cmpge_ps(nu, zero);  // the least far corner.
    const __m128 corner =
        _mm_or_ps(_mm_and_ps(low, lo[k]), _mm_andnot_ps(low, hi[k]));
    beyond = _mm_add_ps(beyond, _mm_mul_ps(nu, corner));
  }
  const __m128 margin = _mm_mul_ps(_mm_set1_ps(1.75f * q.slack), reach);
  const __m128 outside =
      _mm_andnot_ps(inside, _mm_and_ps(off_axis, _mm_cmpgt_ps(beyond, margin)));
  return _mm_movemask_ps(outside);
}

// Per child of a node, the squared distance (single precision) from the
// point `centre` (relative to the tree's origin) to its box.
__m128 BoxDistances2(const Inner& n, const Vec3& centre) {
  const __m128 zero = _mm_setzero_ps();
  __m128 d2 = zero;
  for (int k = 0; k < 3; ++k) {
    const __m128 c = _mm_set1_ps(static_cast<float>(centre[k]));
    const __m128 d =
        _mm_max_ps(_mm_max_ps(_mm_sub_ps(_mm_load_ps(n.lo[k]), c), zero),
                   _mm_sub_ps(c, _mm_load_ps(n.hi[k])));
    d2 = _mm_add_ps(d2, _mm_mul_ps(d, d));
  }
  return d2;
}

// The ball's test for the four children of a node at once, in single
// precision (SSE), with a margin (relative 1e-6 of the radius and of the
// coordinates) far above its rounding, so that it keeps every box the
// double-precision test keeps: a bit per child that may hold a point of
// the ball. `key_out` receives, per child, rho (the radius of the ball
// tangent at x through a point) of the box's point nearest the ball's
// centre, +infinity on or behind the tangent plane: the order of the search,
// not a bound (a smaller ball is likelier in a box with a smaller key).
int ChildrenInBall(const Inner& n, const Vec3& x, const Vec3& axis, double r,
                   float abs_margin, float key_out[kArity]) {
  const __m128 zero = _mm_setzero_ps();
  const Vec3 centre = x + axis * r;
  const __m128 d2 = BoxDistances2(n, centre);
  __m128 along = zero, w2 = zero;
  for (int k = 0; k < 3; ++k) {
    const __m128 c = _mm_set1_ps(static_cast<float>(centre[k]));
    const __m128 lo = _mm_load_ps(n.lo[k]);
    const __m128 hi = _mm_load_ps(n.hi[k]);
    const __m128 w = _mm_sub_ps(_mm_min_ps(_mm_max_ps(c, lo), hi),
                                _mm_set1_ps(static_cast<float>(x[k])));
    along = _mm_add_ps(along,
                       _mm_mul_ps(w, _mm_set1_ps(static_cast<float>(axis[k]))));
    w2 = _mm_add_ps(w2, _mm_mul_ps(w, w));
  }
  const __m128 front = _mm_cmpgt_ps(along, zero);
  const __m128 rho = _mm_div_ps(w2, _mm_add_ps(along, along));
  _mm_storeu_ps(
      key_out,
      _mm_or_ps(
          _mm_and_ps(front, rho),
          _mm_andnot_ps(front,
                        _mm_set1_ps(std::numeric_limits<float>::infinity()))));
  const float reach = static_cast<float>(r * (1 + 4e-6) + abs_margin);
  return _mm_movemask_ps(_mm_cmple_ps(d2, _mm_set1_ps(reach * reach)));
}

}  // namespace

absl::StatusOr<std::unique_ptr<BallTree>> BallTree::Create(
    const Mesh& mesh, const MeshTopology& topo, Build build) {
  std::unique_ptr<BallTree> tree(new BallTree());
  // Boxes relative to the mesh's centre keep single precision close.
  Box all;
  for (const Vec3& p : mesh.positions) all.Extend(p, p);
  tree->origin_ = mesh.positions.empty() ? Vec3() : (all.lo + all.hi) * 0.5;
  for (const Vec3& p : mesh.positions) {
    tree->reach_ = std::max(tree->reach_, MaxAbs(p - tree->origin_));
  }
  const int64_t n = std::ssize(topo.primitives);
  std::vector<RTCBuildPrimitive> prims(n);
  for (int64_t i = 0; i < n; ++i) {
    const Primitive& p = topo.primitives[i];
    Box box;
    for (int j = 0; j < 3 && p.v[j] >= 0; ++j) {
      const Vec3 v = mesh.positions[p.v[j]] - tree->origin_;
      box.Extend(v, v);
    }
    RTCBuildPrimitive& b = prims[i];
    b.lower_x = Down(box.lo.x);
    b.lower_y = Down(box.lo.y);
    b.lower_z = Down(box.lo.z);
    b.upper_x = Up(box.hi.x);
    b.upper_y = Up(box.hi.y);
    b.upper_z = Up(box.hi.z);
    b.geomID = 0;
    b.primID = static_cast<unsigned>(i);
  }
  RTCDevice device = SharedDevice();
  if (!device) return absl::InternalError("rtcNewDevice failed");
  tree->bvh_ = rtcNewBVH(device);
  RTCBuildArguments args = rtcDefaultBuildArguments();
  args.buildQuality =
      build == Build::kSah ? RTC_BUILD_QUALITY_MEDIUM : RTC_BUILD_QUALITY_LOW;
  args.maxBranchingFactor = kArity;
  args.maxLeafSize = 4;
  args.bvh = tree->bvh_;
  args.primitives = prims.data();
  args.primitiveCount = prims.size();
  args.primitiveArrayCapacity = prims.size();
  args.createNode = CreateInner;
  args.setNodeChildren = SetChildren;
  args.setNodeBounds = SetBounds;
  args.createLeaf = CreateLeaf;
  tree->root_ = n > 0 ? rtcBuildBVH(&args) : nullptr;
  if (n > 0 && tree->root_ == nullptr) {
    return absl::InternalError("rtcBuildBVH failed");
  }
  return tree;
}

BallTree::~BallTree() {
  if (bvh_) rtcReleaseBVH(bvh_);
}

void BallTree::Visit(const Vec3& x_world, const ContactCone& cone,
                     double radius,
                     absl::FunctionRef<double(int32_t prim)> visit,
                     double near_radius) const {
  if (root_ == nullptr) return;
  const Vec3 x = x_world - origin_;
  const Vec3& axis = cone.axis;
  // A popped child whose ball shrank since it was pushed is tested against
  // the smaller ball again, in double precision (its cone test does not
  // depend on the radius): boxes hold single-precision bounds rounded
  // outward; the slack covers the rounding of the distances computed here.
  auto in_ball = [&](const Box& b, double r) {
    const Vec3 centre = x + axis * r;
    const double reach = r * (1 + 1e-12) + 1e-12 * MaxAbs(centre);
    return DistanceSquared(b, centre) <= reach * reach;
  };
  // Boxes within near_radius of x: the margin covers the single-precision
  // rounding of x and of the distances (below 1e-6 of the coordinates).
  const bool near_too = near_radius > 0;
  const float near_reach = static_cast<float>(near_radius * (1 + 1e-6) +
                                              1e-6 * (reach_ + MaxAbs(x)));
  const __m128 near_reach2 = _mm_set1_ps(near_reach * near_reach);
  // Single-precision rounding of the ball's centre (relative to the tree's
  // origin) is below 1e-7 of it.
  const float abs_margin = static_cast<float>(1e-6 * (reach_ + MaxAbs(x)));
  ConeLanes lanes;
  for (int k = 0; k < 3; ++k) lanes.axis[k] = static_cast<float>(axis[k]);
  lanes.cos_beta = static_cast<float>(cone.cos_beta);
  lanes.cos2 = static_cast<float>(cone.cos_beta * cone.cos_beta * (1 - 1e-5));
  lanes.sin_beta = static_cast<float>(cone.sin_beta);
  lanes.slack = static_cast<float>(cone.cull_slack + 1e-4);
  double r = radius;
  struct Entry {
    const Node* node;
    const Inner* parent;  // null for the root.
    int lane;             // the node's lane in parent.
    double r;             // the radius it was tested with.
  };
  thread_local std::vector<Entry> stack;
  stack.clear();
  stack.push_back({static_cast<const Node*>(root_), nullptr, 0, r});
  while (!stack.empty()) {
    const Entry e = stack.back();
    stack.pop_back();
    if (e.r != r && e.parent != nullptr &&
        !in_ball(e.parent->BoxOf(e.lane), r) &&
        !(near_too && DistanceSquared(e.parent->BoxOf(e.lane), x) <=
                          static_cast<double>(near_reach) * near_reach)) {
      continue;
    }
    if (e.node->leaf) {
      const auto* leaf = static_cast<const Leaf*>(e.node);
      for (uint32_t i = 0; i < leaf->count && r >= 0; ++i) {
        r = visit(leaf->prims()[i]);
      }
      if (r < 0) return;
      continue;
    }
    // The children that may hold a point, the smallest key on top.
    const auto* inner = static_cast<const Inner*>(e.node);
    float key[kArity];
    const int touched = ChildrenInBall(*inner, x, axis, r, abs_margin, key);
    int held =
        touched == 0 ? 0 : touched & ~ChildrenOutsideCone(*inner, x, lanes);
    if (near_too) {
      held |=
          _mm_movemask_ps(_mm_cmple_ps(BoxDistances2(*inner, x), near_reach2));
    }
    int order[kArity];
    int num_held = 0;
    for (int i = 0; i < kArity; ++i) {
      if (!(held >> i & 1)) continue;
      int k = num_held++;  // insertion, largest key first.
      for (; k > 0 && key[order[k - 1]] < key[i]; --k) order[k] = order[k - 1];
      order[k] = i;
    }
    for (int k = 0; k < num_held; ++k) {
      stack.push_back({inner->child[order[k]], inner, order[k], r});
    }
  }
}

}  // namespace meshgauge
