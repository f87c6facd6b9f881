"""The one conversion layer between Python arguments and the wire types."""

import math
from typing import Any, Optional, Sequence, Tuple

import grpc
import numpy as np
import numpy.typing as npt

from meshgauge_client._stubs import pb
from meshgauge_client.errors import DataLossError
from meshgauge_client.results import (Calibration, FloatArray,
                                      GradCheckReport, GradCheckRow, MeshData,
                                      PenaltyResult,
                                      SdfSummary, SessionInfo, ThinRegion,
                                      ThinSurface)

METHODS = {"cone": pb.SDF_METHOD_CONE, "normal": pb.SDF_METHOD_NORMAL_RAY,
           "sphere": pb.SDF_METHOD_SPHERE}
NORMALS = {"area": pb.NORMAL_WEIGHTING_AREA, "angle": pb.NORMAL_WEIGHTING_ANGLE}
SAMPLES = {"vertices": pb.SAMPLE_SET_VERTICES, "faces": pb.SAMPLE_SET_FACES}
FORMS = {"one-sided": pb.PENALTY_FORM_ONE_SIDED,
         "thesis": pb.PENALTY_FORM_THESIS, "ks": pb.PENALTY_FORM_KS}


def _choice(name: str, value: str, table: "dict[str, Any]") -> Any:
    if not isinstance(value, str) or value not in table:
        raise ValueError(f"{name} must be one of {sorted(table)}, got {value!r}")
    return table[value]


def _number(name: str, value: float, lo: float, hi: float,
            lo_open: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"{name} must be a number, got {type(value).__name__}")
    v = float(value)
    if not math.isfinite(v) or v < lo or v > hi or (lo_open and v == lo):
        bracket = "(" if lo_open else "["
        close = ")" if math.isinf(hi) else "]"
        raise ValueError(f"{name} must be finite and in {bracket}{lo}, {hi}"
                         f"{close}, got {value}")
    return v


def _flag(name: str, value: Any) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool, got {type(value).__name__}")
    return bool(value)


def sdf_params(method: str = "cone", cone_angle: float = 30.0, rays: int = 0,
               kappa: float = 1.0, max_distance: float = 0.0,
               normals: str = "area", contact_angle: float = 60.0,
               opposite_points: bool = False, samples: str = "vertices"
               ) -> Any:
    """SdfParameters from the CLI's flag names and defaults: method
    cone|normal|sphere, cone_angle in (0, 180) degrees, rays 1..4096 (0: 100
    in 3D, 32 in 2D), kappa >= 0, max_distance >= 0 (0: bounding-box
    diagonal), normals area|angle, contact_angle (sphere) in (0, 90)
    degrees, opposite_points a bool, samples vertices|faces."""
    if isinstance(rays, bool) or not isinstance(rays, (int, np.integer)):
        raise TypeError(f"rays must be an int, got {type(rays).__name__}")
    if not 0 <= int(rays) <= 4096:
        raise ValueError(f"rays must be in [1, 4096] (0 = default), got {rays}")
    angle = _number("cone_angle", cone_angle, 0, 180, lo_open=True)
    if angle == 180:
        raise ValueError("cone_angle must be below 180 degrees")
    contact = _number("contact_angle", contact_angle, 0, 90, lo_open=True)
    if contact == 90:
        raise ValueError("contact_angle must be below 90 degrees")
    return pb.SdfParameters(
        method=_choice("method", method, METHODS),
        cone_angle_degrees=angle, rays=int(rays),
        kappa=_number("kappa", kappa, 0, math.inf),
        max_distance=_number("max_distance", max_distance, 0, math.inf),
        normal_weighting=_choice("normals", normals, NORMALS),
        contact_angle_degrees=contact,
        opposite_points=_flag("opposite_points", opposite_points),
        samples=_choice("samples", samples, SAMPLES))


def points(array: Any, name: str, rows: Optional[int] = None) -> FloatArray:
    """An (n, d) float64 array, d = 2 or 3, finite, n = rows if given."""
    a = np.asarray(array, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] not in (2, 3):
        raise ValueError(f"{name} must have shape (N, 2) or (N, 3), got {a.shape}")
    if rows is not None and a.shape[0] != rows:
        raise ValueError(f"{name} must have {rows} rows, got {a.shape[0]}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} has non-finite values")
    return a


