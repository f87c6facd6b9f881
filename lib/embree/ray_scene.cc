#include "lib/embree/ray_scene.h"

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <vector>

#include "absl/strings/str_cat.h"
#include "lib/embree/fan_filter.h"
#include "lib/embree/hub_fan_geometry.h"
#include "lib/embree/ray_hit.h"

namespace meshgauge {
namespace {

absl::Status DeviceStatus(RTCDevice device, const char* what) {
  const RTCError err = rtcGetDeviceError(device);
  if (err == RTC_ERROR_NONE) return absl::OkStatus();
  return absl::InternalError(
      absl::StrCat("Embree error ", static_cast<int>(err), " in ", what));
}

}  // namespace

absl::StatusOr<std::unique_ptr<RayScene>> RayScene::Create(
    const Mesh& mesh, const MeshTopology& topo, BvhUpdatePolicy policy,
    RayTest test, FanTracing fan_tracing) {
  std::unique_ptr<RayScene> scene(new RayScene(topo, policy, test));
  if (fan_tracing == FanTracing::kHubFans) {
    scene->fans_ = HubFans::Find(topo, mesh.positions.size());
  }
  if (absl::Status s = scene->Init(mesh); !s.ok()) return s;
  return scene;
}

RayScene::~RayScene() {
  if (fan_geometry_) rtcReleaseGeometry(fan_geometry_);
  if (geometry_) rtcReleaseGeometry(geometry_);
  if (scene_) rtcReleaseScene(scene_);
}

namespace {

// Embree's single-precision triangle test multiplies a distance by a
// squared edge length: when span * (longest edge)^2 nears FLT_MAX (3.4e38)
// it overflows and every ray misses (measured: an icosphere of radius 1e13
// and 42 vertices gets no hit, one of 642 vertices gets all), and beyond
// about 1.8e18 Embree asserts, aborting the process. Such meshes are
// refused, and so is a face's vertex farther than kMaxSpan from `origin`
// (SceneOrigin: the coordinates Embree sees are relative to it).
constexpr double kMaxSpanTimesEdgeSquared = 1e38;
constexpr double kMaxSpan = 1e17;

// A single-precision hit on a triangle errs by about its longest edge times
// 2^-24. Where one edge is 2^16 times the typical edge (a stray vertex far
// from the rest, as an attacker's update sent) that error exceeds 1/256 of
// a typical edge and the hits, so the values, depend on the BVH: an updated
// session then differed from a fresh upload of the same positions (from a
// vertex 1e4 bounding-box diagonals away on the knight). The test compares
// binary exponents: the squared longest edge's against the median of the
// squared edges' (so "2^16 times" is exact to a factor of 2, and the check is
// one pass with no sort).
constexpr int kMaxEdgeSpreadExponent = 16;

// The median of the binary exponents (ilogb) counted in `histogram`, whose
// index i counts exponent i + kExponentBias.
constexpr int kExponentBias = 1100;
int MedianExponent(const std::vector<int64_t>& histogram, int64_t count) {
  int64_t seen = 0;
  for (size_t i = 0; i < histogram.size(); ++i) {
    seen += histogram[i];
    if (2 * seen >= count) return static_cast<int>(i) - kExponentBias;
  }
  return 0;
}

// What CheckSpan measures of a range of faces; merged exactly (maxima and
// counts), so the faces may be split among threads in any way.
class SpanStats {
 public:
  void Add(const Mesh& mesh, const Vec3& origin, int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      const Face& f = mesh.faces[i];
      for (int k = 0; k < f.size; ++k) {
        const Vec3& p = mesh.positions[f.v[k]];
        const Vec3 e = mesh.positions[f.v[(k + 1) % f.size]] - p;
        const double e2 = Dot(e, e);
        edge2_ = std::max(edge2_, e2);
        reach_ = std::max(reach_, MaxAbs(p - origin));
        if (e2 > 0 && std::isfinite(e2)) {
          ++exponents_[std::ilogb(e2) + kExponentBias];
          ++edges_;
        }
      }
    }
  }
  void Merge(const SpanStats& other) {
    edge2_ = std::max(edge2_, other.edge2_);
    reach_ = std::max(reach_, other.reach_);
    for (size_t i = 0; i < exponents_.size(); ++i) {
      exponents_[i] += other.exponents_[i];
    }
    edges_ += other.edges_;
  }
  double edge2() const { return edge2_; }  // the longest squared edge
  double reach() const { return reach_; }  // the farthest corner (max norm)
  // Finite nonzero squared edges by binary exponent (MedianExponent's).
  const std::vector<int64_t>& exponents() const { return exponents_; }
  int64_t edges() const { return edges_; }

