#include "lib/core/cone.h"

#include <cmath>
#include <numbers>

#include "absl/strings/str_cat.h"

namespace meshgauge {
namespace {

constexpr double kSouthCapTolerance = 1e-6;
// SPEC v2 §3: a neighbour edge defines u when |w| >= 1e-3 |e|.
constexpr double kMinOrthogonalFraction = 1e-3;

bool InSouthCap(const Vec3& a) {
  return Norm(a + Vec3(0, 0, 1)) < kSouthCapTolerance;
}

}  // namespace

absl::StatusOr<std::vector<ConeRay>> MakeCone(int dimension,
                                              double aperture_radians, int rays,
                                              double min_weight_angle) {
  if (!(aperture_radians > 0 && aperture_radians < std::numbers::pi)) {
    return absl::InvalidArgumentError(
        absl::StrCat("cone angle must be in (0, 180) degrees, got ",
                     aperture_radians * 180 / std::numbers::pi));
  }
  if (rays < 1 || rays > 4096) {
    return absl::InvalidArgumentError(
        absl::StrCat("ray count must be in [1, 4096], got ", rays));
  }
  if (!(min_weight_angle > 0) || !std::isfinite(min_weight_angle)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "minimum weight angle must be > 0 radians, got ", min_weight_angle));
  }
  std::vector<ConeRay> cone(rays);
  const double half = aperture_radians / 2;
  const double golden = std::numbers::pi * (3 - std::sqrt(5.0));
  for (int k = 0; k < rays; ++k) {
    ConeRay& ray = cone[k];
    if (dimension == 2) {
      const double theta = -half + aperture_radians * (k + 0.5) / rays;
      ray.local = {std::sin(theta), 0.0, std::cos(theta)};
      ray.angle = std::abs(theta);
    } else {
      const double cos_t = 1 - (k + 0.5) * (1 - std::cos(half)) / rays;
      const double sin_t = std::sqrt(std::max(0.0, 1 - cos_t * cos_t));
      const double phi = k * golden;
      ray.local = {sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t};
      ray.angle = std::acos(cos_t);
    }
    ray.weight = 1 / std::max(ray.angle, min_weight_angle);
  }
  return cone;
}

ConeFrame MakeWorldFrame(int dimension, const Vec3& a) {
  ConeFrame f;
  f.axis = a;
  if (dimension == 2) {
    f.u = {-a.y, a.x, 0.0};
  } else if (InSouthCap(a)) {
    f.u = {1, 0, 0};
    f.v = {0, -1, 0};
  } else {
    const double s = 1 + a.z;
    f.u = {1 - a.x * a.x / s, -a.x * a.y / s, -a.x};
    f.v = {-a.x * a.y / s, 1 - a.y * a.y / s, -a.y};
  }
  return f;
}

ConeFrame MakeAttachedFrame(const Vec3& a, const Vec3& x_p,
                            absl::Span<const int32_t> neighbors,
                            absl::Span<const Vec3> positions) {
  for (int32_t q : neighbors) {
    const Vec3 e = positions[q] - x_p;
    const Vec3 w = e - a * Dot(e, a);
    const double w_norm = Norm(w);
    if (!(w_norm >= kMinOrthogonalFraction * Norm(e)) || w_norm == 0) continue;
    ConeFrame f;
    f.axis = a;
    f.u = w / w_norm;
    f.v = Cross(a, f.u);
    f.reference = q;
    f.edge = e;
    f.w_norm = w_norm;
    return f;
  }
  return MakeWorldFrame(3, a);
}

namespace {

// v1 world frame: g_u^T du/da + g_v^T dv/da.
Vec3 WorldFrameVjp(int dimension, const Vec3& a, const Vec3& gu,
                   const Vec3& gv) {
  if (dimension == 2) {
    // u = (-a_y, a_x): du/da_x = (0, 1), du/da_y = (-1, 0).
    return {gu.y, -gu.x, 0.0};
  }
  if (InSouthCap(a)) return {};
  const double s = 1 + a.z;
  const double s2 = s * s;
  // Columns du/da_x, du/da_y, du/da_z (and likewise for v), dotted with g.
  const Vec3 du_dx(-2 * a.x / s, -a.y / s, -1);
  const Vec3 du_dy(0, -a.x / s, 0);
  const Vec3 du_dz(a.x * a.x / s2, a.x * a.y / s2, 0);
  const Vec3 dv_dx(-a.y / s, 0, 0);
  const Vec3 dv_dy(-a.x / s, -2 * a.y / s, -1);
  const Vec3 dv_dz(a.x * a.y / s2, a.y * a.y / s2, 0);
  return {Dot(gu, du_dx) + Dot(gv, dv_dx), Dot(gu, du_dy) + Dot(gv, dv_dy),
          Dot(gu, du_dz) + Dot(gv, dv_dz)};
}

}  // namespace

FrameGradient FrameVjp(int dimension, const ConeFrame& f, const Vec3& g_u,
                       const Vec3& g_v) {
  if (f.reference < 0) return {WorldFrameVjp(dimension, f.axis, g_u, g_v), {}};
  const Vec3& a = f.axis;
  // v = a x u: g_v.(da x u + a x du) = da.(u x g_v) + du.(g_v x a).
  FrameGradient out;
  out.axis = Cross(f.u, g_v);
  const Vec3 gu = g_u + Cross(g_v, a);
  // u = w/|w|: dL/dw = (I - u u^T) gu / |w|.
  const Vec3 gw = (gu - f.u * Dot(f.u, gu)) / f.w_norm;
  // w = e - (e.a) a: dL/de = gw - (gw.a) a; dL/da = -(gw.a) e - (e.a) gw.
  const double gw_a = Dot(gw, a);
  out.edge = gw - a * gw_a;
  out.axis -= f.edge * gw_a + gw * Dot(f.edge, a);
  return out;
}

}  // namespace meshgauge
