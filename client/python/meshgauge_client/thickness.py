"""Minimum thickness with the KS constraint: the margin that holds, and the
final check (docs/python.md, "A margin that holds").

The aggregated constraint (SPEC v2 §7, form "ks")

    G = (1/rho) ln( (1/|Gamma|) integral of exp(rho (1 - t/t_min)) )

is an area mean, so G <= 0 still allows spots thinner than t_min: if the
thinnest point has weight w (its share of the surface in the integral),
G <= 0 only gives

    min t >= t_min (1 - ln(1/w) / rho),

e.g. 12 % under t_min with rho = 50 and w = 1/400. Two ways to a margin:

* a priori (``ks_t_min``): constrain at t_min' = t_min / (1 - ln(1/w)/rho)
  with w the smallest weight (``min_weight_fraction``). With face samples
  (samples="faces") the constraint's points are the faces themselves, so
  G(t_min') <= 0 guarantees every face's value >= t_min. With vertex
  samples the points are quadrature points inside the triangles (weights
  |triangle|/3; |segment|/2 in 2D), whose values interpolate the vertices':
  the bound holds there, not at the vertices, so also check.
* a posteriori (``check``, Session.check_thickness): measure the values
  after the optimiser stopped; if the minimum (or the quantile asked for)
  is short of t_min, multiply the constraint's t_min by ``ratio`` and run
  the optimiser again from where it stopped.
"""

import math
from typing import Any, Sequence

import numpy as np

from meshgauge_client.results import SdfResult, ThicknessCheck


def _measures(vertices: Any, faces: Sequence[Any]) -> "list[list[float]]":
    """Per face, the measures of its integration elements: its length (a
    segment), or its fan triangles' areas (v0, v_k, v_k+1), as the server
    integrates them."""
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] not in (2, 3):
        raise ValueError(f"vertices must have shape (N, 2) or (N, 3), got "
                         f"{v.shape}")
    out = []
    for f in faces:
        idx = np.asarray(f, dtype=np.int64).ravel()
        if idx.size == 2:
            out.append([float(np.linalg.norm(v[idx[1]] - v[idx[0]]))])
            continue
        p = v[idx]
        if p.shape[1] == 2:
            p = np.hstack([p, np.zeros((len(p), 1))])
        tris = [0.5 * float(np.linalg.norm(np.cross(p[k] - p[0],
                                                    p[k + 1] - p[0])))
                for k in range(1, len(p) - 1)]
        out.append(tris)
    return out


def min_weight_fraction(vertices: Any, faces: Sequence[Any],
                        samples: str = "faces") -> float:
    """The smallest weight of a point of the KS constraint, as a share of
    the surface: samples "faces", the smallest face's area (length in 2D)
    over the total; "vertices", the smallest quadrature point's weight,
    |triangle|/3 (|segment|/2) over the total. Zero-area faces are left
    out (they weigh nothing)."""
    if samples not in ("faces", "vertices"):
        raise ValueError(f"samples must be 'faces' or 'vertices', got "
                         f"{samples!r}")
    measures = _measures(vertices, faces)
    total = sum(sum(m) for m in measures)
    if not total > 0:
        raise ValueError("the surface has no area")
    if samples == "faces":
        weights = [sum(m) for m in measures]
    else:
        weights = [e / (2 if len(m) == 1 and len(f) == 2 else 3)
                   for m, f in zip(measures, faces) for e in m]
    positive = [w for w in weights if w > 0]
    return min(positive) / total


def ks_t_min(t_min: float, rho: float, weight_fraction: float) -> float:
    """The t_min to give the KS constraint so that G <= 0 keeps every point
    of weight share >= weight_fraction at or above t_min:
    t_min / (1 - ln(1/weight_fraction) / rho). ValueError when rho is too
    small for that share (rho <= ln(1/weight_fraction): no finite margin
    holds; raise rho)."""
    if not (t_min > 0 and math.isfinite(t_min)):
        raise ValueError(f"t_min must be finite and > 0, got {t_min}")
    if not (rho > 0 and math.isfinite(rho)):
        raise ValueError(f"rho must be finite and > 0, got {rho}")
    if not 0 < weight_fraction <= 1:
        raise ValueError(f"weight_fraction must be in (0, 1], got "
                         f"{weight_fraction}")
    slack = math.log(1 / weight_fraction) / rho
    if slack >= 1:
        raise ValueError(
            f"rho = {rho} is too small for a point of {weight_fraction:.3g} "
            f"of the surface: G <= 0 allows it any thickness; use rho > "
            f"{math.log(1 / weight_fraction):.3g}")
    return t_min / (1 - slack)


def check(result: SdfResult, t_min: float,
          quantile: float = 0.0) -> ThicknessCheck:
    """The final check of an optimisation: the `quantile` of the values (0:
    the minimum; 0.05: the 5th percentile, linear interpolation) against
    t_min. ok needs every sample to have a value."""
    if not (t_min > 0 and math.isfinite(t_min)):
        raise ValueError(f"t_min must be finite and > 0, got {t_min}")
    if not 0 <= quantile <= 1:
        raise ValueError(f"quantile must be in [0, 1], got {quantile}")
    values = np.asarray(result.values, dtype=np.float64)
    valued = values[np.isfinite(values)]
    missing = int(values.size - valued.size)
    measured = (float(np.quantile(valued, quantile)) if valued.size
                else math.nan)
    ok = missing == 0 and valued.size > 0 and measured >= t_min
    ratio = t_min / measured if measured > 0 else math.inf
    return ThicknessCheck(t_min, quantile, measured, missing, ok,
                          max(ratio, 1.0), result.summary.samples)


__all__ = ["check", "ks_t_min", "min_weight_fraction"]