 private:
  double edge2_ = 0, reach_ = 0;
  std::vector<int64_t> exponents_ = std::vector<int64_t>(2 * kExponentBias, 0);
  int64_t edges_ = 0;
};

// `span` is the mesh's bounding-box diagonal. The faces are measured in
// parallel ranges (serial, this was 6 % of a million-vertex mesh's set-up).
absl::Status CheckSpan(const Mesh& mesh, const Vec3& origin, double span) {
  const SpanStats stats = tbb::parallel_reduce(
      tbb::blocked_range<int64_t>(0, mesh.num_faces(), int64_t{1} << 16),
      SpanStats(),
      [&](const tbb::blocked_range<int64_t>& r, SpanStats s) {
        s.Add(mesh, origin, r.begin(), r.end());
        return s;
      },
      [](SpanStats a, const SpanStats& b) {
        a.Merge(b);
        return a;
      });
  double edge2 = stats.edge2();
  const double reach = stats.reach();
  const std::vector<int64_t>& exponents = stats.exponents();
  const int64_t edges = stats.edges();
  if (edges > 0 && std::ilogb(edge2) - MedianExponent(exponents, edges) >
                       2 * kMaxEdgeSpreadExponent) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the longest edge (", std::sqrt(edge2), ") is more than 2^",
        kMaxEdgeSpreadExponent,
        " times the typical (median) edge: single-precision hits on it would "
        "err by more than 1/256 of a typical edge, so values would depend on "
        "the ray tracer's BVH; a vertex far from the rest? (such meshes are "
        "refused at upload and update alike)"));
  }
  if (reach > kMaxSpan) {
    return absl::InvalidArgumentError(absl::StrCat(
        "a face's vertex lies ", reach,
        " from the centroid of the faces' vertices (at most ", kMaxSpan,
        " in single precision): rescale or recentre the mesh"));
  }
  // 2D segments become quads extruded over twice the diagonal.
  if (mesh.dimension == 2) edge2 = std::max(edge2, 4 * (span + 1) * (span + 1));
  if (span <= kMaxSpan && span * edge2 <= kMaxSpanTimesEdgeSquared) {
    return absl::OkStatus();
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "the mesh is too large for single-precision ray tracing (bounding-box "
      "diagonal ",
      span, ", longest edge ", std::sqrt(edge2),
      "; diagonal x edge^2 must stay below ", kMaxSpanTimesEdgeSquared,
      "): rescale the mesh"));
}

// A power of two at or above `x` (> 0), 1 for x <= 0.
double PowerOfTwoAbove(double x) {
  return x > 0 ? std::exp2(std::ceil(std::log2(x))) : 1.0;
}

// SceneOrigin for a mesh of this bounding-box diagonal.
Vec3 OriginOf(const Mesh& mesh, double diagonal) {
  std::vector<uint8_t> used(mesh.positions.size(), 0);
  for (const Face& f : mesh.faces) {
    for (int k = 0; k < f.size; ++k) used[f.v[k]] = 1;
  }
  Vec3 c;
  int64_t n = 0;
  for (size_t i = 0; i < used.size(); ++i) {
    if (!used[i]) continue;
    c += mesh.positions[i];
    ++n;
  }
  if (n == 0) return c;
  c = c / n;
  const double q = PowerOfTwoAbove(diagonal);
  return Vec3(std::round(c.x / q) * q, std::round(c.y / q) * q,
              std::round(c.z / q) * q);
}

}  // namespace

Vec3 SceneOrigin(const Mesh& mesh) {
  return OriginOf(mesh, BoundingBoxDiagonal(mesh));
}

absl::Status CheckTraceable(const Mesh& mesh) {
  const double diagonal = BoundingBoxDiagonal(mesh);
  return CheckSpan(mesh, OriginOf(mesh, diagonal), diagonal);
}

