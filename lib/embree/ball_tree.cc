#include "lib/embree/ball_tree.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <utility>
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
struct Inner : Node {
  int count;
  Box box[kArity];
  const Node* child[kArity];
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
  return n;
}

void SetChildren(void* node, void** children, unsigned int count, void*) {
  auto* n = static_cast<Inner*>(node);
  n->count = static_cast<int>(count);
  for (unsigned i = 0; i < count; ++i) {
    n->child[i] = static_cast<const Node*>(children[i]);
  }
}

void SetBounds(void* node, const RTCBounds** bounds, unsigned int count,
               void*) {
  auto* n = static_cast<Inner*>(node);
  for (unsigned i = 0; i < count; ++i) {
    n->box[i].lo =
        Vec3(bounds[i]->lower_x, bounds[i]->lower_y, bounds[i]->lower_z);
    n->box[i].hi =
        Vec3(bounds[i]->upper_x, bounds[i]->upper_y, bounds[i]->upper_z);
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

// True when the box lies strictly outside the contact cone at x: every
// corner beyond the separating plane towards the box's centre.
bool OutsideCone(const Box& b, const Vec3& x, const ContactCone& cone) {
  const Vec3 w = (b.lo + b.hi) * 0.5 - x;
  const double along = Dot(cone.axis, w);
  // A box whose centre is in the cone is not outside it.
  if (along >= 0 &&
      along * along >= cone.cos_beta * cone.cos_beta * Dot(w, w)) {
    return false;
  }
  Vec3 nu;
  if (!SeparatingNormal(cone, w, &nu)) return false;
  // The corner least far along nu; every corner is within
  // sqrt(3) (MaxAbs(w) + MaxAbs(extent)) of x.
  const Vec3 corner(nu.x >= 0 ? b.lo.x : b.hi.x, nu.y >= 0 ? b.lo.y : b.hi.y,
                    nu.z >= 0 ? b.lo.z : b.hi.z);
  return BeyondCone(cone, nu, corner - x,
                    1.75 * (MaxAbs(w) + MaxAbs(b.hi - b.lo)));
}

}  // namespace

absl::StatusOr<std::unique_ptr<BallTree>> BallTree::Create(
    const Mesh& mesh, const MeshTopology& topo) {
  std::unique_ptr<BallTree> tree(new BallTree());
  const int64_t n = std::ssize(topo.primitives);
  std::vector<RTCBuildPrimitive> prims(n);
  for (int64_t i = 0; i < n; ++i) {
    const Primitive& p = topo.primitives[i];
    Box box;
    for (int j = 0; j < 3 && p.v[j] >= 0; ++j) {
      box.Extend(mesh.positions[p.v[j]], mesh.positions[p.v[j]]);
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
  args.buildQuality = RTC_BUILD_QUALITY_MEDIUM;
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

void BallTree::Visit(const Vec3& x, const ContactCone& cone, double radius,
                     absl::FunctionRef<double(int32_t prim)> visit) const {
  if (root_ == nullptr) return;
  const Vec3& axis = cone.axis;
  // Boxes hold single-precision bounds rounded outward; the slack covers
  // the rounding of the distances computed here.
  auto may_hold = [&](const Box& b, double r, double* d2) {
    const Vec3 centre = x + axis * r;
    *d2 = DistanceSquared(b, centre);
    const double reach = r * (1 + 1e-12) + 1e-12 * MaxAbs(centre);
    return *d2 <= reach * reach && !OutsideCone(b, x, cone);
  };
  double r = radius;
  // Boxes are tested when pushed and again when popped if the ball has
  // shrunk since.
  struct Entry {
    const Node* node;
    const Box* box;  // null for the root.
    double r;        // the radius it was tested with.
  };
  thread_local std::vector<Entry> stack;
  stack.clear();
  stack.push_back({static_cast<const Node*>(root_), nullptr, r});
  while (!stack.empty()) {
    const Entry e = stack.back();
    stack.pop_back();
    double d2;
    if (e.r != r && e.box != nullptr && !may_hold(*e.box, r, &d2)) continue;
    if (e.node->leaf) {
      const auto* leaf = static_cast<const Leaf*>(e.node);
      for (uint32_t i = 0; i < leaf->count; ++i) r = visit(leaf->prims()[i]);
      continue;
    }
    const auto* inner = static_cast<const Inner*>(e.node);
    // The children that may hold a point, nearest pushed last (visited
    // first).
    std::pair<double, int> held[kArity];
    int num_held = 0;
    for (int i = 0; i < inner->count; ++i) {
      double dist;
      if (!may_hold(inner->box[i], r, &dist)) continue;
      int k = num_held++;  // insertion, farthest first.
      for (; k > 0 && held[k - 1].first < dist; --k) held[k] = held[k - 1];
      held[k] = {dist, i};
    }
    for (int k = 0; k < num_held; ++k) {
      const int i = held[k].second;
      stack.push_back({inner->child[i], &inner->box[i], r});
    }
  }
}

}  // namespace meshgauge
