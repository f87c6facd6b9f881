// huge_pages_probe MIN_FILE_BYTES [ARG...]: what ReexecWithHugePages
// (client/cli/huge_pages.h) does to a process, for huge_pages_test.sh.
// Calls it first with MIN_FILE_BYTES, as the CLI's main does, then touches a
// 64 MiB array and prints
//   GLIBC_TUNABLES=<value after the call>
//   AnonHugePages=<kB of the process's anonymous memory in huge pages>
//   sanitized=<1 when built with a sanitizer, whose allocator ignores glibc's
//   tunables>
#include <stdlib.h>
#include <string.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "client/cli/huge_pages.h"

#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
#define MESHGAUGE_SANITIZED 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define MESHGAUGE_SANITIZED 1
#endif
#ifndef MESHGAUGE_SANITIZED
#define MESHGAUGE_SANITIZED 0
#endif

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  meshgauge::cli::ReexecWithHugePages(argv, std::atoll(argv[1]));
  constexpr size_t kBytes = size_t{64} << 20;
  auto* volatile block = static_cast<char*>(malloc(kBytes));
  if (block == nullptr) return 1;
  memset(block, 1, kBytes);
  long huge_kb = -1;
  std::ifstream rollup("/proc/self/smaps_rollup");
  for (std::string line; std::getline(rollup, line);) {
    if (line.rfind("AnonHugePages:", 0) == 0) {
      huge_kb = std::stol(line.substr(line.find(':') + 1));
    }
  }
  const char* tunables = getenv("GLIBC_TUNABLES");
  std::printf("GLIBC_TUNABLES=%s\nAnonHugePages=%ld\nsanitized=%d\n",
              tunables != nullptr ? tunables : "", huge_kb,
              MESHGAUGE_SANITIZED);
  const int last = block[kBytes - 1];
  free(block);
  return last == 1 ? 0 : 1;
}