absl::Status RayScene::Init(const Mesh& mesh) {
  dimension_ = mesh.dimension;
  device_ = SharedDevice();
  if (!device_) return absl::InternalError("rtcNewDevice failed");
  scene_ = rtcNewScene(device_);
  // ROBUST (RayTest::kWatertight): a ray through a shared edge or vertex
  // (common on symmetric meshes) cannot slip between primitives. DYNAMIC (with
  // LOW quality and a REFIT geometry): without it Embree 3 rebuilds on every
  // commit instead of refitting (measured: 50 ms vs 4 ms for 320k triangles).
  // CONTEXT_FILTER_FUNCTION: IntersectFan's filter.
  int flags = RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION;
  if (test_ == RayTest::kWatertight) flags |= RTC_SCENE_FLAG_ROBUST;
  if (policy_ == BvhUpdatePolicy::kRefit) flags |= RTC_SCENE_FLAG_DYNAMIC;
  rtcSetSceneFlags(scene_, static_cast<RTCSceneFlags>(flags));
  rtcSetSceneBuildQuality(scene_, policy_ == BvhUpdatePolicy::kRefit
                                      ? RTC_BUILD_QUALITY_LOW
                                      : RTC_BUILD_QUALITY_MEDIUM);
  const size_t nv = mesh.positions.size();
  const size_t np = topo_.primitives.size();
  if (dimension_ == 3) {
    geometry_ = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* idx = static_cast<uint32_t*>(
        rtcSetNewGeometryBuffer(geometry_, RTC_BUFFER_TYPE_INDEX, 0,
                                RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), np));
    if (!idx) return DeviceStatus(device_, "index buffer");
    for (size_t i = 0; i < np; ++i) {
      const auto prim = static_cast<int32_t>(i);
      const auto& v = topo_.primitives[i].v;
      if (fans_.Owns(prim)) {
        // A point at a corner other than the hub keeps the primitive's
        // number; Embree's test never reports it.
        const int32_t at = v[0] != fans_.HubOf(prim) ? v[0] : v[1];
        for (int k = 0; k < 3; ++k) idx[3 * i + k] = at;
        continue;
      }
      for (int k = 0; k < 3; ++k) idx[3 * i + k] = v[k];
    }
  } else {
    // Vertex i at z = -H is 2i, at z = +H is 2i + 1.
    geometry_ = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_QUAD);
    auto* idx = static_cast<uint32_t*>(
        rtcSetNewGeometryBuffer(geometry_, RTC_BUFFER_TYPE_INDEX, 0,
                                RTC_FORMAT_UINT4, 4 * sizeof(uint32_t), np));
    if (!idx) return DeviceStatus(device_, "index buffer");
    for (size_t i = 0; i < np; ++i) {
      const uint32_t a = topo_.primitives[i].v[0];
      const uint32_t b = topo_.primitives[i].v[1];
      idx[4 * i + 0] = 2 * a;
      idx[4 * i + 1] = 2 * b;
      idx[4 * i + 2] = 2 * b + 1;
      idx[4 * i + 3] = 2 * a + 1;
    }
  }
  // Embree reads vertex buffers with 16-byte loads: pad one float.
  const size_t num_embree_vertices = dimension_ == 3 ? nv : 2 * nv;
  vertex_buffer_ = static_cast<float*>(rtcSetNewGeometryBuffer(
      geometry_, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
      4 * sizeof(float), num_embree_vertices));
  if (!vertex_buffer_) return DeviceStatus(device_, "vertex buffer");
  if (absl::Status s = FillVertices(mesh); !s.ok()) return s;
  if (policy_ == BvhUpdatePolicy::kRefit) {
    rtcSetGeometryBuildQuality(geometry_, RTC_BUILD_QUALITY_REFIT);
  }
  rtcCommitGeometry(geometry_);
  rtcAttachGeometry(scene_, geometry_);
  if (absl::Status s = AddHubFans(); !s.ok()) return s;
  return Commit();
}

absl::Status RayScene::AddHubFans() {
  if (fans_.empty()) return absl::OkStatus();
  fan_geometry_ = NewHubFanGeometry(device_, &fans_);
  if (!fan_geometry_) return DeviceStatus(device_, "hub fan geometry");
  if (policy_ == BvhUpdatePolicy::kRefit) {
    rtcSetGeometryBuildQuality(fan_geometry_, RTC_BUILD_QUALITY_REFIT);
  }
  rtcCommitGeometry(fan_geometry_);
  rtcAttachGeometry(scene_, fan_geometry_);
  return DeviceStatus(device_, "hub fan geometry");
}

absl::Status RayScene::FillVertices(const Mesh& mesh) {
  const double diagonal = BoundingBoxDiagonal(mesh);
  const Vec3 origin = OriginOf(mesh, diagonal);
  if (absl::Status s = CheckSpan(mesh, origin, diagonal); !s.ok()) return s;
  origin_ = origin;
  // Like the origin, a function of the current positions alone.
  extrude_half_height_ = static_cast<float>(PowerOfTwoAbove(diagonal + 1));
  const size_t nv = mesh.positions.size();
  for (size_t i = 0; i < nv; ++i) {
    const Vec3 p = mesh.positions[i] - origin_;
    if (dimension_ == 3) {
      float* dst = vertex_buffer_ + 4 * i;
      dst[0] = static_cast<float>(p.x);
      dst[1] = static_cast<float>(p.y);
      dst[2] = static_cast<float>(p.z);
      dst[3] = 0;
    } else {
      for (int level = 0; level < 2; ++level) {
        float* dst = vertex_buffer_ + 4 * (2 * i + level);
        dst[0] = static_cast<float>(p.x);
        dst[1] = static_cast<float>(p.y);
        dst[2] = level == 0 ? -extrude_half_height_ : extrude_half_height_;
        dst[3] = 0;
      }
    }
  }
  if (!fans_.empty()) {
    double largest = 0;
    for (size_t i = 0; i < nv; ++i) {
      largest = std::max(largest, MaxAbs(mesh.positions[i] - origin_));
    }
    fans_.Update(vertex_buffer_, largest + diagonal);
  }
  cone_walk_built_ = std::make_unique<std::once_flag>();
  return absl::OkStatus();
}

