// Transparent huge pages for the CLI's large arrays (issue 27: on this
// project's machines page faults took most of the read and check stages of
// a million-vertex mesh).
#pragma once

#include <cstdint>

namespace meshgauge::cli {

// Whether GLIBC_TUNABLES names glibc.malloc.hugetlb (set to any value: a
// user's explicit 0 is respected).
bool HugePageTunableNamed();

// glibc's malloc (2.35 and later) asks the kernel for transparent huge pages
// for its large chunks only when the tunable glibc.malloc.hugetlb=1 is in
// GLIBC_TUNABLES at start-up; the kernel grants them when its THP mode is
// "madvise" (Debian's default) or "always". When the tunable is not named
// yet and one of the arguments argv[1..] names a regular file of at least
// `min_file_bytes` (a mesh large enough to repay the re-execution, about
// 20 ms), re-executes this program (/proc/self/exe, the same arguments)
// with the tunable appended to GLIBC_TUNABLES. Returns when it does not
// re-execute or the re-execution failed (no /proc: the run goes on with
// small pages). `argv`: main's, null-terminated. Call first in main, before
// any thread starts.
void ReexecWithHugePages(char** argv, int64_t min_file_bytes);

}  // namespace meshgauge::cli
