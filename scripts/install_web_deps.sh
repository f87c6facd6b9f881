#!/usr/bin/env bash
# Installs the report page's WebGL library (web/package.json pins three.js
# and the bundler esbuild; web/package-lock.json pins their exact files) from
# the npm registry (scripts/fetch_npm_lock.py: the lock's tarballs, their
# hashes checked; no node or npm needed), and bundles three.js with its OrbitControls into
# web/vendor/three.bundle.min.js (one minified script defining the global
# MG3), with three.js's licence next to it (web/vendor/three.LICENSE). CMake
# embeds both into the meshgauge CLI and the Python package, so neither needs
# node at run time. Idempotent: does nothing when the bundle is newer than
# the lock file.
set -euo pipefail
cd "$(dirname "$0")/../web"
out=vendor/three.bundle.min.js
if [ -s "$out" ] && [ -s vendor/three.LICENSE ] && [ "$out" -nt package-lock.json ] \
   && [ "$out" -nt three_entry.js ]; then
  echo "install_web_deps: $out is up to date"
  exit 0
fi
/usr/bin/python3 ../scripts/fetch_npm_lock.py .
mkdir -p vendor
version=$(/usr/bin/python3 -c 'import json; print(json.load(open("node_modules/three/package.json"))["version"])')
# esbuild's native binary, from its package for this os and cpu.
esbuild=$(ls node_modules/@esbuild/*/bin/esbuild)
"$esbuild" three_entry.js --bundle --minify --format=iife \
  --global-name=MG3 --target=es2020 --legal-comments=none \
  --banner:js="/* three.js r${version#0.} (https://threejs.org), MIT licence, see three.LICENSE; bundled by meshgauge's scripts/install_web_deps.sh */" \
  --outfile="$out.tmp" --log-level=warning
mv "$out.tmp" "$out"
cp node_modules/three/LICENSE vendor/three.LICENSE
echo "install_web_deps: three.js $version bundled into web/$out ($(wc -c <"$out") bytes)"
