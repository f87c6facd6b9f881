// The CLI's own executable and the programs installed beside it.
#pragma once

#include <string>

#include "absl/status/status.h"

namespace meshgauge::cli {

// The path /proc/self/exe links to; empty when it cannot be read (no /proc).
std::string SelfExecutable();

// Whether `path` names the dynamic loader (ld-linux-*.so, ld.so): what
// SelfExecutable() gives for a program run as `ld.so PROGRAM`.
bool IsDynamicLoader(const std::string& path);

// Replaces this process with the program `name` in this program's
// directory (SelfExecutable()'s; argv[0]'s when run through the dynamic
// loader), with the same arguments (argv[0] kept, so that usage messages
// still name the command the user typed) and environment. Returns only on
// failure: NotFound naming the path when there is no such executable (or
// no way to tell the directory), Internal with errno's text when execv
// fails otherwise. `argv`: main's, null-terminated.
absl::Status ExecSibling(const char* name, char** argv);

}  // namespace meshgauge::cli
