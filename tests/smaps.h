// What the kernel says of this process's memory: its THP mode and the
// mapping that holds an address (/proc/self/smaps), for tests of where
// large arrays live (TableAllocator, ExactSums).
#pragma once

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

namespace meshgauge::testing {

// The kernel's THP mode: the bracketed word of
// /sys/kernel/mm/transparent_hugepage/enabled ("always", "madvise",
// "never"), empty when the file is missing (a kernel without THP).
inline std::string ThpMode() {
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  std::getline(in, line);
  const size_t open = line.find('['), close = line.find(']');
  if (open == std::string::npos || close == std::string::npos) return "";
  return line.substr(open + 1, close - open - 1);
}

// What /proc/self/smaps says of the mapping that holds `address`.
struct Mapping {
  bool found = false;
  bool advised = false;  // VmFlags has "hg" (MADV_HUGEPAGE).
  long huge_kb = 0;      // AnonHugePages.
};

inline Mapping MappingAt(const void* address) {
  const auto at = reinterpret_cast<uintptr_t>(address);
  std::ifstream smaps("/proc/self/smaps");
  Mapping m;
  bool inside = false;
  for (std::string line; std::getline(smaps, line);) {
    uintptr_t lo = 0, hi = 0;
    char dash = 0;
    std::istringstream range(line);
    if (range >> std::hex >> lo >> dash >> hi && dash == '-' &&
        line.find(':') > line.find(' ')) {
      if (m.found) break;
      inside = lo <= at && at < hi;
      m.found = inside;
      continue;
    }
    if (!inside) continue;
    if (line.rfind("AnonHugePages:", 0) == 0) {
      m.huge_kb = std::stol(line.substr(line.find(':') + 1));
    } else if (line.rfind("VmFlags:", 0) == 0) {
      m.advised = (line + " ").find(" hg ") != std::string::npos;
    }
  }
  return m;
}

inline bool TunablesName(const char* setting) {
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  return tunables != nullptr &&
         std::string(tunables).find(setting) != std::string::npos;
}

}  // namespace meshgauge::testing
