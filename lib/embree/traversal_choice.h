// Which traversal a ray pass uses for its fans (SdfEvaluator::Compute, when
// EvaluatorOptions::fan_traversal leaves it open; sdf_evaluator.h):
// Embree's packets or streams, or the cone walk where a pilot finds its
// work small (docs/numerics.md, "The cone walk").
#pragma once

#include <cstdint>

#include "lib/core/mesh_geometry.h"
#include "lib/embree/pass_state.h"
#include "lib/embree/ray_scene.h"

namespace meshgauge {

// A pass whose rays start at the surface streams them (FanTraversal::
// kStream) on scenes of fewer primitives than this; on larger ones Embree's
// frustum walks cost more than they share. Measured (docs/benchmarks.md,
// "coherent streams"): streams took 0.64-0.72 of the packets' time on the
// knight (1,000 primitives) and the tray (4,520), 0.87-0.93 on the teapot
// (6,320), 0.99-1.02 on spot (5,856); 1.06-1.16 on fandisk (12,946) and
// 1.16-1.24 on ranges of bunny, horse and igea.
inline constexpr int64_t kStreamMaxPrimitives = int64_t{1} << 13;
// ... and whose cones open less than this (full angle, degrees); wider
// cones go in packets (likely because Embree's frustum test culls less of a
// wider cone's BVH: not profiled). Measured (meshgauge_bench --repeat 3,
// 170 degrees at --repeat 1, packets and streams forced from the surface,
// pass / SPEC ceiling; docs/benchmarks.md, "streams for narrow cones
// alone"): on the knight and the tray streams 0.853 and 0.800
// against packets 0.799 and 0.733 at 30 degrees, level at 40 (0.777 and
// 0.772 against 0.809 and 0.748), behind from 45 (0.759 and 0.727 against
// 0.836 and 0.798) to 170 (0.480 and 0.639 against 0.782 and 0.883).
inline constexpr double kStreamMaxConeDegrees = 40;
// A pass walks cones where a pilot finds the walk's work small: at most
// this many (triangle, group of 8 rays) tests per ray over kPilotSamples
// fans (ConeWalk::Intersect's count). Measured (meshgauge_bench, pass /
// SPEC ceiling; docs/benchmarks.md, "The cone walk's pilot"): the walk won
// at 1.9-6.2 tests a ray (the knight, the tray, spot and the teapot at 30
// degrees; the knight and the tray at 60, the knight at 90), broke even at
// 7.4 (the tray at 90) and lost at 10.9-18.4 (spot and the teapot at 45
// and 60 degrees: 0.45-0.59 of the ceiling walked, 0.77-0.96 by Embree).
inline constexpr double kWalkMaxGroupTestsPerRay = 8;
// Cones narrower than kNarrowWalkMaxConeDegrees (full angle, degrees) of
// more than one ray are piloted on scenes of fewer than
// kNarrowWalkMaxPrimitives primitives (others: kStreamMaxPrimitives). A
// narrow cone meets few triangles even on a finer mesh; the pilot needs the
// walk's tree, built after every move, which a wider cone there seldom
// repays. Measured (meshgauge_bench --repeat 2, pass / SPEC ceiling;
// docs/benchmarks.md, "the walk for narrow cones on larger scenes"): at 10
// degrees rocker-arm (20,088 primitives) 1.746 walked against 0.832 in
// packets, fandisk (12,946) 1.484 against 0.904, homer (12,000) 1.680
// against 0.739, cheburashka (13,334) 1.646 against 0.782; at 20 degrees,
// the limit at 2^13 against 2^15, 0.991 -> 1.382, 0.896 -> 0.965, 0.975 ->
// 1.574, 0.951 -> 1.488; at 30 degrees (--repeat 3) the pilot walked homer
// alone (0.91-0.94 -> 1.09-1.22) and its tree made fandisk's pass 0.85-0.87
// -> 0.78-0.80; bunny (69,664) walked at 0.47 of the ceiling at 20
// degrees. The bound 2^15 is extrapolated from these meshes: none between
// 20,088 and 32,768 primitives was measured.
inline constexpr int64_t kNarrowWalkMaxPrimitives = int64_t{1} << 15;
inline constexpr double kNarrowWalkMaxConeDegrees = 30;
// The pilot's fans: this many samples spread evenly over all of the pass's
// kind (every one of fewer), whatever its range.
inline constexpr int64_t kPilotSamples = 16;
// The traversal of a pass that EvaluatorOptions::fan_traversal leaves
// open and that does not walk cones: streams where the rays start at the
// surface on a small 3D scene under the watertight test and the cone
// (half-angle `cone_half_angle`, radians) opens less than
// kStreamMaxConeDegrees; else packets. Embree's fast test met other
// primitives in streams than in packets (the tray's raw plain passes); a
// 2D circle of 4,000 segments took 1.30-1.35 times as long streamed (a
// throwaway program; docs/benchmarks.md).
FanTraversal ChooseTraversal(bool past_balls, RayTest test, int64_t primitives,
                             int dimension, double cone_half_angle);

// Whether a pass left to choose (EvaluatorOptions::fan_traversal unset,
// RayStartMode::kAuto or kSurface starts) walks cones: a cone pass (or normal
// rays) on a scene of fewer than kStreamMaxPrimitives (a cone of more than
// one ray narrower than kNarrowWalkMaxConeDegrees: kNarrowWalkMaxPrimitives)
// under the watertight test, every fan of which the walk takes
// (ConeWalk::TakesEveryFan): always for one ray a fan (normal rays, or a
// cone of one ray: the pilot's count, made for groups of 8, says little
// there; the walk meets the far face along seams where Embree's box test
// misses it, ConeWalkTest.MeetsTheFarFace...),
// else where the pilot (into *pilot) finds at most
// kWalkMaxGroupTestsPerRay tests a ray. The pilot depends on the positions
// (the walk's tree is built from them after every update, not refitted,
// so on nothing else): a pass reuses only a pass that chose alike
// (SdfEvaluator::PlanReuse). Such a pass starts its rays at the surface.
// `g` is the scene's geometry. In the caller's arena.
bool WalksCones(const MeshGeometry& g, const RayScene& scene,
                const pass_state::PassSetup& setup, RayTest test,
                double* pilot);

}  // namespace meshgauge
