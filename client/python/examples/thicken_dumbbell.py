#!/usr/bin/env python3
"""Remote optimiser example: thicken the neck of a 2D dumbbell.

The dumbbell (two discs joined by a neck thinner than t_min) is uploaded to a
meshgauge server once; every iteration moves its vertices on the server
(UpdatePositions: a BVH refit) and asks for the minimum-thickness penalty and
its gradient (ComputePenalty). The design variables are all vertex
positions; the objective is

    f(x) = P(x) + mu/2 |L x|^2 + lam/2 |x - x0|^2

with P the one-sided penalty max(0, 1 - t/t_target)^2 integrated over the
curve (t_target slightly above t_min so the one-sided penalty does not
vanish just before the goal), L the discrete curve Laplacian (smoothness) and
the last term an anchor. Gradient descent with a backtracking line search
inside a trust region (no vertex moves more than a fifth of the element size
per iteration, so the curve never folds); the minimum SDF is printed every
iteration until it reaches t_min.

    PYTHONPATH=build/python \\
        python3 client/python/examples/thicken_dumbbell.py --server 127.0.0.1:50051
"""

import argparse
import sys

import numpy as np
import scipy.sparse as sp

from meshgauge_client import MeshGaugeClient


def dumbbell(radius=1.0, centre=1.8, neck=0.3, h=0.05):
    """CCW closed polyline: two discs at (+-centre, 0) and a neck of width
    `neck`. Returns (vertices (N, 2), segments (N, 2))."""
    phi = np.arcsin(neck / 2 / radius)
    x_join = centre - radius * np.cos(phi)
    pts = []

    def arc(cx, a0, a1):
        n = max(8, int(np.ceil(radius * abs(a1 - a0) / h)))
        for a in np.linspace(a0, a1, n, endpoint=False):
            pts.append((cx + radius * np.cos(a), radius * np.sin(a)))

    def line(p, q):
        n = max(2, int(np.ceil(np.hypot(q[0] - p[0], q[1] - p[1]) / h)))
        for s in np.linspace(0, 1, n, endpoint=False):
            pts.append((p[0] + s * (q[0] - p[0]), p[1] + s * (q[1] - p[1])))

    arc(centre, -(np.pi - phi), np.pi - phi)              # right lobe
    line((x_join, neck / 2), (-x_join, neck / 2))          # top of neck
    arc(-centre, phi, 2 * np.pi - phi)                     # left lobe
    line((-x_join, -neck / 2), (x_join, -neck / 2))        # bottom of neck
    v = np.array(pts)
    n = len(v)
    return v, np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)


def laplacian(n):
    """L x_i = x_i - (x_{i-1} + x_{i+1}) / 2 on a closed curve."""
    i = np.arange(n)
    return (sp.eye(n) - 0.5 * sp.csr_matrix((np.ones(n), (i, (i + 1) % n)), (n, n))
            - 0.5 * sp.csr_matrix((np.ones(n), (i, (i - 1) % n)), (n, n))).tocsr()


def optimise(client, t_min=0.6, neck=0.3, max_iterations=200, mu=0.5,
             lam=1e-3, h=0.05, out=sys.stdout):
    """Runs the optimisation; returns the list of minimum SDFs per iteration."""
    x0, segments = dumbbell(neck=neck, h=h)
    max_move = 0.2 * h
    session = client.session(x0, segments)
    L = laplacian(len(x0))
    LtL = (L.T @ L).tocsr()
    t_target = 1.15 * t_min
    x = x0.copy()

    def objective(x):
        session.update(x)
        pen = session.penalty(t_target)
        reg = 0.5 * mu * np.sum((L @ x) ** 2) + 0.5 * lam * np.sum((x - x0) ** 2)
        g = pen.gradient + mu * (LtL @ x) + lam * (x - x0)
        return pen.value + reg, g, pen.sdf_min

    f, g, sdf_min = objective(x)
    history = [sdf_min]
    step = 1.0
    print(f"iteration   0  min SDF {sdf_min:.4f}  objective {f:.6f}", file=out)
    for it in range(1, max_iterations + 1):
        if sdf_min >= t_min:
            break
        # Backtracking (Armijo) along -g, inside the trust region.
        step = min(step, max_move / np.max(np.linalg.norm(g, axis=1)))
        while True:
            x_new = x - step * g
            f_new, g_new, sdf_new = objective(x_new)
            if f_new <= f - 1e-4 * step * np.sum(g * g) or step < 1e-6:
                break
            step *= 0.5
        x, f, g, sdf_min = x_new, f_new, g_new, sdf_new
        step *= 2.0
        history.append(sdf_min)
        print(f"iteration {it:3d}  min SDF {sdf_min:.4f}  objective {f:.6f}  "
              f"step {step:.3g}", file=out)
    session.close()
    return history


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--server", default="127.0.0.1:50051")
    ap.add_argument("--t-min", type=float, default=0.6)
    ap.add_argument("--neck", type=float, default=0.3)
    ap.add_argument("--max-iterations", type=int, default=200)
    args = ap.parse_args(argv)
    with MeshGaugeClient(args.server) as client:
        history = optimise(client, args.t_min, args.neck, args.max_iterations)
    reached = history[-1] >= args.t_min
    print(f"{'reached' if reached else 'did not reach'} t_min = {args.t_min} "
          f"after {len(history) - 1} iterations (min SDF {history[-1]:.4f})")
    return 0 if reached else 1


if __name__ == "__main__":
    sys.exit(main())
