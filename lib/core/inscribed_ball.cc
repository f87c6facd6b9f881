#include "lib/core/inscribed_ball.h"

#include <algorithm>
#include <cmath>

// clang-format off: AutoDiff needs Eigen/Core first.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <unsupported/Eigen/AutoDiff>
// clang-format on

namespace meshgauge {
namespace {

// Variables of the derivative: x, axis, three corners.
constexpr int kVariables = 15;
using Ad = Eigen::AutoDiffScalar<Eigen::Matrix<double, kVariables, 1>>;

template <typename S>
using V = Eigen::Matrix<S, 3, 1>;

inline double Val(double v) { return v; }
inline double Val(const Ad& v) { return v.value(); }

// The closed forms, numbered for BallContact::kind.
constexpr int kPlane = 0;           // the minimum over the triangle's plane.
constexpr int kCorner = 1;          // + corner (0..2).
constexpr int kEdgeStationary = 4;  // + 2 edge (root slot 1 unused).
constexpr int kEdgeCone = 10;       // + 2 edge + root.
constexpr int kConic = 16;          // + root.
constexpr int kKinds = 18;

// Slack of the feasibility tests (barycentric coordinates, edge parameter,
// cone angle): a candidate this close to its piece's boundary still counts.
constexpr double kSlack = 1e-12;

// Root `which` (0: the smaller, 1: the larger) of a2 t^2 + b t + c2 = 0,
// each computed in the stable form q / a2 or c2 / q with
// q = -(b + sign(b) sqrt(b^2 - 4 a2 c2)) / 2; a linear equation (a2 = 0)
// has one root, both 0 and 1. False when the root does not exist.
template <typename S>
bool Root(const S& a2, const S& b, const S& c2, int which, S* t) {
  const S disc = b * b - 4.0 * a2 * c2;
  if (!(Val(disc) >= 0)) return false;
  const S sq = sqrt(disc);
  const S q = Val(b) >= 0 ? S(-(b + sq) / 2.0) : S(-(b - sq) / 2.0);
  if (Val(q) == 0) return false;
  const S r1 = c2 / q;
  if (Val(a2) == 0) {
    *t = r1;
  } else {
    const S r0 = q / a2;
    *t = (Val(r0) < Val(r1)) == (which == 0) ? r0 : r1;
  }
  return std::isfinite(Val(*t));
}

template <typename S>
struct Inputs {
  V<S> x, a, corner[3];
  int corners;  // 3 for a triangle, 2 for a segment.
  double cos_beta;
};

// The touching points of the closed forms below, each with its barycentric
// coordinates (lambda, zero on entry); false when the form does not apply
// or its point lies outside its piece (the triangle, the edge).

// Corner j of the piece.
template <typename S>
bool CornerPoint(const Inputs<S>& in, int j, V<S>* s, S lambda[3]) {
  if (j >= in.corners) return false;
  *s = in.corner[j];
  lambda[j] = S(1.0);
  return true;
}

// An edge's stationary point or its meeting with the contact cone (kind in
// [kEdgeStationary, kConic)).
template <typename S>
bool EdgePoint(const Inputs<S>& in, int kind, V<S>* s, S lambda[3]) {
  const double c = in.cos_beta;
  const bool cone = kind >= kEdgeCone;
  const int e = (kind - (cone ? kEdgeCone : kEdgeStationary)) / 2;
  const int root = (kind - (cone ? kEdgeCone : kEdgeStationary)) % 2;
  if (e >= (in.corners == 2 ? 1 : 3)) return false;
  const int e1 = (e + 1) % in.corners;
  const V<S>& p = in.corner[e];
  const V<S> edge = in.corner[e1] - p;
  const V<S> w0 = p - in.x;
  // |s - x|^2 = A t^2 + B t + C, a.(s - x) = D t + E along s = p + t edge.
  const S A = edge.dot(edge), B = 2.0 * w0.dot(edge), C = w0.dot(w0);
  const S D = in.a.dot(edge), E = in.a.dot(w0);
  S t;
  bool found;
  if (cone) {
    found = Root(S(D * D - c * c * A), S(2.0 * D * E - c * c * B),
                 S(E * E - c * c * C), root, &t);
  } else {
    // rho is convex along the line where a.(s - x) = D t + E > 0, so one
    // root is its minimum there and the other lies where D t + E < 0:
    // one form per edge (slot root 0), whichever root that is.
    if (root != 0) return false;
    const S a2 = A * D, b = 2.0 * A * E, c2 = B * E - C * D;
    S other;
    found = Root(a2, b, c2, 0, &t);
    if (Root(a2, b, c2, 1, &other) && (!found || !(Val(D * t + E) > 0))) {
      t = other;
      found = true;
    }
    found = found && Val(D * t + E) > 0;
  }
  if (!found || !(Val(t) >= -kSlack && Val(t) <= 1 + kSlack)) return false;
  *s = p + edge * t;
  lambda[e] = 1.0 - t;
  lambda[e1] = t;
  return true;
}

// A triangle's plane point (kPlane) or conic point (kind >= kConic).
template <typename S>
bool FacePoint(const Inputs<S>& in, int kind, V<S>* s, S lambda[3]) {
  const double c = in.cos_beta;
  // The triangle's plane: x0 the foot of x, h its signed height, g the
  // axis' component in the plane, alpha0 = a.(x0 - x).
  const V<S> ab = in.corner[1] - in.corner[0];
  const V<S> ac = in.corner[2] - in.corner[0];
  const V<S> m = ab.cross(ac);
  const S mm = m.dot(m);
  const V<S> unit = m / sqrt(mm);
  const S h = (in.x - in.corner[0]).dot(unit);
  const V<S> x0 = in.x - unit * h;
  const S an = in.a.dot(unit);
  const V<S> g = in.a - unit * an;
  const S alpha0 = -h * an;
  const S g2 = g.dot(g);
  if (kind == kPlane) {
    // The disc {rho < r} of the plane shrinks to a point at
    // r = h^2 / (alpha0 + sqrt(alpha0^2 + |g|^2 h^2)).
    const S den = alpha0 + sqrt(alpha0 * alpha0 + g2 * h * h);
    if (!(Val(den) > 0)) return false;
    *s = x0 + g * (h * h / den);
  } else {
    // The conic psi = beta of the plane: a.(s - x) = (alpha0 + |g| eta) on
    // the line s = x0 + eta g/|g|, whose extreme points solve
    // (|g|^2 - c^2) eta^2 + 2 alpha0 |g| eta + alpha0^2 - c^2 h^2 = 0.
    V<S> dir;
    S gl;
    if (Val(g2) > 1e-24) {
      gl = sqrt(g2);
      dir = g / gl;
    } else {  // the plane is normal to the axis: any direction will do.
      gl = S(0.0);
      dir = ab / sqrt(ab.dot(ab));
    }
    S eta;
    if (!Root(S(g2 - c * c), S(2.0 * alpha0 * gl),
              S(alpha0 * alpha0 - c * c * h * h), kind - kConic, &eta)) {
      return false;
    }
    *s = x0 + dir * eta;
  }
  const V<S> as = *s - in.corner[0];
  const S beta = as.cross(ac).dot(m) / mm;
  const S gamma = ab.cross(as).dot(m) / mm;
  lambda[0] = 1.0 - beta - gamma;
  lambda[1] = beta;
  lambda[2] = gamma;
  for (int j = 0; j < 3; ++j) {
    if (!(Val(lambda[j]) >= -kSlack)) return false;
  }
  return true;
}

// The touching point of closed form `kind` and its barycentric
// coordinates; false when the form does not apply or its point lies outside
// its piece (the triangle, the edge).
template <typename S>
bool KindPoint(const Inputs<S>& in, int kind, V<S>* s, S lambda[3]) {
  for (int j = 0; j < 3; ++j) lambda[j] = S(0.0);
  if (kind >= kCorner && kind < kEdgeStationary) {
    return CornerPoint(in, kind - kCorner, s, lambda);
  }
  if (kind >= kEdgeStationary && kind < kConic) {
    return EdgePoint(in, kind, s, lambda);
  }
  return in.corners == 3 && FacePoint(in, kind, s, lambda);
}

// rho(s), or false when s is at x or behind the tangent plane. `inside`
// tells whether s is in the contact cone.
template <typename S>
bool Rho(const Inputs<S>& in, const V<S>& s, S* rho, bool* inside) {
  const V<S> w = s - in.x;
  const S w2 = w.dot(w);
  const S aw = in.a.dot(w);
  if (!(Val(aw) > 0) || !(Val(w2) > 0)) return false;
  *inside = Val(aw) >= in.cos_beta * std::sqrt(Val(w2)) * (1 - kSlack);
  *rho = w2 / (2.0 * aw);
  return std::isfinite(Val(*rho));
}

// The corners relative to x (x is the origin of the computation, so that
// rounding scales with the primitive's distance, not with where the part
// sits).
Inputs<double> DoubleInputs(const PrimitiveCorners& pc, const Vec3& x,
                            const Vec3& axis, double cos_beta) {
  auto v = [](const Vec3& p) { return V<double>(p.x, p.y, p.z); };
  Inputs<double> in;
  in.x = V<double>::Zero();
  in.a = v(axis);
  in.corner[0] = v(pc.a - x);
  in.corner[1] = v(pc.b - x);
  in.corner[2] = pc.segment ? V<double>::Zero() : v(pc.c - x);
  in.corners = pc.segment ? 2 : 3;
  in.cos_beta = cos_beta;
  return in;
}

}  // namespace

BallContact MinimumTangentBall(const PrimitiveCorners& pc, const Vec3& x,
                               const Vec3& axis, double cos_beta) {
  const Inputs<double> in = DoubleInputs(pc, x, axis, cos_beta);
  // The smallest rho of the kinds in [begin, end), over the points in the
  // cone only (`cone`) or over all; `inside` tells whether the winner is in
  // the cone.
  auto smallest = [&](int begin, int end, bool cone, bool* inside) {
    BallContact best;
    for (int kind = begin; kind < end; ++kind) {
      V<double> s;
      double lambda[3], rho;
      bool in_cone;
      if (!KindPoint(in, kind, &s, lambda) || !Rho(in, s, &rho, &in_cone) ||
          (cone && !in_cone) || !(rho < best.radius)) {
        continue;
      }
      best.radius = rho;
      best.kind = kind;
      for (int j = 0; j < 3; ++j) best.lambda[j] = lambda[j];
      *inside = in_cone;
    }
    return best;
  };
  // The minimum over the whole primitive is the minimum over its admissible
  // part when it lies in the cone: first the plane's minimum (when inside
  // the triangle, it is the triangle's), then the boundary's; otherwise
  // every form, in the cone only.
  bool inside = false;
  BallContact best = smallest(kPlane, kPlane + 1, false, &inside);
  if (best.kind >= 0) {
    return inside ? best : smallest(0, kKinds, true, &inside);
  }
  best = smallest(kCorner, kEdgeCone, false, &inside);
  if (best.kind >= 0 && inside) return best;
  return smallest(0, kKinds, true, &inside);
}

ContactCone MakeContactCone(const Vec3& axis, double cos_beta) {
  ContactCone cone;
  cone.axis = axis;
  cone.cos_beta = cos_beta;
  cone.sin_beta = std::sqrt(1 - cos_beta * cos_beta);
  // Rho admits a.w >= cos(beta) |w| (1 - kSlack), angles up to
  // kSlack cot(beta) beyond beta: nu.w <= |w| sin(that angle).
  cone.cull_slack = 4 * kSlack * cos_beta / cone.sin_beta + 1e-15;
  return cone;
}

bool SeparatingNormal(const ContactCone& cone, const Vec3& w, Vec3* nu) {
  const Vec3 across = w - cone.axis * Dot(cone.axis, w);
  const double length = Norm(across);
  if (!(length > 0)) return false;
  *nu = across * (cone.cos_beta / length) - cone.axis * cone.sin_beta;
  return true;
}

bool ClosestPointWithin(const PrimitiveCorners& pc, const Vec3& centre,
                        double radius) {
  // The closest point of the primitive to the centre (Ericson, Real-Time
  // Collision Detection, 5.1.5), by its Voronoi regions.
  const Vec3 ab = pc.b - pc.a, ap = centre - pc.a;
  Vec3 closest;
  if (pc.segment) {
    const double t = std::clamp(Dot(ap, ab) / Dot(ab, ab), 0.0, 1.0);
    closest = pc.a + ab * t;
  } else {
    const Vec3 ac = pc.c - pc.a;
    const double d1 = Dot(ab, ap), d2 = Dot(ac, ap);
    const Vec3 bp = centre - pc.b, cp = centre - pc.c;
    const double d3 = Dot(ab, bp), d4 = Dot(ac, bp);
    const double d5 = Dot(ab, cp), d6 = Dot(ac, cp);
    const double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6,
                 va = d3 * d6 - d5 * d4;
    if (d1 <= 0 && d2 <= 0) {
      closest = pc.a;
    } else if (d3 >= 0 && d4 <= d3) {
      closest = pc.b;
    } else if (vc <= 0 && d1 >= 0 && d3 <= 0) {
      closest = pc.a + ab * (d1 / (d1 - d3));
    } else if (d6 >= 0 && d5 <= d6) {
      closest = pc.c;
    } else if (vb <= 0 && d2 >= 0 && d6 <= 0) {
      closest = pc.a + ac * (d2 / (d2 - d6));
    } else if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
      closest = pc.b + (pc.c - pc.b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    } else {
      const double denom = 1 / (va + vb + vc);
      closest = pc.a + ab * (vb * denom) + ac * (vc * denom);
    }
  }
  const Vec3 d = closest - centre;
  // Rounding of the closest point: a relative 1e-9 of the sizes involved.
  const double slack = 1e-9 * (radius + Norm(ap) + Norm(ab));
  return Dot(d, d) <= (radius + slack) * (radius + slack);
}

bool MayTouchBall(const PrimitiveCorners& pc, const Vec3& x,
                  const ContactCone& cone, double radius) {
  // In coordinates relative to x. Outside the contact cone: beyond the
  // separating plane towards the first corner (|w| <= sqrt(3) MaxAbs(w)).
  PrimitiveCorners rel = pc;
  rel.a = pc.a - x;
  rel.b = pc.b - x;
  rel.c = pc.c - x;
  Vec3 nu;
  if (SeparatingNormal(cone, rel.a, &nu)) {
    auto beyond = [&](const Vec3& w) {
      return BeyondCone(cone, nu, w, 1.75 * MaxAbs(w));
    };
    if (beyond(rel.a) && beyond(rel.b) && (pc.segment || beyond(rel.c))) {
      return false;
    }
  }
  return ClosestPointWithin(rel, cone.axis * radius, radius);
}

BallGradient TangentBallGradient(const PrimitiveCorners& pc, const Vec3& x,
                                 const Vec3& axis, double cos_beta, int kind) {
  BallGradient out;
  if (kind < 0) return out;
  auto v = [](const Vec3& p) { return V<double>(p.x, p.y, p.z); };
  const V<double> values[5] = {v(x), v(axis), v(pc.a), v(pc.b),
                               pc.segment ? V<double>::Zero() : v(pc.c)};
  V<Ad> vars[5];
  for (int k = 0; k < 5; ++k) {
    for (int i = 0; i < 3; ++i) {
      vars[k](i) = Ad(values[k](i), kVariables, 3 * k + i);
    }
  }
  Inputs<Ad> in;
  in.corners = pc.segment ? 2 : 3;
  in.cos_beta = cos_beta;
  in.x = V<Ad>::Zero();
  in.a = vars[1];
  for (int j = 0; j < 3; ++j) in.corner[j] = vars[2 + j] - vars[0];
  V<Ad> s;
  Ad lambda[3], rho;
  bool inside;
  if (!KindPoint(in, kind, &s, lambda) || !Rho(in, s, &rho, &inside)) {
    return out;
  }
  const auto& g = rho.derivatives();
  Vec3* slots[5] = {&out.x, &out.axis, &out.corner[0], &out.corner[1],
                    &out.corner[2]};
  for (int v = 0; v < 5; ++v) {
    *slots[v] = Vec3(g(3 * v), g(3 * v + 1), g(3 * v + 2));
  }
  return out;
}

}  // namespace meshgauge
