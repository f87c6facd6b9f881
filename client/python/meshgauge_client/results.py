"""Frozen results of the calls. Arrays are numpy; lengths are in mesh units;
N is the vertex count, d the dimension (2 or 3)."""

from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any, List, Optional, Tuple

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


class VertexStatus(IntEnum):
    """Why a vertex has (OK) or has no value (the wire's VertexStatus)."""

    OK = 1
    NO_HIT = 2             # no ray hit (or none was kept).
    NO_FACES = 3           # the vertex is on no face.
    DEGENERATE_NORMAL = 4  # its faces' normals cancel: no cone axis.


@dataclass(frozen=True)
class SdfSummary:
    """Counts and statistics of one ray pass."""

    generation: int
    ok: int
    no_hit: int
    no_faces: int
    degenerate_normal: int
    sdf_min: float          # NaN when no vertex has a value.
    sdf_median: float
    sdf_max: float
    sdf_mean: float
    integral: float         # of the SDF over the faces with values.
    rays: int
    seconds: float          # server-side compute time.
    reused_hits: bool       # served from the session's cached ray pass.
    world_frame_vertices: int  # cones that fell back to the world frame.
    missing_vertices: int   # vertices on faces but without a value.
    missing_faces: int
    missing_fraction: float  # share of the area those faces cover, [0, 1].
    # Per component with over 1 % of the surface missing: the likely cause.
    warnings: Tuple[str, ...] = ()
    samples: str = "vertices"  # where the values are: "vertices" or "faces".


@dataclass(frozen=True)
class SdfResult:
    """Shape diameter per sample (SPEC §5): N is the vertex count, or the
    face count with samples="faces" (each face's centroid along its own
    normal, SPEC v2 §5c; the Jacobian then has one row per face and a
    column per vertex coordinate).

    values: (N,) SDF, NaN unless status is OK (never a silent zero).
    status: (N,) VertexStatus values; ``status_names`` gives their names.
    hits, kept: (N,) rays that hit / that the filter kept.
    normalized: (N,) Shapira's normalised SDF in [0, 1], NaN unless OK.
    jacobian: scipy.sparse.csr_matrix (N, V*d) of dSDF_p/dx_j (column
    j*d + c, V vertices) when asked for, else None.
    opposite: (N, 3) with opposite_points=True, what each sample was
    measured against (SPEC v2 §5c: the normal ray's hit point, the cone's
    weighted mean hit point, the sphere's touching point; z = 0 in 2D), NaN
    unless OK; else None.
    """

    values: FloatArray
    status: IntArray
    hits: IntArray
    kept: IntArray
    normalized: FloatArray
    summary: SdfSummary
    jacobian: Optional[Any] = None
    opposite: Optional[FloatArray] = None

    def status_names(self) -> List[str]:
        return [VertexStatus(int(s)).name for s in self.status]


@dataclass(frozen=True)
class ThinRegion:
    """A connected set of faces whose linearly interpolated thickness falls
    below t_min. area: of the part below t_min (length in 2D); points are
    (x, y, z) in mesh units; speck: area < min_region_area."""

    faces: int
    area: float
    min_thickness: float
    min_vertex: int
    min_point: Tuple[float, float, float]
    centroid: Tuple[float, float, float]
    box_min: Tuple[float, float, float]
    box_max: Tuple[float, float, float]
    speck: bool


@dataclass(frozen=True)
class ThinSurface:
    """Where the surface is thinner than t_min: the largest regions first
    (region_count counts them all, sent or not); min_thickness is the
    smallest value of any vertex (min_vertex -1 when none has a value)."""

    t_min: float
    total_area: float
    missing_area: float
    thin_area: float
    min_thickness: float
    min_vertex: int
    min_point: Tuple[float, float, float]
    regions: List[ThinRegion]
    region_count: int

    @property
    def thin_fraction(self) -> float:
        """Share of the whole surface below t_min."""
        return self.thin_area / self.total_area if self.total_area else 0.0


@dataclass(frozen=True)
class PenaltyResult:
    """A penalty P = integral of phi(t) (length^(d-1)) or the aggregated
    constraint G (form "ks", dimensionless; bound it by 0) of SPEC v2 §7.

    gradient: (N, d) dP/dx (including the face-measure terms), or None.
    missing_fraction: share of the surface skipped for missing values.
    """

    value: float
    gradient: Optional[FloatArray]
    sdf_min: float
    missing_fraction: float
    missing_vertices: int
    skipped_faces: int
    world_frame_vertices: int
    generation: int
    reused_hits: bool
    form: str
    thin: Optional[ThinSurface] = None  # with thin_regions=True.


