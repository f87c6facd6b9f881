"""One optimiser iteration (move every vertex, SDF values, VJP with g = 1)
from the Python package against a running server: the same calls as
meshgauge_client_bench (scripts/bench_clients.sh runs both).

    python3 bench/python_client_bench.py TARGET MESH.obj [ITERATIONS]

(MESH.obj as meshgauge_client_bench --dump writes it.)
"""

import math
import sys
import time

import numpy as np

from meshgauge_client import MeshGaugeClient


def read_obj(path):
    """Vertices (N, 3) and triangle faces (M, 3) of an OBJ written by
    meshgauge (`v` and `f` lines only)."""
    vertices, faces = [], []
    with open(path) as f:
        for line in f:
            parts = line.split()
            if parts and parts[0] == "v":
                vertices.append([float(x) for x in parts[1:4]])
            elif parts and parts[0] == "f":
                faces.append([int(x) - 1 for x in parts[1:]])
    return np.array(vertices), np.array(faces)


def main(argv):
    target, mesh_path = argv[1], argv[2]
    iterations = int(argv[3]) if len(argv) > 3 else 5
    vertices, faces = read_obj(mesh_path)
    with MeshGaugeClient(target) as client:
        with client.session(vertices, faces, session_id="py-bench") as s:
            ones = np.ones(len(vertices))
            best = math.inf
            for i in range(iterations):
                moved = vertices * (1 + 1e-5 * math.sin(1.0 + i))
                start = time.perf_counter()
                s.update(moved)
                s.sdf()
                s.vjp(ones)
                best = min(best, time.perf_counter() - start)
    print(f"Python client iteration: {best:.4f} s (best of {iterations})")


if __name__ == "__main__":
    main(sys.argv)
