"""Welded sessions: between the caller's (uploaded) vertices and the
session's, as pure functions of the map the server returns
(CreateSessionResponse.welded_vertex).

A welded upload merges duplicate vertices; the session then has S vertices
for the caller's N. ``vertex[i]`` is the session vertex of uploaded vertex i;
``first[s]`` the lowest-numbered uploaded vertex of session vertex s (the one
whose position the session keeps). The client speaks the caller's indexing:

* a per-vertex output (SDF value, status, ...) of session vertex s is given
  to every uploaded vertex that maps to it (``expand``);
* per-vertex weights in (VJP weights) are summed onto their session vertex
  (``sum_weights``);
* a per-vertex gradient out goes to ``first[s]``, the other copies get 0
  (``scatter_gradient``), as moving the copy the session keeps is what moves
  the session's vertex;
* positions in are those of ``first[s]`` (``gather_positions``,
  ``session_update``).

Faces keep their indexing (welding refuses a face whose corners would merge,
so none is dropped), so face samples need no mapping.
"""

from dataclasses import dataclass
from typing import Any, List, Optional, Tuple

import math

import numpy as np
import numpy.typing as npt

IntArray = npt.NDArray[np.int64]
FloatArray = npt.NDArray[np.float64]

# The server's range (lib/core/weld.h): 0 (exact duplicates) or in
# [MIN_TOLERANCE, MAX_TOLERANCE].
MAX_TOLERANCE = 0.01
MIN_TOLERANCE = 1e-12


def options(weld: Any) -> Tuple[bool, float]:
    """(header.weld, header.weld_tolerance) of the ``weld`` argument: False
    (no welding), True (exact duplicates: tolerance 0) or a number, the
    tolerance relative to the bounding box's diagonal: 0 (exact
    duplicates) or in [1e-12, 0.01]."""
    if isinstance(weld, (bool, np.bool_)):
        return bool(weld), 0.0
    if not isinstance(weld, (int, float, np.integer, np.floating)):
        raise TypeError("weld must be a bool or a relative tolerance (a "
                        f"number), got {type(weld).__name__}")
    t = float(weld)
    if not math.isfinite(t) or not (
            t == 0 or MIN_TOLERANCE <= t <= MAX_TOLERANCE):
        raise ValueError(f"weld tolerance must be 0 (exact duplicates) or in "
                         f"[{MIN_TOLERANCE:g}, {MAX_TOLERANCE:g}] (relative "
                         f"to the bounding box's diagonal), got {weld}")
    return True, t


@dataclass(frozen=True)
class WeldMap:
    """vertex: (N,) session vertex of each uploaded vertex; first: (S,) the
    lowest-numbered uploaded vertex of each session vertex."""

    vertex: IntArray
    first: IntArray

    @property
    def uploaded(self) -> int:
        return int(self.vertex.size)

    @property
    def session(self) -> int:
        return int(self.first.size)


def weld_map(welded: Any, session_vertices: int,
             uploaded: Optional[int] = None) -> WeldMap:
    """The WeldMap of the server's welded_vertex for a session of
    `session_vertices` vertices (and `uploaded` vertices sent, when known).
    ValueError when it is not a map onto every session vertex."""
    vertex = np.asarray(welded, dtype=np.int64).ravel()
    if uploaded is not None and vertex.size != uploaded:
        raise ValueError(f"the weld map has {vertex.size} entries for "
                         f"{uploaded} uploaded vertices")
    if vertex.size and (vertex.min() < 0 or vertex.max() >= session_vertices):
        raise ValueError(f"the weld map names vertices outside the session's "
                         f"{session_vertices}")
    n = vertex.size
    first = np.full(session_vertices, n, dtype=np.int64)
    np.minimum.at(first, vertex, np.arange(n, dtype=np.int64))
    if np.any(first == n):
        missing = int(np.argmax(first == n))
        raise ValueError(f"the weld map leaves session vertex {missing} "
                         "without an uploaded vertex")
    return WeldMap(vertex, first)


def expand(per_session: Any, m: WeldMap) -> Any:
    """One row per uploaded vertex from one per session vertex (values,
    statuses, (S, k) arrays): each takes its session vertex's."""
    a = np.asarray(per_session)
    if a.shape[0] != m.session:
        raise ValueError(f"{a.shape[0]} rows for {m.session} session vertices")
    return a[m.vertex]