MAX_POLYGON_CORNERS = 256


def _indices(a: Any, what: str) -> "npt.NDArray[np.int64]":
    """`a` as int64 vertex indices: integers (or floats holding integers)
    in [0, 2**31 - 1]; anything else is a ValueError (never truncated)."""
    if a.dtype.kind == "f":
        if not np.all(np.isfinite(a)) or np.any(a != np.floor(a)):
            raise ValueError(f"{what} holds indices that are not integers")
    elif a.dtype.kind not in "iu":
        raise ValueError(f"{what} must hold integer indices, got {a.dtype}")
    if a.size and (a.min() < 0 or a.max() > 2**31 - 1):
        raise ValueError(f"{what} holds indices outside [0, 2**31 - 1]")
    out: "npt.NDArray[np.int64]" = a.astype(np.int64)
    return out


def faces_list(faces: Any, dimension: int) -> "list[npt.NDArray[np.int64]]":
    """Faces as int64 index arrays: 2 per segment (2D); 3 to 256 corners in
    3D (polygons of more than 4 are triangulated by the server)."""
    if isinstance(faces, np.ndarray) and faces.ndim == 2 and \
            faces.dtype != object:
        out = list(_indices(faces, "faces"))
    else:
        out = [_indices(np.asarray(f).ravel(), f"face {i}")
               for i, f in enumerate(faces)]
    low, high = (2, 2) if dimension == 2 else (3, MAX_POLYGON_CORNERS)
    for i, f in enumerate(out):
        if not low <= len(f) <= high:
            raise ValueError(
                f"face {i} has {len(f)} corners; {dimension}D faces have "
                + ("2 (segments)" if dimension == 2
                   else f"3 to {MAX_POLYGON_CORNERS}"))
    if not out:
        raise ValueError("faces must not be empty")
    return out


# meshio's linear surface cells (second-order ones such as triangle6 hold
# edge midpoints, not corners).
_MESHIO_SURFACE_CELLS = ("triangle", "quad", "line", "polygon")


def mesh_arrays(mesh: Any) -> Tuple[Any, Any]:
    """(vertices, faces) of a mesh object: trimesh-like (.vertices, .faces),
    Open3D-like (.vertices, .triangles) or meshio-like (.points and .cells
    blocks of type triangle, quad, polygon or line). Faces may be an (M, k)
    array or a list of index sequences of any length (polygons)."""
    if hasattr(mesh, "points") and hasattr(mesh, "cells"):
        faces: "list[Any]" = []
        for block in mesh.cells:
            kind = str(getattr(block, "type", None))
            if kind not in _MESHIO_SURFACE_CELLS:
                raise ValueError(f"meshio cell block of type {kind!r}: only "
                                 "triangle, quad, polygon and line cells are "
                                 "surfaces")
            faces.extend(np.asarray(f, dtype=np.int64) for f in block.data)
        return np.asarray(mesh.points, dtype=np.float64), faces
    vertices = getattr(mesh, "vertices", None)
    faces_attr = getattr(mesh, "faces", None)
    if faces_attr is None:
        faces_attr = getattr(mesh, "triangles", None)
    if vertices is None or faces_attr is None:
        raise TypeError(
            f"{type(mesh).__name__} is not a mesh: pass (vertices, faces), or "
            "an object with .vertices and .faces (trimesh), .vertices and "
            ".triangles (Open3D), or .points and .cells (meshio)")
    if isinstance(faces_attr, np.ndarray) and faces_attr.dtype != object:
        return np.asarray(vertices, dtype=np.float64), faces_attr
    return np.asarray(vertices, dtype=np.float64), list(faces_attr)


def flat(values: Sequence[float], dimension: int) -> FloatArray:
    return np.asarray(values, dtype=np.float64).reshape(-1, dimension)


def mesh_data(r: Any) -> MeshData:
    sizes = np.asarray(r.face_sizes, dtype=np.int64)
    indices = np.asarray(r.face_indices, dtype=np.int64)
    ends = np.cumsum(sizes)
    faces = [indices[e - n:e] for n, e in zip(sizes, ends)]
    regions = (np.asarray(r.face_regions, dtype=np.int32)
               if len(r.face_regions) else None)
    return MeshData(flat(r.positions, r.dimension), faces, regions,
                    r.generation)


