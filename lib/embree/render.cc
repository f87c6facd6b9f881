#include "lib/embree/render.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "lib/core/box.h"
#include "lib/core/topology.h"
#include "lib/embree/ray_scene.h"

namespace meshgauge {
namespace {

constexpr double kHuge = std::numeric_limits<double>::max();

Box Bounds(const Mesh& mesh) {
  Box b;
  for (const Vec3& p : mesh.positions) b.Extend(p, p);
  return b;
}

Vec3 Center(const Box& box) { return (box.lo + box.hi) * 0.5; }

Rgb Shade(Rgb c, double s) {
  auto f = [s](uint8_t v) {
    return static_cast<uint8_t>(std::lround(std::clamp(v * s, 0.0, 255.0)));
  };
  return {f(c.r), f(c.g), f(c.b)};
}

// The value at barycentric (1 - u - w, u, w) of the triangle's values, NaN
// when one is missing.
double Interpolate(double a, double b, double c, double u, double w) {
  return (1 - u - w) * a + u * b + w * c;
}

// A fresh picture: background, no face, no value.
RenderedView Blank(std::string name, const RenderOptions& options) {
  const size_t n = static_cast<size_t>(options.width) * options.height;
  return {std::move(name), Image(options.width, options.height,
                                 options.background),
          std::vector<int32_t>(n, -1),
          std::vector<double>(n, std::numeric_limits<double>::quiet_NaN())};
}

// Outlines marked regions from outside: an unmarked pixel (a face without
// a mark, a pixel of a marked face whose value is not below `below`, or the
// background) within 2 pixels of a marked one turns kThinOutline, so the
// marked pixels keep their colours (two marked regions that touch in the
// picture are not separated). With `below` finite the outline is the
// contour of the per-pixel values, as smooth as the interpolated field.
void DrawOutlines(const std::vector<int32_t>& outline, double below,
                  RenderedView& view) {
  const int w = view.image.width, h = view.image.height;
  std::vector<int32_t> mark(static_cast<size_t>(w) * h, -1);
  for (size_t i = 0; i < mark.size(); ++i) {
    if (view.face[i] < 0) continue;
    if (!std::isnan(below) && !(view.value[i] < below)) continue;
    mark[i] = outline[view.face[i]];
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const int32_t own = mark[static_cast<size_t>(y) * w + x];
      if (own >= 0) continue;
      bool near = false;
      for (int dy = -2; dy <= 2 && !near; ++dy) {
        for (int dx = -2; dx <= 2 && !near; ++dx) {
          if (dx * dx + dy * dy > 5 || !view.image.contains(x + dx, y + dy)) {
            continue;
          }
          near = mark[static_cast<size_t>(y + dy) * w + x + dx] >= 0;
        }
      }
      if (near) view.image.at(x, y) = kThinOutline;
    }
  }
}

absl::StatusOr<RenderedView> RenderSurface(
    const Mesh& mesh, const MeshTopology& topo, const RayScene& scene,
    const std::vector<double>& values, const ColorScale& scale,
    const View& view, const Box& box, const RenderOptions& options) {
  const Vec3 d = view.direction / Norm(view.direction);
  Vec3 right = Cross(d, view.up);
  if (Norm(right) < 1e-12) {
    return absl::InvalidArgumentError(
        absl::StrCat("view '", view.name, "': up is parallel to direction"));
  }
  right = right / Norm(right);
  const Vec3 up = Cross(right, d);
  // Frame the box's projection: its centre in the middle, 4 % margins.
  double lo_u = kHuge, hi_u = -kHuge, lo_v = kHuge, hi_v = -kHuge;
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 p{corner & 1 ? box.hi.x : box.lo.x,
                 corner & 2 ? box.hi.y : box.lo.y,
                 corner & 4 ? box.hi.z : box.lo.z};
    lo_u = std::min(lo_u, Dot(p, right));
    hi_u = std::max(hi_u, Dot(p, right));
    lo_v = std::min(lo_v, Dot(p, up));
    hi_v = std::max(hi_v, Dot(p, up));
  }
  const int w = options.width, h = options.height;
  const double pixel =
      std::max({(hi_u - lo_u) / w, (hi_v - lo_v) / h, 1e-300}) * 1.08;
  const double radius = Norm(box.hi - box.lo) + 1e-300;
  const Vec3 center = right * (0.5 * (lo_u + hi_u)) +
                      up * (0.5 * (lo_v + hi_v)) + d * Dot(Center(box), d);
  const Vec3 eye = center - d * (2 * radius);
  RenderedView out = Blank(view.name, options);
  const bool per_face = options.samples == SampleSet::kFaces;
  tbb::parallel_for(0, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const Vec3 origin = eye + right * ((x + 0.5 - 0.5 * w) * pixel) +
                          up * ((0.5 * h - y - 0.5) * pixel);
      const RayScene::Hit hit = scene.Intersect(
          origin, d, 0.0f, std::numeric_limits<float>::infinity());
      if (hit.prim < 0) continue;
      const Primitive& prim = topo.primitives[hit.prim];
      const Vec3& a = mesh.positions[prim.v[0]];
      const Vec3 e1 = mesh.positions[prim.v[1]] - a;
      const Vec3 e2 = mesh.positions[prim.v[2]] - a;
      const Vec3 n = Cross(e1, e2);
      const double n2 = Dot(n, n);
      const Vec3 q = origin + d * static_cast<double>(hit.t) - a;
      const double u = std::clamp(Dot(Cross(q, e2), n) / n2, 0.0, 1.0);
      const double v = std::clamp(Dot(Cross(e1, q), n) / n2, 0.0, 1.0 - u);
      // Per pixel, not per face: a sliver's colour follows the field
      // across it instead of streaking along its length.
      const double t =
          per_face ? values[prim.face]
                   : Interpolate(values[prim.v[0]], values[prim.v[1]],
                                 values[prim.v[2]], u, v);
      const double lambert = std::abs(Dot(n, d)) / std::sqrt(n2);
      out.image.at(x, y) = Shade(scale(t), 0.3 + 0.7 * lambert);
      out.face[static_cast<size_t>(y) * w + x] = prim.face;
      out.value[static_cast<size_t>(y) * w + x] = t;
    }
  });
  return out;
}

