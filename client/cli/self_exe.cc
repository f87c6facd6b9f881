#include "client/cli/self_exe.h"

#include <limits.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"

namespace meshgauge::cli {

std::string SelfExecutable() {
  char exe[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
  if (n <= 0) return "";
  return std::string(exe, n);
}

bool IsDynamicLoader(const std::string& path) {
  const std::string name = path.substr(path.rfind('/') + 1);
  return name.rfind("ld-", 0) == 0 || name.rfind("ld.so", 0) == 0;
}

absl::Status ExecSibling(const char* name, char** argv) {
  std::string self = SelfExecutable();
  if (!self.empty() && IsDynamicLoader(self)) {
    self = argv[0] != nullptr && std::strchr(argv[0], '/') ? argv[0] : "";
  }
  if (self.empty()) {
    return absl::NotFoundError(absl::StrCat(
        "cannot find ", name,
        " (it runs the remote verbs): this program's directory is unknown; "
        "run ",
        name, " itself"));
  }
  const std::string path = self.substr(0, self.rfind('/') + 1) + name;
  if (access(path.c_str(), X_OK) != 0) {
    return absl::NotFoundError(absl::StrCat(
        path, " is missing or not executable (", std::strerror(errno),
        "): it runs the remote verbs and must be installed beside ", self));
  }
  execv(path.c_str(), argv);
  return absl::InternalError(
      absl::StrCat("cannot run ", path, ": ", std::strerror(errno)));
}

}  // namespace meshgauge::cli
