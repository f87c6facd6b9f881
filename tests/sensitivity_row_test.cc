#include "lib/core/sensitivity_row.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::Bits;

// Rows of primitive corner terms and single terms, made by one row with
// AddCorners and by another with Add alone, term by term: the same entries
// in the same order, each summed in the same order, whatever primitives
// repeat, share a memo slot (indices 64 apart), are segments (v[2] = -1),
// or arrive after the index has grown; across many rows on the same
// objects, so that a slot filled by an earlier row must not be trusted.
TEST(SampleRowTest, AddCornersMakesTheEntriesOfAddTermByTerm) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int32_t> vertex(0, 400);
  std::uniform_real_distribution<double> u(-1, 1);
  // A pool of primitives: ids 0..191 (three per memo slot), some segments.
  std::vector<Primitive> prims(192);
  for (size_t id = 0; id < prims.size(); ++id) {
    for (int j = 0; j < 3; ++j) prims[id].v[j] = vertex(rng);
    if (id % 7 == 0) prims[id].v[2] = -1;
  }
  auto term = [&] {
    // -0 in some components: a new entry turns it into +0 (Vec3() + d).
    return Vec3{u(rng), rng() % 5 == 0 ? -0.0 : u(rng), u(rng) * 1e-9};
  };
  SampleRow with_memo, by_vertex;
  std::vector<RowTerm> got, want;
  for (int row = 0; row < 300; ++row) {
    with_memo.Clear();
    by_vertex.Clear();
    // Short rows draw from a few primitives (many repeats); long ones
    // (over 128 entries) grow the index mid-row.
    const int pool = row % 3 == 0 ? 192 : 6 + row % 10;
    const int rays = row % 3 == 0 ? 150 : 40;
    for (int k = 0; k < rays; ++k) {
      const int32_t id = static_cast<int32_t>(
          (rng() % pool + 64 * (rng() % 3)) % prims.size());
      const Primitive& prim = prims[id];
      const Vec3 corner[3] = {term(), term(), term()};
      with_memo.AddCorners(id, prim, [&](int j) { return corner[j]; });
      for (int j = 0; j < 3 && prim.v[j] >= 0; ++j) {
        by_vertex.Add(prim.v[j], corner[j]);
      }
      if (k % 9 == 0) {  // a term of the sample's own vertex or axis
        const int32_t v = vertex(rng);
        const Vec3 d = term();
        with_memo.Add(v, d);
        by_vertex.Add(v, d);
      }
    }
    with_memo.TakeTerms(got);
    by_vertex.TakeTerms(want);
    ASSERT_EQ(got.size(), want.size()) << "row " << row;
    for (size_t e = 0; e < want.size(); ++e) {
      ASSERT_EQ(got[e].vertex, want[e].vertex) << "row " << row;
      for (int a = 0; a < 3; ++a) {
        ASSERT_EQ(Bits(got[e].d[a]), Bits(want[e].d[a]))
            << "row " << row << " entry " << e;
      }
    }
  }
}

// TakeTerms leaves the row empty and ready for the next sample.
TEST(SampleRowTest, TakeTermsEmptiesTheRow) {
  SampleRow row;
  const Primitive prim{{1, 2, 3}, 0};
  row.AddCorners(5, prim, [](int j) { return Vec3{1.0 * j, 0, 0}; });
  std::vector<RowTerm> first, second;
  row.TakeTerms(first);
  EXPECT_EQ(first.size(), 3u);
  row.AddCorners(5, prim, [](int) { return Vec3{1, 1, 1}; });
  row.TakeTerms(second);
  ASSERT_EQ(second.size(), 3u);
  for (const RowTerm& t : second) EXPECT_EQ(t.d, (Vec3{1, 1, 1}));
}

}  // namespace
}  // namespace meshgauge