def session_info(s: Any, welded_vertex: Optional[Any] = None) -> SessionInfo:
    return SessionInfo(s.session_id, s.dimension, s.num_vertices, s.num_faces,
                       s.generation, s.memory_bytes, s.bvh_builds,
                       s.bvh_refits, s.idle_seconds, s.signed_volume, s.closed,
                       tuple(s.warnings), welded_vertex)


def summary(s: Any) -> SdfSummary:
    return SdfSummary(s.generation, s.ok, s.no_hit, s.no_faces,
                      s.degenerate_normal, s.sdf_min, s.sdf_median, s.sdf_max,
                      s.sdf_mean, s.integral, s.rays, s.seconds, s.reused_hits,
                      s.world_frame_vertices, s.missing.vertices,
                      s.missing.faces, s.missing.area_fraction,
                      tuple(s.warnings),
                      "faces" if s.samples == pb.SAMPLE_SET_FACES
                      else "vertices")


def _point(p: Any, field: str) -> Tuple[float, float, float]:
    if len(p) != 3:
        raise DataLossError(grpc.StatusCode.DATA_LOSS,
                            f"thin region {field} has {len(p)} values, not 3")
    return (float(p[0]), float(p[1]), float(p[2]))


def thin_surface(t: Any, t_min: float) -> ThinSurface:
    regions = [ThinRegion(r.faces, r.area, r.min_thickness, r.min_vertex,
                          _point(r.min_point, "min_point"),
                          _point(r.centroid, "centroid"),
                          _point(r.box_min, "box_min"),
                          _point(r.box_max, "box_max"), r.speck)
               for r in t.regions]
    return ThinSurface(t_min, t.total_area, t.missing_area, t.thin_area,
                       t.min_thickness, t.min_vertex,
                       _point(t.min_point, "min_point"), regions,
                       t.region_count)


def penalty(resp: Any, dimension: int, form: str, t_min: float,
            with_thin: bool) -> PenaltyResult:
    gradient = flat(resp.gradient, dimension) if len(resp.gradient) else None
    thin = thin_surface(resp.thin, t_min) if with_thin else None
    return PenaltyResult(resp.value, gradient, resp.sdf_min,
                         resp.missing.area_fraction, resp.missing.vertices,
                         resp.missing.faces, resp.world_frame_vertices,
                         resp.generation, resp.reused_hits, form, thin)


VERDICTS = {pb.GRAD_CHECK_VERDICT_PASS: "PASS",
            pb.GRAD_CHECK_VERDICT_FAIL: "FAIL",
            pb.GRAD_CHECK_VERDICT_INCONCLUSIVE: "INCONCLUSIVE"}


def _grad_row(r: Any) -> GradCheckRow:
    if r.coordinate not in (0, 1, 2):
        raise DataLossError(grpc.StatusCode.DATA_LOSS,
                            f"gradcheck row with coordinate {r.coordinate}")
    return GradCheckRow(r.row, r.vertex, r.coordinate, r.analytic, r.fd,
                        r.relative_error, r.clean, r.step)


def gradcheck(r: Any) -> GradCheckReport:
    if r.verdict not in VERDICTS:
        raise DataLossError(grpc.StatusCode.DATA_LOSS,
                            f"gradcheck verdict {r.verdict}")
    return GradCheckReport(
        VERDICTS[r.verdict], [_grad_row(x) for x in r.rows],
        [_grad_row(x) for x in r.penalty_rows],
        [_grad_row(x) for x in r.vjp_rows], r.clean, r.passed, r.worst,
        r.vjp_checks, r.vjp_passed, r.penalty_clean, r.penalty_passed,
        r.max_abs_derivative, r.median_abs_derivative,
        r.world_frame_vertices, r.rays_traced, r.full_pass_rays,
        r.probe_repeats, r.generation, r.seconds)


def calibration(r: Any) -> Calibration:
    return Calibration(r.compared, r.sdf_lower, r.sdf_equal, r.sdf_higher,
                       r.alpha1, r.alpha2, (r.histogram_lo, r.histogram_hi),
                       np.asarray(r.sdf_histogram, dtype=np.int64),
                       np.asarray(r.thickness_histogram, dtype=np.int64),
                       r.ball_compared, r.ball_lower, r.ball_equal,
                       r.ball_higher, r.ball_alpha,
                       np.asarray(r.ball_histogram, dtype=np.int64))
