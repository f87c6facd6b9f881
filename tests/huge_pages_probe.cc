// huge_pages_probe MIN_FILE_BYTES [ARG...]: what ReexecWithHugePages
// (client/cli/huge_pages.h) does to a process, for huge_pages_test.sh.
// Starts as the CLI's main does (re-executing when an argument names a file
// of at least MIN_FILE_BYTES), then touches a 64 MiB array and prints
//   GLIBC_TUNABLES=<its value (getenv)>
//   exec_hugetlb=<the value of glibc.malloc.hugetlb in the environment this
//   process image was executed with (/proc/self/environ, where glibc's
//   start-up splits the tunables in place), empty without one: set by a
//   re-execution, not by setenv alone>
//   AnonHugePages=<kB of the process's anonymous memory in huge pages>
//   comm=<the process's name (/proc/self/comm)>
//   sanitized=<1 when built with a sanitizer, whose allocator ignores glibc's
//   tunables>
#include <stdlib.h>
#include <string.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include "client/cli/huge_pages.h"
#include "lib/core/sanitizers.h"

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  if (meshgauge::cli::ArgumentNamesFileOfAtLeast(argv, std::atoll(argv[1]))) {
    meshgauge::cli::ReexecWithHugePages(argv);
  }
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
  std::string exec_hugetlb;
  {
    std::ifstream env_file("/proc/self/environ");
    const std::string env((std::istreambuf_iterator<char>(env_file)),
                          std::istreambuf_iterator<char>());
    constexpr char kName[] = "glibc.malloc.hugetlb=";
    if (const size_t at = env.find(kName); at != std::string::npos) {
      const size_t from = at + sizeof(kName) - 1;
      exec_hugetlb = env.substr(
          from, env.find_first_of(std::string(":\0", 2), from) - from);
    }
  }
  const char* tunables = getenv("GLIBC_TUNABLES");
  std::string comm;
  std::getline(std::ifstream("/proc/self/comm"), comm);
  std::printf(
      "GLIBC_TUNABLES=%s\nexec_hugetlb=%s\nAnonHugePages=%ld\ncomm=%s\n"
      "sanitized=%d\n",
      tunables != nullptr ? tunables : "", exec_hugetlb.c_str(), huge_kb,
      comm.c_str(), MESHGAUGE_SANITIZED);
  const int last = block[kBytes - 1];
  free(block);
  return last == 1 ? 0 : 1;
}
