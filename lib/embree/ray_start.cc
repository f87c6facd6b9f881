#include "lib/embree/ray_start.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lib/core/inscribed_ball.h"

namespace meshgauge {
namespace {

// The rounding of the traced ray's origin, relative to its reach.
constexpr double kOriginRounding = 0x1p-21;
// The rounding of its unit direction.
constexpr double kDirectionRounding = 0x1p-20;
// Balls below this share of the reach (over cos^2 of the largest ray
// angle) fall back.
constexpr double kMinRadius = 0x1p-11;
// The stretch kept before the ball's far side.
constexpr double kChordShare = 1 - 0x1p-8;

}  // namespace

RayStarts::RayStarts(absl::Span<const ConeRay> cone) {
  double max_angle = 0;
  for (const ConeRay& ray : cone) max_angle = std::max(max_angle, ray.angle);
  const double beta = max_angle + kAngleMargin;
  if (cone.empty() || !(beta < 80 * std::numbers::pi / 180)) return;
  cos_beta_ = std::cos(beta);
  min_radius_ = kMinRadius / (std::cos(max_angle) * std::cos(max_angle));
  for (const ConeRay& ray : cone) {
    chord_cos_.push_back(2 * std::cos(ray.angle) * kChordShare);
  }
}

double RayStarts::ApexRadius(double reach, const RayScene::FanLimits& limits) {
  const double a = reach * kOriginRounding;
  const double t_apex = a / (std::sin(kAngleMargin) - kDirectionRounding);
  return 2 * (t_apex + a) +
         2 * RayScene::NearBelow(limits, static_cast<float>(reach));
}

double RayStarts::EmptyBall(const MeshGeometry& g, const BallTree& tree,
                            const Vec3& x, const Vec3& axis,
                            absl::Span<const int32_t> excluded, double cap,
                            double reach,
                            const RayScene::FanLimits& limits) const {
  const double apex = ApexRadius(reach, limits);
  const double smallest = std::max(reach * min_radius_, apex);
  if (empty() || !(cap > smallest)) return 0;
  // The ball, shrunk to the nearest admissible point of any primitive, and
  // nothing but the excluded primitives near x (else r < 0: no ball).
  const ContactCone cone = MakeContactCone(axis, cos_beta_);
  double r = cap;
  tree.Visit(
      x, cone, r,
      [&](int32_t prim) {
        if (std::binary_search(excluded.begin(), excluded.end(), prim)) {
          return r;
        }
        const PrimitiveCorners pc = g.Corners(prim);
        PrimitiveCorners rel = pc;
        rel.a = pc.a - x;
        rel.b = pc.b - x;
        rel.c = pc.c - x;
        if (ClosestPointWithin(rel, Vec3(), apex)) return r = -1;
        if (!MayTouchBall(pc, x, cone, r)) return r;
        const double rho = MinimumTangentBall(pc, x, axis, cos_beta_).radius;
        // NaN: no certificate.
        r = rho >= smallest ? std::min(r, rho) : -1;
        return r;
      },
      apex);
  return r >= smallest ? r : 0;
}

void RayStarts::Fill(double r, absl::Span<const int> rays,
                     const RayScene::FanLimits& limits,
                     std::vector<float>* starts) const {
  starts->resize(rays.size());
  for (size_t j = 0; j < rays.size(); ++j) {
    (*starts)[j] =
        std::max(limits.t_near, static_cast<float>(r * chord_cos_[rays[j]]));
  }
}

}  // namespace meshgauge
