// TableAllocator (lib/core/table_allocator.h): a large table sits in
// transparent huge pages, where a std::vector of the same size does not.
#include "lib/core/table_allocator.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace meshgauge {
namespace {

// The kernel's THP mode: the bracketed word of
// /sys/kernel/mm/transparent_hugepage/enabled ("always", "madvise",
// "never"), empty when the file is missing.
std::string ThpMode() {
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  std::getline(in, line);
  const size_t open = line.find('['), close = line.find(']');
  if (open == std::string::npos || close == std::string::npos) return "";
  return line.substr(open + 1, close - open - 1);
}

// kB of huge pages (AnonHugePages) in the mapping of /proc/self/smaps that
// holds `address`; -1 when no mapping holds it.
long HugePagesKbAt(const void* address) {
  const auto at = reinterpret_cast<uintptr_t>(address);
  std::ifstream smaps("/proc/self/smaps");
  bool inside = false;
  for (std::string line; std::getline(smaps, line);) {
    uintptr_t lo = 0, hi = 0;
    char dash = 0;
    std::istringstream range(line);
    if (range >> std::hex >> lo >> dash >> hi && dash == '-' &&
        line.find(':') > line.find(' ')) {
      inside = lo <= at && at < hi;
      continue;
    }
    if (inside && line.rfind("AnonHugePages:", 0) == 0) {
      return std::stol(line.substr(line.find(':') + 1));
    }
  }
  return -1;
}

TEST(TableAllocatorTest, ALargeTableSitsInHugePages) {
  const std::string mode = ThpMode();
  if (mode.empty() || mode == "never") {
    GTEST_SKIP() << "transparent huge pages are off (mode '" << mode << "')";
  }
  constexpr size_t kEntries = size_t{16} << 20;  // 64 MiB of int32_t.
  TableVector<int32_t> table;
  table.resize(kEntries);
  for (size_t i = 0; i < kEntries; ++i) table[i] = static_cast<int32_t>(i);
  EXPECT_GT(HugePagesKbAt(table.data()), 0);
  EXPECT_EQ(table[kEntries - 1], static_cast<int32_t>(kEntries - 1));
  // In "madvise" mode, without glibc's hugetlb tunable, malloc's memory does
  // not: the huge pages are the allocator's.
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  if (mode == "madvise" &&
      (tunables == nullptr ||
       std::string(tunables).find("hugetlb") == std::string::npos)) {
    std::vector<int32_t> plain(kEntries, 1);
    EXPECT_EQ(HugePagesKbAt(plain.data()), 0);
  }
}

TEST(TableAllocatorTest, CopiesAndComparesAsVectors) {
  TableVector<uint8_t> small(100, 3);
  TableVector<uint8_t> large(size_t{8} << 20, 5);
  TableVector<uint8_t> copy = large;
  EXPECT_EQ(copy, large);
  copy.back() = 6;
  EXPECT_NE(copy, large);
  large = small;
  EXPECT_EQ(large, small);
  EXPECT_EQ(large.size(), 100u);
}

}  // namespace
}  // namespace meshgauge
