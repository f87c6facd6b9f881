#include "client/cli/huge_pages.h"

#include <stdlib.h>
#include <sys/auxv.h>
#include <sys/stat.h>
#include <unistd.h>

#include <string>

#include "client/cli/self_exe.h"

namespace meshgauge::cli {
namespace {

constexpr char kTunable[] = "glibc.malloc.hugetlb";

}  // namespace

bool ArgumentNamesFileOfAtLeast(char** argv, int64_t bytes) {
  if (argv[0] == nullptr) return false;
  for (char** arg = argv + 1; *arg != nullptr; ++arg) {
    struct stat st;
    if (stat(*arg, &st) == 0 && S_ISREG(st.st_mode) && st.st_size >= bytes) {
      return true;
    }
  }
  return false;
}

bool SetHugePagesTunable() {
  // A tunables string naming it already (a user's explicit 0 included)
  // is left as it is.
  const char* tunables = getenv("GLIBC_TUNABLES");
  if (getauxval(AT_SECURE) != 0 ||
      (tunables != nullptr &&
       std::string(tunables).find(kTunable) != std::string::npos)) {
    return false;
  }
  std::string value = tunables != nullptr && *tunables != '\0'
                          ? std::string(tunables) + ":"
                          : std::string();
  value += std::string(kTunable) + "=1";
  return setenv("GLIBC_TUNABLES", value.c_str(), 1) == 0;
}

void ReexecWithHugePages(char** argv) {
  if (argv[0] == nullptr) return;
  const std::string path = SelfExecutable();
  if (path.empty() || IsDynamicLoader(path)) return;
  if (!SetHugePagesTunable()) return;
  execv(path.c_str(), argv);
  // Not re-executed: this process keeps its small pages.
}

}  // namespace meshgauge::cli