absl::Status RayScene::Commit() {
  rtcCommitScene(scene_);
  return DeviceStatus(device_, "rtcCommitScene");
}

absl::Status RayScene::UpdatePositions(const Mesh& mesh) {
  if (absl::Status s = FillVertices(mesh); !s.ok()) return s;
  rtcUpdateGeometryBuffer(geometry_, RTC_BUFFER_TYPE_VERTEX, 0);
  rtcCommitGeometry(geometry_);
  if (fan_geometry_) rtcCommitGeometry(fan_geometry_);
  rtcCommitScene(scene_);
  return DeviceStatus(device_, "rtcCommitScene (update)");
}

const ConeWalk& RayScene::cone_walk() const {
  std::call_once(*cone_walk_built_, [this] {
    if (ConeWalk::Supported() && dimension_ == 3 &&
        std::ssize(topo_.primitives) <= ConeWalk::kMaxPrimitives) {
      cone_walk_.Build(vertex_buffer_, topo_.primitives);
    }
  });
  return cone_walk_;
}

namespace {

std::atomic<int64_t> ray_tracer_bytes{0};

bool CountBytes(void*, ssize_t bytes, bool) {
  ray_tracer_bytes.fetch_add(bytes, std::memory_order_relaxed);
  return true;
}

}  // namespace

RTCDevice SharedDevice() {
  static RTCDevice device = [] {
    RTCDevice d = rtcNewDevice(nullptr);
    if (d) rtcSetDeviceMemoryMonitorFunction(d, CountBytes, nullptr);
    return d;
  }();
  return device;
}

int64_t RayTracerBytes() {
  return ray_tracer_bytes.load(std::memory_order_relaxed);
}

namespace {

// A fan's rays in the tracer's coordinates: ray k from `origin` along
// dirs[k] over [start(k), t_far].
struct FanRays {
  Vec3 origin;
  absl::Span<const Vec3> dirs;
  absl::Span<const float> starts;  // empty: every ray from t_near.
  float t_near = 0, t_far = 0;
  float start(size_t k) const { return starts.empty() ? t_near : starts[k]; }
};

// The fan as one coherent stream, out[k] found by ray id k; false, tracing
// nothing, when a ray has a component Embree's streams mishandle
// (StreamMayLoseHits).
bool IntersectStream(RTCScene scene, const FanRays& rays, FanContext& fan,
                     absl::Span<HitCandidates> out) {
  // Reused by the thread's fans: no allocation per fan.
  thread_local std::vector<RTCRayHit> stream;
  stream.resize(rays.dirs.size());
  for (size_t k = 0; k < rays.dirs.size(); ++k) {
    stream[k] =
        MakeRayHit(rays.origin, rays.dirs[k], rays.start(k), rays.t_far);
    if (StreamMayLoseHits(stream[k].ray)) return false;
    stream[k].ray.id = static_cast<unsigned>(k);
  }
  fan.lanes_by_id = true;
  fan.out = out.data();
  fan.rtc.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  rtcIntersect1M(scene, &fan.rtc, stream.data(),
                 static_cast<unsigned>(stream.size()), sizeof(RTCRayHit));
  return true;
}

// The fan in packets of 16 consecutive rays, or one ray at a time without
// native packets.
void IntersectPackets(RTCScene scene, const FanRays& rays, bool packets,
                      FanContext& fan, absl::Span<HitCandidates> out) {
  if (!packets) {
    for (size_t k = 0; k < rays.dirs.size(); ++k) {
      fan.out = &out[k];
      RTCRayHit rh =
          MakeRayHit(rays.origin, rays.dirs[k], rays.start(k), rays.t_far);
      rtcIntersect1(scene, &fan.rtc, &rh);
    }
    return;
  }
  constexpr int kWidth = 16;
  alignas(64) RTCRayHit16 rh;
  alignas(64) int valid[kWidth];
  const size_t n_rays = rays.dirs.size();
  for (size_t first = 0; first < n_rays; first += kWidth) {
    const int n = static_cast<int>(std::min<size_t>(kWidth, n_rays - first));
    for (int j = 0; j < kWidth; ++j) {
      valid[j] = j < n ? -1 : 0;
      const size_t k = first + std::min(j, n - 1);
      SetPacketRay(rh, j, rays.origin, rays.dirs[k], rays.start(k), rays.t_far);
    }
    fan.out = &out[first];
    rtcIntersect16(valid, scene, &fan.rtc, &rh);
  }
}

}  // namespace