@dataclass(frozen=True)
class GradCheckRow:
    """One checked entry d SDF_row / d x_vertex[coordinate] (row -1: the
    penalty's derivative); clean False: the probe crossed an event (a hit
    or the kept set changed) even at the smallest step."""

    row: int
    vertex: int
    coordinate: int  # 0, 1, 2 = x, y, z.
    analytic: float
    fd: float  # the central difference.
    relative_error: float
    clean: bool
    step: float  # of the attempt kept, mesh units.


@dataclass(frozen=True)
class GradCheckReport:
    """The SPEC §6 finite-difference check run by the server (GradCheck).

    verdict: "PASS", "FAIL" (a clean entry, a VJP or a penalty entry
    disagrees: wrong derivatives) or "INCONCLUSIVE" (none disagrees, but
    fewer than min_clean_fraction of the entries are clean)."""

    verdict: str
    rows: List[GradCheckRow]
    penalty_rows: List[GradCheckRow]
    # One per VJP check (row -1): analytic g^T J against sum_p g_p fd_p.
    vjp_rows: List[GradCheckRow]
    clean: int
    passed: int
    worst: float
    vjp_checks: int
    vjp_passed: int
    penalty_clean: int
    penalty_passed: int
    max_abs_derivative: float
    median_abs_derivative: float
    world_frame_vertices: int
    rays_traced: int
    full_pass_rays: int
    probe_repeats: int
    generation: int
    seconds: float

    @property
    def ok(self) -> bool:
        return self.verdict == "PASS"


@dataclass(frozen=True)
class Calibration:
    """SPEC §8: SDF (cone) against physical thickness (normal ray), and the
    inscribed ball (sphere, SPEC v2 §5b) as a third column (ball_*)."""

    compared: int
    lower: int
    equal: int
    higher: int
    alpha1: float  # max(thickness) / t_min.
    alpha2: float  # min(SDF) / t_min.
    histogram_range: Tuple[float, float]
    sdf_histogram: IntArray
    thickness_histogram: IntArray
    ball_compared: int
    ball_lower: int
    ball_equal: int
    ball_higher: int
    ball_alpha: float  # min(ball) / t_min.
    ball_histogram: IntArray


@dataclass(frozen=True)
class ServerInfo:
    """The server's release version and the limits it applies to this
    client's tenant (GetServerInfo)."""

    version: str
    api: str
    max_rays: int
    max_vertices: int
    max_faces: int
    max_message_bytes: int
    max_upload_message_bytes: int
    max_sessions: int
    memory_budget_bytes: int
    max_upload_file_bytes: int = 0  # 0: the server predates file uploads.


@dataclass(frozen=True)
class MeshData:
    """A session's mesh as the server holds it (GetMesh)."""

    vertices: FloatArray  # (N, d) at `generation`.
    faces: "list[npt.NDArray[np.int64]]"  # 2, 3 or 4 indices each.
    regions: Optional["npt.NDArray[np.int32]"]  # per face, or None.
    generation: int


@dataclass(frozen=True)
class SessionInfo:
    """A session on the server."""

    session_id: str
    dimension: int
    num_vertices: int
    num_faces: int
    generation: int
    memory_bytes: int
    bvh_builds: int
    bvh_refits: int
    idle_seconds: float
    signed_volume: float
    closed: bool
    warnings: Tuple[str, ...] = field(default_factory=tuple)
    # A welded upload's map (CreateSessionResponse.welded_vertex): the
    # session vertex of each uploaded vertex; None when nothing merged (or
    # not from an upload). num_vertices counts the session's vertices.
    welded_vertex: Optional[IntArray] = field(default=None, compare=False)


@dataclass(frozen=True)
class ThicknessCheck:
    """The final check of a minimum-thickness optimisation
    (Session.check_thickness, thickness.check): `measured` is the
    `quantile` of the values with a value (0: the minimum), `missing` the
    samples without one; ok when none is missing and measured >= t_min.
    ratio = t_min / measured when short (else 1): the factor to raise the
    constraint's t_min by before running the optimiser again."""

    t_min: float
    quantile: float
    measured: float
    missing: int
    ok: bool
    ratio: float
    samples: str = "vertices"
