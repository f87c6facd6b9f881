#include "lib/cone.h"

#include <cmath>
#include <numbers>

#include "absl/strings/str_cat.h"

namespace meshgauge {
namespace {

constexpr double kSouthCapTolerance = 1e-6;

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

ConeFrame MakeFrame(int dimension, const Vec3& a) {
  if (dimension == 2) return {{-a.y, a.x, 0.0}, {}, a};
  if (InSouthCap(a)) return {{1, 0, 0}, {0, -1, 0}, a};
  const double s = 1 + a.z;
  return {{1 - a.x * a.x / s, -a.x * a.y / s, -a.x},
          {-a.x * a.y / s, 1 - a.y * a.y / s, -a.y},
          a};
}

Vec3 FrameVjp(int dimension, const Vec3& a, const Vec3& gu, const Vec3& gv) {
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

}  // namespace meshgauge
