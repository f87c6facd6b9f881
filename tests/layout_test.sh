#!/usr/bin/env bash
# The library layout's one-way dependencies, checked on the headers as a
# compiler sees them: no header of lib/core, lib/io, the wire conversion
# (proto/wire) or the client library (client/remote) includes Embree;
# lib/core includes nothing from lib/embree or lib/io; proto/wire nothing
# from lib/embree, lib/io, server/ or client/.
#   layout_test.sh CXX SOURCE_DIR GENERATED_PROTO_DIR
set -euo pipefail
CXX="$1" SRC="$2" GEN="$3"
fail=0
for header in "$SRC"/lib/core/*.h "$SRC"/lib/io/*.h "$SRC"/proto/wire/*.h \
    "$SRC"/client/remote/*.h; do
  deps=$(echo "#include \"${header#"$SRC"/}\"" |
    "$CXX" -std=c++20 -I"$SRC" -I"$GEN" -x c++ -M - 2>&1) || {
    echo "FAIL: $header does not compile alone"; echo "$deps"; fail=1; continue; }
  if grep -q "embree3/" <<<"$deps"; then
    echo "FAIL: ${header#"$SRC"/} pulls in Embree"; fail=1
  fi
  case "$header" in
    "$SRC"/lib/core/*)
      if grep -Eq "lib/(embree|io)/" <<<"$deps"; then
        echo "FAIL: ${header#"$SRC"/} depends on lib/embree or lib/io"; fail=1
      fi ;;
    "$SRC"/proto/wire/*)
      if grep -Eq "lib/(embree|io)/|$SRC/(server|client)/" <<<"$deps"; then
        echo "FAIL: ${header#"$SRC"/} depends on lib/embree, lib/io, server or client"
        fail=1
      fi ;;
  esac
done
checked=$(ls "$SRC"/lib/core/*.h "$SRC"/lib/io/*.h "$SRC"/proto/wire/*.h \
  "$SRC"/client/remote/*.h | wc -l)
if [ "$fail" -eq 0 ]; then
  echo "layout: $checked headers checked, none pulls Embree; lib/core is self-contained"
fi
exit "$fail"