def sum_weights(per_uploaded: Any, m: WeldMap) -> FloatArray:
    """Weights per uploaded vertex summed onto their session vertex:
    g_session[s] = sum of g[i] over the i with vertex[i] = s."""
    g = np.asarray(per_uploaded, dtype=np.float64)
    if g.shape != (m.uploaded,):
        raise ValueError(f"weights must have one entry per uploaded vertex "
                         f"({m.uploaded}), got shape {g.shape}")
    out = np.bincount(m.vertex, weights=g, minlength=m.session)
    return np.asarray(out, dtype=np.float64)


def scatter_gradient(per_session: Any, m: WeldMap) -> FloatArray:
    """A gradient (S, d) per session vertex as (N, d) per uploaded vertex:
    session vertex s's row at first[s], zeros at the other copies."""
    g = np.asarray(per_session, dtype=np.float64)
    if g.shape[0] != m.session:
        raise ValueError(f"{g.shape[0]} rows for {m.session} session vertices")
    out: FloatArray = np.zeros((m.uploaded,) + g.shape[1:], dtype=np.float64)
    out[m.first] = g
    return out


def gather_positions(per_uploaded: Any, m: WeldMap) -> FloatArray:
    """Positions (N, d) per uploaded vertex as the session's (S, d): those
    of each session vertex's lowest-numbered uploaded vertex."""
    p = np.asarray(per_uploaded, dtype=np.float64)
    if p.shape[0] != m.uploaded:
        raise ValueError(f"positions must have one row per uploaded vertex "
                         f"({m.uploaded}), got {p.shape[0]}")
    out: FloatArray = p[m.first]
    return out


def session_update(indices: Any, positions: Any, m: WeldMap
                   ) -> Tuple[IntArray, FloatArray]:
    """A partial update (uploaded `indices`, their positions) as the
    session's: the entries of lowest-numbered copies, their indices mapped
    to session vertices (other copies follow the copy the session keeps and
    are left out)."""
    idx = np.asarray(indices, dtype=np.int64).ravel()
    p = np.asarray(positions, dtype=np.float64)
    if idx.size and (idx.min() < 0 or idx.max() >= m.uploaded):
        raise ValueError(f"indices must be uploaded vertices in [0, "
                         f"{m.uploaded}), got {idx.min()}..{idx.max()}")
    keep = m.first[m.vertex[idx]] == idx
    out_p: FloatArray = p[keep]
    out_i: IntArray = m.vertex[idx[keep]]
    return out_i, out_p


def uploaded_vertex(session_vertex: int, m: WeldMap) -> int:
    """The uploaded vertex that stands for a session vertex (its
    lowest-numbered copy); -1 (none) stays -1."""
    return int(m.first[session_vertex]) if session_vertex >= 0 else -1


def session_vertices(uploaded: Any, m: WeldMap) -> List[int]:
    """Uploaded vertex indices as session vertices, each once, in order."""
    idx = np.asarray(uploaded, dtype=np.int64).ravel()
    if idx.size and (idx.min() < 0 or idx.max() >= m.uploaded):
        raise ValueError(f"vertices must be in [0, {m.uploaded}) (uploaded "
                         "vertices)")
    return list(dict.fromkeys(int(v) for v in m.vertex[idx]))


def jacobian(j: Any, m: WeldMap, dimension: int, vertex_rows: bool) -> Any:
    """A Jacobian (R, S*d) in the session's indexing as (R', N*d): column
    s*d + c becomes first[s]*d + c (the other copies' columns are zero), and
    with vertex rows, row s is repeated for each uploaded vertex of s."""
    import scipy.sparse
    csr = scipy.sparse.csr_matrix(j)
    d = dimension
    columns = (m.first[:, None] * d + np.arange(d)).ravel()
    out = scipy.sparse.csr_matrix(
        (csr.data, columns[csr.indices], csr.indptr),
        shape=(csr.shape[0], m.uploaded * d))
    if vertex_rows:
        out = out[m.vertex]
    return out


def uploaded_mesh(positions: Any, faces: "list[Any]", m: WeldMap
                  ) -> Tuple[FloatArray, "list[IntArray]"]:
    """The session's mesh (S positions, faces of session vertices) in the
    uploaded indexing: every uploaded vertex at its session vertex's
    position, each face's corners the lowest-numbered copies."""
    p: FloatArray = np.asarray(positions, dtype=np.float64)[m.vertex]
    return p, [m.first[np.asarray(f, dtype=np.int64)] for f in faces]


__all__ = ["WeldMap", "weld_map", "options", "expand", "sum_weights",
           "scatter_gradient", "gather_positions", "session_update",
           "uploaded_vertex", "session_vertices", "jacobian",
           "uploaded_mesh"]
