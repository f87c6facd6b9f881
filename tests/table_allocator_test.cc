// TableAllocator (lib/core/table_allocator.h): a large table is advised for
// transparent huge pages, where a std::vector of the same size is not, and
// tables behave as vectors across its small and large sizes.
#include "lib/core/table_allocator.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "tests/smaps.h"

namespace meshgauge {
namespace {

using testing::Mapping;
using testing::MappingAt;
using testing::ThpMode;
using testing::TunablesName;

// Also run with glibc.malloc.hugetlb=0 in GLIBC_TUNABLES (CTest's
// table_allocator_hugetlb_off) and in the sanitize stage: then the table
// must not be advised.
TEST(TableAllocatorTest, ALargeTableIsAdvisedForHugePagesUnlessTurnedOff) {
  const std::string mode = ThpMode();
  if (mode.empty() || mode == "never") {
    GTEST_SKIP() << "no transparent huge pages (mode '" << mode << "')";
  }
  const bool turned_off = TunablesName("glibc.malloc.hugetlb=0");
  const bool expected = kTableMapsLargeArrays && !turned_off;
  std::printf("%s, hugetlb=0 %s: the table should%s be advised\n",
              kTableMapsLargeArrays ? "not sanitized" : "sanitized",
              turned_off ? "set" : "not set", expected ? "" : " not");
  constexpr size_t kEntries = size_t{16} << 20;  // 64 MiB of int32_t.
  TableVector<int32_t> table;
  table.resize(kEntries);
  for (size_t i = 0; i < kEntries; ++i) table[i] = static_cast<int32_t>(i);
  const Mapping m = MappingAt(table.data());
  ASSERT_TRUE(m.found);
  EXPECT_EQ(m.advised, expected);
  // Whether the kernel grants them depends on its free memory.
  if (m.huge_kb == 0) std::printf("no huge page granted this time\n");
  EXPECT_EQ(table[kEntries - 1], static_cast<int32_t>(kEntries - 1));
  // Without glibc's hugetlb tunable malloc does not advise its memory: the
  // advice is the allocator's.
  if (!TunablesName("glibc.malloc.hugetlb")) {
    std::vector<int32_t> plain(kEntries, 1);
    const Mapping p = MappingAt(plain.data());
    ASSERT_TRUE(p.found);
    EXPECT_FALSE(p.advised);
  }
}

TEST(TableAllocatorTest, BehavesAsAVectorAcrossSmallAndLargeSizes) {
  constexpr size_t kLarge = TableAllocator<uint8_t>::kHugeBytes + 1;
  TableVector<uint8_t> grown(100, 3);
  while (grown.size() < kLarge) grown.push_back(4);  // small to large.
  EXPECT_EQ(grown[99], 3);
  EXPECT_EQ(grown[kLarge - 1], 4);
  TableVector<uint8_t> copy = grown;
  EXPECT_EQ(copy, grown);
  copy.back() = 6;
  EXPECT_NE(copy, grown);
  copy.resize(10);
  copy.shrink_to_fit();  // large to small.
  EXPECT_EQ(copy, TableVector<uint8_t>(10, 3));
  copy.swap(grown);
  EXPECT_EQ(copy.size(), kLarge);
  EXPECT_EQ(grown.size(), 10u);
  grown = copy;
  EXPECT_EQ(grown, copy);
}

}  // namespace
}  // namespace meshgauge
