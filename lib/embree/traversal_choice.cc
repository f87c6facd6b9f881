#include "lib/embree/traversal_choice.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include <algorithm>
#include <array>
#include <numbers>
#include <vector>

#include "absl/types/span.h"
#include "lib/core/face_sample.h"
#include "lib/core/vertex_cone.h"
#include "lib/embree/cone_walk.h"

namespace meshgauge {
namespace {

using pass_state::MakePassSample;
using pass_state::PassSetup;
using pass_state::SampleScratch;

// The cone walk's (triangle, group of 8 rays) tests per ray from the
// surface on the fans of kPilotSamples samples spread evenly over all of
// the pass's kind at the current positions, whatever its range (so that
// every range of a pass decides alike); -1 where the walk gives up on one.
// In the caller's arena.
double PilotGroupTestsPerRay(const MeshGeometry& g, const RayScene& scene,
                             const PassSetup& setup) {
  const SampleSet set = setup.resolved.params.samples;
  const int64_t n = NumSamples(g.mesh(), set);
  const int64_t pilots = std::min(n, kPilotSamples);
  // Per fan: its tests (-1: the walk gave up) and rays, summed in order.
  std::vector<std::array<int64_t, 2>> walked(pilots, {0, 0});
  // A scratch per chunk: one chunk per thread (static_partitioner).
  tbb::parallel_for(
      tbb::blocked_range<int64_t>(0, pilots),
      [&](const tbb::blocked_range<int64_t>& r) {
        SampleScratch s(setup.num_rays);
        for (int64_t i = r.begin(); i < r.end(); ++i) {
          const int64_t p = i * n / pilots;
          SampleCone sample;
          if (MakePassSample(g, setup, p, &sample) != VertexStatus::kOk) {
            continue;
          }
          RayDirections(sample.cone.frame, setup.cone, absl::MakeSpan(s.dirs));
          SampleExclusions(g.mesh(), g.topology(), set, /*ball=*/false, p,
                           &s.excluded);
          walked[i] = {scene.ConeWalkTests(sample.x, s.dirs, setup.limits,
                                           s.excluded, sample.cone.frame.axis,
                                           absl::MakeSpan(s.candidates)),
                       setup.num_rays};
        }
      },
      tbb::static_partitioner());
  int64_t tests = 0, rays = 0;
  for (const auto& [fan_tests, fan_rays] : walked) {
    if (fan_tests < 0) return -1;
    tests += fan_tests;
    rays += fan_rays;
  }
  return rays > 0 ? static_cast<double>(tests) / static_cast<double>(rays) : 0;
}

// Whether a cone of half-angle `half_angle` (radians) opens less than
// `degrees` (its full angle).
bool OpensLessThan(double half_angle, double degrees) {
  return 2 * half_angle < degrees * std::numbers::pi / 180;
}

}  // namespace

FanTraversal ChooseTraversal(bool past_balls, RayTest test, int64_t primitives,
                             int dimension, double cone_half_angle) {
  return !past_balls && test == RayTest::kWatertight &&
                 primitives < kStreamMaxPrimitives && dimension == 3 &&
                 OpensLessThan(cone_half_angle, kStreamMaxConeDegrees)
             ? FanTraversal::kStream
             : FanTraversal::kPackets;
}

bool WalksCones(const MeshGeometry& g, const RayScene& scene,
                const PassSetup& setup, RayTest test, double* pilot) {
  const int64_t primitives = std::ssize(g.topology().primitives);
  const bool narrow =
      setup.num_rays > 1 &&
      OpensLessThan(setup.cone_half_angle, kNarrowWalkMaxConeDegrees);
  if (setup.sphere || test != RayTest::kWatertight ||
      primitives >=
          (narrow ? kNarrowWalkMaxPrimitives : kStreamMaxPrimitives) ||
      !ConeWalk::TakesEveryFan(primitives, g.mesh().dimension, setup.num_rays,
                               setup.cone_half_angle)) {
    return false;
  }
  if (setup.num_rays == 1) return true;
  *pilot = PilotGroupTestsPerRay(g, scene, setup);
  return *pilot >= 0 && *pilot <= kWalkMaxGroupTestsPerRay;
}

}  // namespace meshgauge
