// Transparent huge pages for the CLI's large arrays (issue 27: on this
// project's machines page faults took most of the read and check stages of
// a million-vertex mesh).
#pragma once

#include <cstdint>

namespace meshgauge::cli {

// The CLI takes huge pages when an argument names a file of this size or
// more (main.cc).
inline constexpr int64_t kHugePagesFileBytes = int64_t{4} << 20;

// Whether one of argv[1..] (inputs and outputs alike; `--flag=path` is not
// split) names a regular file of at least `bytes`. `argv`: main's,
// null-terminated.
bool ArgumentNamesFileOfAtLeast(char** argv, int64_t bytes);

// glibc's malloc (2.35 and later) asks the kernel for transparent huge pages
// for its large chunks only when the tunable glibc.malloc.hugetlb=1 is in
// GLIBC_TUNABLES at start-up; the kernel grants them when its THP mode is
// "madvise" (Debian's default) or "always". Unless the tunable is named
// already, re-executes this program (the file /proc/self/exe links to, so
// that its process name stays; the same arguments, about 20 ms) with the
// tunable appended to GLIBC_TUNABLES. Does nothing in a secure-execution
// (setuid) process, whose loader drops the tunable, or when the program is
// run through the dynamic loader (`ld.so PROGRAM`). Returns when it does not
// re-execute or the re-execution failed (no /proc: the run goes on with
// small pages). A run under a tool that follows the process (valgrind)
// should set glibc.malloc.hugetlb=0. `argv`: main's, null-terminated. Call
// first in main, before any thread starts.
void ReexecWithHugePages(char** argv);

// Appends glibc.malloc.hugetlb=1 to GLIBC_TUNABLES, for a program this one
// executes (meshgauge-remote); false, changing nothing, when the tunable is
// named already or in a secure-execution process.
bool SetHugePagesTunable();

}  // namespace meshgauge::cli
