#!/usr/bin/env bash
# The CLI's transparent huge pages (client/cli/huge_pages.h), through
# huge_pages_probe, which starts as the CLI's main does: given a large enough
# file and no tunable, the program re-executes itself with
# glibc.malloc.hugetlb=1 and its large arrays sit in huge pages; given only
# small files it does not; a user's explicit value is kept (0: no huge
# pages) and their other tunables survive.
# Usage: huge_pages_test.sh PROBE CLI
set -euo pipefail
probe=$1 cli=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
field() { sed -n "s/^$1=//p" <<<"$2"; }
thp=$(cat /sys/kernel/mm/transparent_hugepage/enabled 2>/dev/null || echo "[never]")
echo "kernel THP mode: $thp"
truncate -s 1000 "$tmp/small"
truncate -s 5000 "$tmp/large"

out=$(env -u GLIBC_TUNABLES "$probe" 5000 --flag "$tmp/small" "$tmp/large")
echo "$out"
[[ $(field GLIBC_TUNABLES "$out") == glibc.malloc.hugetlb=1 &&
   $(field exec_hugetlb "$out") == 1 ]] ||
  fail "the probe did not re-execute itself with glibc.malloc.hugetlb=1"
comm=$(field comm "$out")  # (the kernel keeps 15 characters)
[[ -n $comm && huge_pages_probe == "$comm"* ]] ||
  fail "the re-executed process is named '$comm'"
sanitized=$(field sanitized "$out")
if [[ $thp != *"[never]"* && $sanitized == 0 ]]; then
  (($(field AnonHugePages "$out") > 0)) ||
    fail "with glibc.malloc.hugetlb=1 no memory is in huge pages"
fi

out=$(env -u GLIBC_TUNABLES "$probe" 5000 "$tmp/small" "$tmp")
[[ -z $(field GLIBC_TUNABLES "$out") && -z $(field exec_hugetlb "$out") ]] ||
  fail "re-executed without a file of the size asked for"
# With the kernel in madvise mode only the tunable brings huge pages: none
# here shows that the first run's came from it.
if [[ $thp == *"[madvise]"* && $sanitized == 0 ]]; then
  (($(field AnonHugePages "$out") == 0)) ||
    fail "huge pages without the tunable in madvise mode"
fi

# Run through the dynamic loader, /proc/self/exe is the loader: no
# re-execution (it would start the loader on the first argument).
loader=$(readelf -l "$probe" 2>/dev/null | sed -n 's/.*interpreter: \(.*\)]/\1/p')
if [[ -x $loader ]]; then
  out=$(env -u GLIBC_TUNABLES "$loader" "$probe" 5000 "$tmp/large")
  [[ -z $(field exec_hugetlb "$out") ]] ||
    fail "re-executed when run through the loader $loader"
fi

out=$(GLIBC_TUNABLES=glibc.malloc.hugetlb=0 "$probe" 0 "$tmp/large")
[[ $(field GLIBC_TUNABLES "$out") == glibc.malloc.hugetlb=0 ]] ||
  fail "a user's glibc.malloc.hugetlb=0 was overridden"

out=$(GLIBC_TUNABLES=glibc.malloc.arena_max=2 "$probe" 0 "$tmp/large")
[[ $(field GLIBC_TUNABLES "$out") == glibc.malloc.arena_max=2:glibc.malloc.hugetlb=1 &&
   $(field exec_hugetlb "$out") == 1 ]] ||
  fail "the user's other tunables were not kept: $(field GLIBC_TUNABLES "$out")"

# The CLI itself, re-executed for a large file, with its arguments intact:
# it reads the file and rejects its contents.
head -c $((5 << 20)) /dev/zero >"$tmp/zeros.obj"
set +e
message=$(env -u GLIBC_TUNABLES "$cli" sdf "$tmp/zeros.obj" 2>&1)
code=$?
set -e
echo "$message"
((code == 1)) && [[ $message == *zeros.obj* ]] ||
  fail "meshgauge sdf on a large file exited $code"
echo "huge pages: PASS"
