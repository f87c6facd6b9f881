# Sourced by the client benchmarks: MESH and N from the arguments ($1, $2;
# igea and 5 by default), dependencies installed, the build current, and a
# temporary directory $tmp.
MESH="${1:-data/meshes/igea-triangles.ply}"
N="${2:-5}"
scripts/install_deps.sh >/dev/null
scripts/build.sh >/dev/null
tmp=$(mktemp -d)