// The curve drawn in its plane, segments as lines about 1/150 of the
// picture wide.
RenderedView RenderCurve(const Mesh& mesh, const std::vector<double>& values,
                         const ColorScale& scale, const Box& box,
                         const RenderOptions& options) {
  const int w = options.width, h = options.height;
  RenderedView out = Blank("plane", options);
  const bool per_face = options.samples == SampleSet::kFaces;
  const double extent =
      std::max({box.hi.x - box.lo.x, box.hi.y - box.lo.y, 1e-300});
  const double pixel = 1.1 * extent / std::min(w, h);
  const Vec3 c = Center(box);
  const double half_width = std::max(1.5, std::min(w, h) / 300.0);
  auto to_pixel = [&](const Vec3& p) {
    return Vec3{(p.x - c.x) / pixel + 0.5 * w, 0.5 * h - (p.y - c.y) / pixel,
                0};
  };
  for (int32_t f = 0; f < mesh.num_faces(); ++f) {
    const Face& face = mesh.faces[f];
    const Vec3 a = to_pixel(mesh.positions[face.v[0]]);
    const Vec3 b = to_pixel(mesh.positions[face.v[1]]);
    const Vec3 ab = b - a;
    const double len2 = std::max(Dot(ab, ab), 1e-300);
    const int x0 =
        std::max(0, static_cast<int>(std::min(a.x, b.x) - half_width));
    const int x1 =
        std::min(w - 1, static_cast<int>(std::max(a.x, b.x) + half_width) + 1);
    const int y0 =
        std::max(0, static_cast<int>(std::min(a.y, b.y) - half_width));
    const int y1 =
        std::min(h - 1, static_cast<int>(std::max(a.y, b.y) + half_width) + 1);
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const Vec3 p{x + 0.5, y + 0.5, 0};
        const double s = std::clamp(Dot(p - a, ab) / len2, 0.0, 1.0);
        if (Norm(a + ab * s - p) > half_width) continue;
        const double t =
            per_face ? values[f]
                     : (1 - s) * values[face.v[0]] + s * values[face.v[1]];
        out.image.at(x, y) = scale(t);
        out.face[static_cast<size_t>(y) * w + x] = f;
        out.value[static_cast<size_t>(y) * w + x] = t;
      }
    }
  }
  return out;
}

}  // namespace

std::vector<View> StandardViews(int up_axis) {
  if (up_axis == 1) {
    return {{"front", {0, 0, -1}, {0, 1, 0}},
            {"back", {0, 0, 1}, {0, 1, 0}},
            {"top", {0, -1, 0}, {0, 0, -1}},
            {"oblique", {-1, -1, -1}, {0, 1, 0}}};
  }
  return {{"front", {0, 1, 0}, {0, 0, 1}},
          {"back", {0, -1, 0}, {0, 0, 1}},
          {"top", {0, 0, -1}, {0, 1, 0}},
          {"oblique", {-1, 1, -1}, {0, 0, 1}}};
}

absl::StatusOr<std::vector<RenderedView>> RenderViews(
    const Mesh& mesh, const std::vector<double>& values,
    const ColorScale& scale, const std::vector<int32_t>& outline,
    const std::vector<View>& views, const RenderOptions& options) {
  const bool per_face = options.samples == SampleSet::kFaces;
  if (std::ssize(values) !=
      (per_face ? mesh.num_faces() : mesh.num_vertices())) {
    return absl::InvalidArgumentError(absl::StrCat(
        "values has ", values.size(), " entries for ",
        per_face ? mesh.num_faces() : mesh.num_vertices(),
        per_face ? " faces" : " vertices"));
  }
  if (!outline.empty() && std::ssize(outline) != mesh.num_faces()) {
    return absl::InvalidArgumentError(
        absl::StrCat("outline has ", outline.size(), " entries for ",
                     mesh.num_faces(), " faces"));
  }
  for (int size : {options.width, options.height}) {
    if (size < 16 || size > 8192) {
      return absl::InvalidArgumentError(
          absl::StrCat("a view is 16..8192 pixels wide and high, got ",
                       options.width, "x", options.height));
    }
  }
  const Box box = Bounds(mesh);
  std::vector<RenderedView> out;
  if (mesh.dimension == 2) {
    out.push_back(RenderCurve(mesh, values, scale, box, options));
  } else {
    const MeshTopology topo = MeshTopology::Build(mesh);
    auto scene = RayScene::Create(mesh, topo, BvhUpdatePolicy::kRebuild);
    if (!scene.ok()) return scene.status();
    for (const View& view : views) {
      auto rendered =
          RenderSurface(mesh, topo, **scene, values, scale, view, box, options);
      if (!rendered.ok()) return rendered.status();
      out.push_back(*std::move(rendered));
    }
  }
  if (!outline.empty()) {
    for (RenderedView& view : out) {
      DrawOutlines(outline, options.outline_below, view);
    }
  }
  return out;
}

}  // namespace meshgauge
