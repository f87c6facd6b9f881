#include "client/cli/huge_pages.h"

#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <string>

namespace meshgauge::cli {
namespace {

constexpr char kTunable[] = "glibc.malloc.hugetlb";

bool NamesFileOfAtLeast(char** argv, int64_t bytes) {
  for (char** arg = argv + 1; *arg != nullptr; ++arg) {
    struct stat st;
    if (stat(*arg, &st) == 0 && S_ISREG(st.st_mode) && st.st_size >= bytes) {
      return true;
    }
  }
  return false;
}

}  // namespace

bool HugePageTunableNamed() {
  const char* tunables = getenv("GLIBC_TUNABLES");
  return tunables != nullptr &&
         std::string(tunables).find(kTunable) != std::string::npos;
}

void ReexecWithHugePages(char** argv, int64_t min_file_bytes) {
  if (argv[0] == nullptr || HugePageTunableNamed() ||
      !NamesFileOfAtLeast(argv, min_file_bytes)) {
    return;
  }
  const char* tunables = getenv("GLIBC_TUNABLES");
  std::string value = tunables != nullptr && *tunables != '\0'
                          ? std::string(tunables) + ":"
                          : std::string();
  value += std::string(kTunable) + "=1";
  if (setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  // Not re-executed: this process keeps its small pages.
}

}  // namespace meshgauge::cli