RTCRayHit MakeRayHit(const Vec3& origin, const Vec3& dir, float t_near,
                     float t_far) {
  RTCRayHit rh;
  rh.ray.org_x = static_cast<float>(origin.x);
  rh.ray.org_y = static_cast<float>(origin.y);
  rh.ray.org_z = static_cast<float>(origin.z);
  rh.ray.dir_x = static_cast<float>(dir.x);
  rh.ray.dir_y = static_cast<float>(dir.y);
  rh.ray.dir_z = static_cast<float>(dir.z);
  rh.ray.tnear = t_near;
  rh.ray.tfar = t_far;
  rh.ray.time = 0.0f;
  rh.ray.mask = std::numeric_limits<unsigned>::max();
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  return rh;
}

RayScene::Hit RayScene::Intersect(const Vec3& origin, const Vec3& dir,
                                  float t_near, float t_far) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh = MakeRayHit(origin - origin_, dir, t_near, t_far);
  rtcIntersect1(scene_, &ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return {};
  return {static_cast<int32_t>(rh.hit.primID), rh.ray.tfar};
}

Vec3 RayScene::StartFan(const Vec3& origin, const FanLimits& limits,
                        absl::Span<const int32_t> excluded,
                        absl::Span<HitCandidates> out, FanContext* fan) const {
  const Vec3 o = origin - origin_;
  const float reach = static_cast<float>(MaxAbs(o));
  for (HitCandidates& c : out) c.Reset(reach);
  rtcInitIntersectContext(&fan->rtc);
  fan->rtc.filter = FanFilter;
  fan->excluded = excluded;
  fan->t_min = limits.t_min;
  fan->near_below = NearBelow(limits, reach);
  fan->t_far = limits.t_far;
  fan->segments = dimension_ == 2;
  return o;
}

FanTraversal RayScene::IntersectFan(
    const Vec3& origin, absl::Span<const Vec3> dirs, const FanLimits& limits,
    absl::Span<const int32_t> excluded, absl::Span<HitCandidates> out,
    absl::Span<const float> starts, FanTraversal traversal,
    const Vec3* axis) const {
  FanContext fan;
  const Vec3 o = StartFan(origin, limits, excluded, out, &fan);
  const FanRays rays{o, dirs, starts, limits.t_near, limits.t_far};
  // Every scene is on the process's SharedDevice. Where Embree has no
  // streams (built without packets) a fan asked to stream goes in packets;
  // where it has no native 16-wide packets (built without them, or a CPU
  // without AVX-512) packets go one ray at a time.
  static const bool streams =
      rtcGetDeviceProperty(SharedDevice(),
                           RTC_DEVICE_PROPERTY_RAY_STREAM_SUPPORTED) != 0;
  static const bool packets =
      rtcGetDeviceProperty(SharedDevice(),
                           RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) != 0;
  if (traversal == FanTraversal::kCone) {
    if (cone_walk().Intersect(o, dirs, axis, starts, limits.t_near, fan, out)) {
      return FanTraversal::kCone;
    }
    for (HitCandidates& c : out) c.Clear();
  }
  if (traversal != FanTraversal::kPackets && streams &&
      IntersectStream(scene_, rays, fan, out)) {
    return FanTraversal::kStream;
  }
  IntersectPackets(scene_, rays, packets, fan, out);
  return FanTraversal::kPackets;
}

int64_t RayScene::ConeWalkTests(const Vec3& origin, absl::Span<const Vec3> dirs,
                                const FanLimits& limits,
                                absl::Span<const int32_t> excluded,
                                const Vec3& axis,
                                absl::Span<HitCandidates> out) const {
  out = out.first(dirs.size());
  FanContext fan;
  const Vec3 o = StartFan(origin, limits, excluded, out, &fan);
  int64_t tests = 0;
  if (!cone_walk().Intersect(o, dirs, &axis, {}, limits.t_near, fan, out,
                             &tests)) {
    return -1;
  }
  return tests;
}

}  // namespace meshgauge
