// RunGradCheck's retries and verdicts: a probe that crosses an event is
// repeated with smaller steps, and a check whose checkable entries all agree
// but too few are checkable is INCONCLUSIVE, not FAIL.
#include "lib/embree/gradcheck.h"

#include <gtest/gtest.h>

#include "lib/core/shapes.h"
#include "lib/io/mesh_io.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

// On the CAD tray (thin plates, many rays grazing edges) some probes at
// the default step cross an event; the retries at steps 10 and 100 times
// smaller make entries clean, and the check passes.
TEST(GradCheckTest, AProbeThatCrossedAnEventIsRepeatedWithSmallerSteps) {
  auto tray = ReadMesh(testing::SharedMesh("1002_tray_bottom.STL"));
  ASSERT_TRUE(tray.ok());
  GradCheckOptions options;
  // Progress never goes back, repeats or not, and ends at the whole check.
  int64_t done = 0, total = 0;
  bool monotonic = true;
  ComputeControl control;
  control.progress = [&](int64_t d, int64_t t) {
    monotonic &= d >= done;
    done = d;
    total = t;
  };
  auto rep = RunGradCheck(*tray, {}, options, control);
  ASSERT_TRUE(rep.ok()) << rep.status();
  EXPECT_GT(rep->retried, 0);
  EXPECT_TRUE(monotonic);
  EXPECT_EQ(done, total);
  EXPECT_EQ(total, GradCheckPasses(*tray, options) * tray->num_vertices());
  const double first = options.relative_step * BoundingBoxDiagonal(*tray);
  int64_t clean_after_retry = 0;
  for (const GradCheckRow& r : rep->rows) {
    clean_after_retry += r.clean && r.step < 0.5 * first;
  }
  EXPECT_GT(clean_after_retry, 0);
  EXPECT_EQ(rep->Verdict(), GradCheckVerdict::kPass);
  std::printf(
      "retried %lld probes; %lld entries clean only at a smaller step; "
      "clean %lld of %zu, passed %lld, worst %.2e, VJP %lld/%lld\n",
      static_cast<long long>(rep->retried),
      static_cast<long long>(clean_after_retry),
      static_cast<long long>(rep->clean), rep->rows.size(),
      static_cast<long long>(rep->passed), rep->worst,
      static_cast<long long>(rep->vjp_passed),
      static_cast<long long>(rep->vjp_checks));
}

// Outsider report: `meshgauge gradcheck` failed on spot with the default
// seed, every entry agreeing: its one VJP check that failed was at a retry's
// step 100 times smaller, where sum_p g_p fd_p over 198 entries carries
// their round-off (1.4e-7 against the base step's floor of 1e-7). The floor
// now grows with the step's reduction and with |g| over the entries.
TEST(GradCheckTest, VjpChecksAtARetrysStepAllowForTheirRoundOff) {
  auto spot = ReadMesh(testing::SharedMesh("spot_triangulated.obj"));
  ASSERT_TRUE(spot.ok());
  const GradCheckOptions options;
  auto rep = RunGradCheck(*spot, {}, options);
  ASSERT_TRUE(rep.ok()) << rep.status();
  EXPECT_EQ(rep->vjp_passed, rep->vjp_checks);
  EXPECT_EQ(std::ssize(rep->vjp_rows), rep->vjp_checks);
  const double first = options.relative_step * BoundingBoxDiagonal(*spot);
  int64_t at_retries = 0;
  for (const GradCheckRow& r : rep->vjp_rows) {
    at_retries += r.step < 0.5 * first;
    EXPECT_LE(r.relative_error, options.tolerance)
        << r.vertex << " " << r.coordinate << " step " << r.step;
  }
  EXPECT_GT(at_retries, 0);
  EXPECT_EQ(rep->Verdict(), GradCheckVerdict::kPass);
  EXPECT_EQ(GradCheckFloor(1e-7, 1e-7), 1e-2);
  EXPECT_NEAR(GradCheckFloor(1e-7, 1e-9, 10), 10, 1e-12);
  EXPECT_NEAR(GradCheckFloor(1e-7, 1e-8, 0.5), 0.1, 1e-15);
}

GradCheckRow Row(bool clean, double relative_error) {
  GradCheckRow r;
  r.clean = clean;
  r.relative_error = relative_error;
  return r;
}

TEST(GradCheckTest, TooFewCheckableEntriesIsInconclusiveAndAWrongOneFails) {
  GradCheckReport rep;
  rep.min_clean_fraction = 0.9;
  for (int i = 0; i < 8; ++i) rep.rows.push_back(Row(true, 1e-8));
  for (int i = 0; i < 2; ++i) rep.rows.push_back(Row(false, 0));
  rep.clean = rep.passed = 8;
  EXPECT_EQ(rep.Verdict(), GradCheckVerdict::kInconclusive);
  rep.min_clean_fraction = 0.8;
  EXPECT_EQ(rep.Verdict(), GradCheckVerdict::kPass);
  rep.passed = 7;  // one clean entry beyond the tolerance.
  EXPECT_EQ(rep.Verdict(), GradCheckVerdict::kFail);
  rep.passed = 8;
  rep.vjp_checks = 1;  // a VJP check that failed.
  EXPECT_EQ(rep.Verdict(), GradCheckVerdict::kFail);
}

// On a caller's evaluator the probed vertices are put back, also when the
// check is cancelled between a probe's two passes.
TEST(GradCheckTest, TheEvaluatorEndsAtItsPositionsEvenWhenCancelled) {
  const Mesh sphere = MakeIcosphere(1, 4);
  auto ev = SdfEvaluator::Create(sphere);
  ASSERT_TRUE(ev.ok());
  SdfParams params;
  params.rays = 10;
  auto rep = RunGradCheck(**ev, params, {.samples = 2});
  ASSERT_TRUE(rep.ok()) << rep.status();
  EXPECT_EQ((*ev)->mesh().positions, sphere.positions);
  EXPECT_GE((*ev)->generation(), 2 * 3 * 3);  // +h, -h and back per probe.
  ComputeControl control;
  int64_t asked = 0;
  control.cancelled = [&] { return ++asked > 40; };
  auto cancelled = RunGradCheck(**ev, params, {.samples = 2}, control);
  EXPECT_EQ(cancelled.status().code(), absl::StatusCode::kCancelled);
  EXPECT_EQ((*ev)->mesh().positions, sphere.positions);
}

}  // namespace
}  // namespace meshgauge
