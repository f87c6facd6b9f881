#!/usr/bin/env bash
# The CLI's two programs (client/CMakeLists.txt): `meshgauge` runs the local
# verbs without linking gRPC or Protobuf (its start-up does not load them)
# and hands `remote ...` and --help-all to `meshgauge-remote` beside it, with
# the same arguments and exit codes; without that program the remote verbs
# fail with an error naming it, and the local verbs still work.
# Usage: cli_split_test.sh CLI CLI_REMOTE MESH
# Outputs are captured before they are matched: `PROGRAM | grep -q` fails
# under pipefail when grep exits before PROGRAM has written everything.
set -euo pipefail
cli=$1 remote=$2 mesh=$3
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

needed=$(readelf -d "$cli" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p')
echo "meshgauge needs: $(tr '\n' ' ' <<<"$needed")"
[[ -n $needed ]] || fail "readelf found no NEEDED entries in $cli"
if grep -E 'grpc|protobuf|libssl|libcrypto|libcares|libre2|libupb' <<<"$needed"; then
  fail "the local CLI links the libraries above"
fi
[[ $(readelf -d "$remote") == *'libgrpc++'* ]] ||
  fail "meshgauge-remote does not link gRPC (is this the right program?)"

# A remote verb through the local program: meshgauge-remote's error and
# exit code (1), the status code first; also when flags come first and when
# the program is run through the dynamic loader.
set +e
out=$("$cli" remote list --server "unix://$tmp/no-server" --connect-timeout 1 2>&1)
code=$?
set -e
echo "$out"
[[ $code == 1 && $out == *"meshgauge: error: UNAVAILABLE"* ]] ||
  fail "remote list without a server: exit $code"
# Through the dynamic loader, with a missing file (it fails before any
# connection, so no retries to wait for).
loader=$(readelf -l "$cli" | sed -n 's/.*program interpreter: \(.*\)\]/\1/p')
set +e
out=$("$loader" "$cli" remote sdf "$tmp/none.obj" 2>&1)
code=$?
set -e
[[ $code == 1 && $out == *"meshgauge: error: NOT_FOUND: cannot open mesh"* ]] ||
  fail "through $loader: exit $code: $out"
[[ $("$cli" -h remote) == *upload* ]] || fail "-h remote lacks upload"
# A usage error under remote: exit 2, as before.
set +e
out=$("$cli" remote sdf --no-such-flag 2>&1)
code=$?
set -e
[[ $code == 2 && $out == *"usage error"* ]] ||
  fail "remote usage error: exit $code: $out"
# Help: the local program lists `remote`; --help-all has every remote flag.
[[ $("$cli" --help) == *$'\n  remote '* ]] || fail "--help does not list remote"
[[ $("$cli" --help-all) == *'upload MESH as a session'* ]] ||
  fail "--help-all lacks the remote verbs"
[[ $("$cli" remote --help) == *upload* ]] || fail "remote --help lacks upload"

# Alone in a directory: local verbs work, remote ones name the missing
# program (NOT_FOUND), --help-all lists the local verbs.
cp "$cli" "$tmp/meshgauge"
"$tmp/meshgauge" sdf "$mesh" --json >"$tmp/sdf.json" ||
  fail "a local verb failed without meshgauge-remote beside the CLI"
grep -q '"ok"' "$tmp/sdf.json" || fail "no summary from the local verb"
set +e
out=$("$tmp/meshgauge" remote list 2>&1)
code=$?
set -e
echo "$out"
[[ $code == 1 &&
   $out == *"meshgauge: error: NOT_FOUND: $tmp/meshgauge-remote is missing"* ]] ||
  fail "remote without meshgauge-remote: exit $code"
# --help-all then lists the local verbs.
[[ $("$tmp/meshgauge" --help-all) == *--cone-angle* ]] ||
  fail "--help-all without meshgauge-remote"

# What meshgauge-remote receives (a stand-in printing it): the same
# arguments and, for a file of 4 MiB or more, the huge-page tunable already
# set, so that it does not re-execute itself (and load gRPC) a second time;
# for small files no tunable.
cat >"$tmp/meshgauge-remote" <<'STAND_IN'
#!/usr/bin/env bash
echo "program=$0 args=$* tunables=${GLIBC_TUNABLES-unset}"
STAND_IN
chmod +x "$tmp/meshgauge-remote"
truncate -s 5M "$tmp/big.obj"
out=$(env -u GLIBC_TUNABLES "$tmp/meshgauge" remote sdf "$tmp/big.obj" --rays 3)
echo "$out"
[[ $out == "program=$tmp/meshgauge-remote args=remote sdf $tmp/big.obj --rays 3 tunables=glibc.malloc.hugetlb=1" ]] ||
  fail "meshgauge-remote got: $out"
out=$(env -u GLIBC_TUNABLES "$tmp/meshgauge" remote sdf "$mesh")
[[ $out == *"args=remote sdf $mesh tunables=unset" ]] ||
  fail "meshgauge-remote got, for a small file: $out"
echo PASS
