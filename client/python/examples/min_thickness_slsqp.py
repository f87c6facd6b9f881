#!/usr/bin/env python3
"""Minimum thickness that holds: scipy's SLSQP with the KS constraint, a
margin, and a final check that the measured minimum is at least t_min.

The part is thicken_plate.py's grooved plate (a 1 x 1 plate, 0.3 thick but
0.08 in a band across it), smaller (n = 6); the goal is t_min = 0.15. The
KS constraint G <= 0 is an area mean and allows spots up to
t_min ln(1/a)/rho thinner than t_min (a: the spot's share of the surface),
so constraining at t_min itself ends under it. Here:

1. with face samples (the default) the constraint is asked for at
   session.ks_t_min(t_min, rho) = t_min / (1 - ln(1/a_min)/rho), a_min the
   smallest face's share of the surface: G <= 0 then keeps every face's
   value at or above t_min (docs/python.md, "A margin that holds"); with
   --samples vertices it starts at t_min (the bound holds at the
   constraint's quadrature points, not at the vertices);
2. after SLSQP, session.check_thickness(t_min) measures the minimum (of the
   samples the constraint used: each face's value, or each vertex's); when
   it is short (SLSQP ends with G a little above 0, or vertex samples), the
   constraint's t_min is raised by the ratio missing plus 1 % and SLSQP
   runs again from where it stopped (at most --rounds runs);
3. the script fails (exit 1) unless the measured minimum is >= t_min.

    PYTHONPATH=build/python python3 \\
        client/python/examples/min_thickness_slsqp.py --server 127.0.0.1:50051
"""

import argparse
import os
import sys

import numpy as np
from scipy.optimize import minimize

from meshgauge_client import MeshGaugeClient

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from thicken_plate import grooved_plate  # noqa: E402


def optimise(client, t_min=0.15, rho=50.0, n=6, samples="faces", rounds=4,
             out=sys.stdout):
    """Runs SLSQP until the measured minimum is >= t_min (at most `rounds`
    runs); returns (the final ThicknessCheck, the targets given to the
    constraint, the distance moved |z - z0|)."""
    v0, faces, top, z0 = grooved_plate(n)
    with client.session(v0, faces) as session:
        target = (session.ks_t_min(t_min, rho) if samples == "faces"
                  else t_min)
        state = {}

        def evaluate(z):
            key = (z.tobytes(), target)
            if state.get("key") == key:
                return
            v = v0.copy()
            v[top, 2] = z
            session.update(v)
            g = session.constraint(target, rho=rho, samples=samples)
            state.update(key=key, g=g.value, grad=g.gradient[top, 2])

        def constraint(z):  # SLSQP wants fun(z) >= 0
            evaluate(z)
            return -state["g"]

        def constraint_jac(z):
            evaluate(z)
            return -state["grad"][np.newaxis, :]

        z = z0.copy()
        targets = []
        for _ in range(rounds):
            targets.append(target)
            result = minimize(
                lambda z: 0.5 * np.sum((z - z0) ** 2), z,
                jac=lambda z: z - z0, method="SLSQP",
                bounds=[(0.02, None)] * len(z0),
                constraints=[{"type": "ineq", "fun": constraint,
                              "jac": constraint_jac}],
                options={"maxiter": 100, "ftol": 1e-9})
            z = result.x
            evaluate(z)
            check = session.check_thickness(t_min, samples=samples)
            print(f"target {target:.5f}: SLSQP {result.message!r}, G "
                  f"{state['g']:+.2e}, measured minimum {check.measured:.5f}"
                  f" ({samples})", file=out)
            if check.ok or not np.isfinite(check.ratio):
                break
            target *= check.ratio * 1.01
        return check, targets, float(np.linalg.norm(z - z0))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--server", default="127.0.0.1:50051")
    ap.add_argument("--t-min", type=float, default=0.15)
    ap.add_argument("--rho", type=float, default=50.0)
    ap.add_argument("--samples", choices=("faces", "vertices"),
                    default="faces")
    ap.add_argument("--rounds", type=int, default=4)
    args = ap.parse_args(argv)
    with MeshGaugeClient(args.server) as client:
        check, targets, moved = optimise(client, args.t_min, args.rho,
                                         samples=args.samples,
                                         rounds=args.rounds)
    print(f"minimum {args.samples} SDF {check.measured:.5f} against t_min "
          f"{args.t_min} (constraint's t_min {targets[-1]:.5f}, moved "
          f"{moved:.4f}): " + ("holds" if check.ok else "FAILS"))
    return 0 if check.ok else 1


if __name__ == "__main__":
    sys.exit(main())
