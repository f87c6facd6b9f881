"""What a whole ComputeSdf pass's summary holds that needs every value,
computed from the merged values of a fanned-out sdf (docs/server.md,
Fan-out) exactly as the server computes it: `normalized` (lib/core/
normalized_sdf.cc), min, max, mean and median (sdf_types.cc,
SummarizeValues), the missing counts (missing_values.cc), the integral
(integrals.cc) and the warnings (missing_diagnosis.cc, with the
components of components.cc and the nesting of nesting.cc).

Every float is the server's bit for bit: the server is built for x86-64
with -O2 (SSE2, no FMA contraction, no reassociation), so each value is the
same IEEE operations in the same order. Here elementwise numpy operations
(+ - * / sqrt, correctly rounded), sums in the server's order
(np.add.accumulate from 0.0, never np.sum's pairwise order or Python 3.12's
compensated sum()), and logarithms and arctangents through libm (math.log,
math.atan2: the C library the server calls; numpy's own SIMD versions
differ in the last bit). The warnings' numbers are printed with Python's
%-formatting, correctly rounded like absl::StrFormat's.
"""

import math
from typing import Any, Callable, List, Sequence, Tuple

import numpy as np
import numpy.typing as npt
import scipy.sparse
import scipy.sparse.csgraph

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

# The wire's VertexStatus values (meshgauge.proto).
_NO_HIT = 2
_DEGENERATE_NORMAL = 4

# lib/core/missing_diagnosis.h, missing_values.h.
WARN_MISSING_FRACTION = 0.01
MIN_TRACED_EXTENT = 1e-12
_UNRESOLVED_SHARE = 2.0 ** -16
_CORNER_RAYS_LOST = (
    "these are rays lost at sharp or coarse corners: there the vertex "
    "normal leans towards the side with more triangles and the cone leaves "
    "the solid through the vertex's own faces, which rays ignore (NO_HIT); "
    "measure face samples (--samples faces, samples=\"faces\": each face "
    "along its own normal, as CAD parts need), refine the mesh there, or "
    "widen the cone (--cone-angle 60) so that some rays stay inside")

# QuadratureRule (integrals.cc): (weight, shape functions) per point.
_SEGMENT_RULE = ((0.5, (0.78867513459481288225, 0.21132486540518711775)),
                 (0.5, (0.21132486540518711775, 0.78867513459481288225)))
_TRIANGLE_RULE = ((1.0 / 3, (2.0 / 3, 1.0 / 6, 1.0 / 6)),
                  (1.0 / 3, (1.0 / 6, 2.0 / 3, 1.0 / 6)),
                  (1.0 / 3, (1.0 / 6, 1.0 / 6, 2.0 / 3)))

# Segments shorter than this are summed one term at a time across segments
# (a numpy operation per term position); longer ones with accumulate each.
_SHORT_SEGMENT = 256


def sequential_sum(x: FloatArray) -> float:
    """((0 + x[0]) + x[1]) + ...: a C++ loop's `sum += x`."""
    if len(x) == 0:
        return 0.0
    return float(np.add.accumulate(np.concatenate((np.zeros(1), x)))[-1])


def segment_sums(x: FloatArray, offsets: IntArray) -> FloatArray:
    """sequential_sum of each x[offsets[s]:offsets[s + 1]]."""
    lengths = np.diff(offsets)
    out = np.zeros(len(lengths))
    long = np.nonzero(lengths > _SHORT_SEGMENT)[0]
    for s in long:
        out[s] = sequential_sum(x[offsets[s]:offsets[s + 1]])
    short = np.nonzero(lengths <= _SHORT_SEGMENT)[0]
    for k in range(int(lengths[short].max()) if len(short) else 0):
        short = short[lengths[short] > k]
        out[short] = out[short] + x[offsets[short] + k]
    return out


def _grouped_sums(x: FloatArray, group: IntArray, groups: int) -> FloatArray:
    """Per group g, sequential_sum of x[group == g] in x's order."""
    order = np.argsort(group, kind="stable")
    offsets: IntArray = np.concatenate(
        (np.zeros(1, np.int64), np.cumsum(np.bincount(group,
                                                      minlength=groups))))
    return segment_sums(x[order], offsets)


def _libm(f: Callable[..., float], *args: FloatArray) -> FloatArray:
    """f (a math function: the C library's) of each element."""
    return np.fromiter(map(f, *(a.tolist() for a in args)), dtype=np.float64,
                       count=len(args[0]))


# Vectors as three columns (arrays of x, y and z), or three scalars.
Vec = Sequence[Any]


def _norm(x: FloatArray, y: FloatArray, z: FloatArray) -> FloatArray:
    out: FloatArray = np.sqrt(x * x + y * y + z * z)
    return out


def _cross(a: Vec, b: Vec) -> Tuple[Any, Any, Any]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0])


def _dot(a: Vec, b: Vec) -> Any:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _norm_of(d: Sequence[float]) -> float:
    """Norm of one vector (Python floats are IEEE doubles)."""
    x, y, z = float(d[0]), float(d[1]), float(d[2])
    return math.sqrt(x * x + y * y + z * z)


def _at(columns: Vec, index: Any) -> Tuple[Any, Any, Any]:
    """The points `index` of positions given as columns, as columns."""
    return (columns[0][index], columns[1][index], columns[2][index])


def _minus(a: Vec, b: Vec) -> Tuple[Any, Any, Any]:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _array(field: Any, dtype: Any) -> Any:
    """A repeated protobuf field as an array (np.fromiter: a few times
    faster than np.asarray on one)."""
    return np.fromiter(field, dtype=dtype, count=len(field))


class WholeMesh:
    """A session's mesh (GetMeshResponse) and its integration elements
    (ForEachElement: per face in order, a segment, a triangle, or a quad's
    triangles (0, 1, 2) and (0, 2, 3))."""

    def __init__(self, reply: Any) -> None:
        self.dimension = int(reply.dimension)
        flat = _array(reply.positions, np.float64)
        p = np.zeros((len(flat) // self.dimension, 3))
        p[:, :self.dimension] = flat.reshape(-1, self.dimension)
        self.positions = p
        # x, y and z, each contiguous.
        self.columns = (p[:, 0].copy(), p[:, 1].copy(), p[:, 2].copy())
        sizes = _array(reply.face_sizes, np.int64)
        indices = _array(reply.face_indices, np.int64)
        if (np.any((sizes < 2) | (sizes > 4)) or sizes.sum() != len(indices)
                or np.any((indices < 0) | (indices >= len(p)))):
            raise ValueError("the mesh's faces do not match its sizes")
        starts: IntArray = np.concatenate(
            (np.zeros(1, np.int64), np.cumsum(sizes)[:-1]))
        faces = np.full((len(sizes), 4), -1, dtype=np.int64)
        for k in range(4):
            has = sizes > k
            faces[has, k] = indices[starts[has] + k]
        self.sizes = sizes
        self.faces = faces
        per_face = np.where(sizes == 4, 2, 1)
        face = np.repeat(np.arange(len(sizes)), per_face)
        t = np.arange(len(face)) - np.repeat(np.cumsum(per_face) - per_face,
                                             per_face)
        v = np.full((len(face), 3), -1, dtype=np.int64)
        v[:, 0] = faces[face, 0]
        segment = sizes[face] == 2
        v[:, 1] = np.where(segment, faces[face, 1], faces[face, t + 1])
        v[:, 2] = np.where(segment, -1, faces[face, np.minimum(t + 2, 3)])
        self.element_face = face
        self.element_vertices = v
        self.segments = bool(np.all(segment)) if len(face) else False
        cols = self.columns
        a = _at(cols, v[:, 0])
        b = _at(cols, v[:, 1])
        if self.segments:
            self.measure = _norm(*_minus(b, a))
        else:
            c = _at(cols, np.maximum(v[:, 2], 0))
            m = _norm(*_cross(_minus(b, a), _minus(c, a))) / 2
            seg = _norm(*_minus(b, a))
            self.measure = np.where(segment, seg, m)

    @property
    def num_vertices(self) -> int:
        return len(self.positions)

    @property
    def num_faces(self) -> int:
        return len(self.sizes)

    def element_finite(self, finite: BoolArray, faces: bool) -> BoolArray:
        """Per element: every value it integrates is finite (face samples:
        its face's; else its vertices')."""
        if faces:
            return finite[self.element_face]
        v = self.element_vertices
        out: BoolArray = np.all(
            np.where(v >= 0, finite[np.maximum(v, 0)], True), axis=1)
        return out

    def components(self) -> "_Components":
        return _Components(self)


def normalized(values: FloatArray) -> FloatArray:
    """NormalizedSdf: log((v - lo) / (hi - lo) * 4 + 1) / log(5) over the
    finite values; the others as they are; 0 when all are equal."""
    out = values.copy()
    finite = np.isfinite(values)
    if not finite.any():
        return out
    ok = values[finite]
    lo, hi = ok.min(), ok.max()
    if hi > lo:
        x = (ok - lo) / (hi - lo) * 4 + 1
        out[finite] = _libm(math.log, x) / math.log(5.0)
    else:
        out[finite] = 0.0
    return out


def value_stats(values: FloatArray) -> Tuple[float, float, float, float]:
    """SummarizeValues' (min, max, mean, median) of the finite values
    (NaN when none): the first smallest, the last largest, the sum in
    order over the count, and the middle (even count: the mean of the
    two middle values)."""
    ok = values[np.isfinite(values)]
    if len(ok) == 0:
        nan = float("nan")
        return nan, nan, nan, nan
    n = len(ok)
    lo = float(ok[int(np.argmin(ok))])
    hi = float(ok[n - 1 - int(np.argmax(ok[::-1]))])
    mean = sequential_sum(ok) / n
    s = np.sort(ok)
    median = (float(s[n // 2]) if n % 2
              else float((s[n // 2 - 1] + s[n // 2]) / 2))
    return lo, hi, mean, median


def count_missing(mesh: WholeMesh, values: FloatArray, faces: bool
                  ) -> Tuple[int, int, float]:
    """CountMissing (CountMissingFaces with face samples): (vertices on a
    face without a value (0 for faces), faces with an element without
    one, their measure over the surface's)."""
    finite = np.isfinite(values)
    elem_ok = mesh.element_finite(finite, faces)
    total = sequential_sum(mesh.measure)
    missing = sequential_sum(mesh.measure[~elem_ok])
    missing_faces = len(np.unique(mesh.element_face[~elem_ok]))
    vertices = 0
    if not faces:
        on_face = np.zeros(mesh.num_vertices, dtype=bool)
        on_face[mesh.faces[mesh.faces >= 0]] = True
        vertices = int(np.count_nonzero(on_face & ~finite))
    return vertices, missing_faces, (missing / total if total > 0 else 0.0)


def integral(mesh: WholeMesh, values: FloatArray, faces: bool) -> float:
    """IntegrateSdf: the values interpolated linearly on each element
    (2-point Gauss on segments, the degree-2 3-point rule on triangles),
    or constant per face with face samples; elements with a missing value
    skipped."""
    ok = mesh.element_finite(np.isfinite(values), faces)
    measure = mesh.measure[ok]
    if faces:
        return sequential_sum(measure * values[mesh.element_face[ok]])
    v = mesh.element_vertices[ok]
    rule = _SEGMENT_RULE if mesh.segments else _TRIANGLE_RULE
    corner = [values[np.maximum(v[:, i], 0)] for i in range(len(rule[0][1]))]
    total = np.zeros(len(v))
    for weight, shape in rule:
        t = np.zeros(len(v))
        for s, x in zip(shape, corner):
            t = t + s * x
        total = total + weight * t
    return sequential_sum(measure * total)


class _Components:
    """ConnectedComponents (faces joined by shared vertices, ordered by
    their first face) with closedness, boundary edges, signed volume and
    nesting depth, and the edge analysis DiagnoseMesh reads."""

    def __init__(self, mesh: WholeMesh) -> None:
        self.mesh = mesh
        nv = mesh.num_vertices
        faces, sizes = mesh.faces, mesh.sizes
        # Union of every corner with the face's first corner.
        rows, cols = [], []
        for k in range(1, 4):
            has = sizes > k
            rows.append(faces[has, 0])
            cols.append(faces[has, k])
        r = np.concatenate(rows)
        graph = scipy.sparse.coo_matrix(
            (np.ones(len(r)), (r, np.concatenate(cols))), shape=(nv, nv))
        _, label = scipy.sparse.csgraph.connected_components(
            graph, directed=False)
        face_label = label[faces[:, 0]]
        labels, first = np.unique(face_label, return_index=True)
        rank = np.empty(len(labels), dtype=np.int64)
        rank[np.argsort(first, kind="stable")] = np.arange(len(labels))
        remap = np.full(int(label.max()) + 1 if nv else 0, -1, dtype=np.int64)
        remap[labels] = rank
        self.count = len(labels)
        self.of_face = remap[face_label]
        used = np.zeros(nv, dtype=bool)
        used[faces[faces >= 0]] = True
        self.of_vertex = np.where(used, remap[label], -1)
        self.face_counts = np.bincount(self.of_face, minlength=self.count)
        self.first_face = np.zeros(self.count, dtype=np.int64)
        self.first_face[rank] = first
        self._edges()
        self._signed_volumes()
        self._depth: "IntArray | None" = None

    def _edges(self) -> None:
        """SortedEdgeUses: every use of an edge (2D: of a vertex by a
        segment), sorted by key, each edge's uses in face order."""
        mesh = self.mesh
        faces, sizes = mesh.faces, mesh.sizes
        keys, face_ids, forward = [], [], []
        ids = np.arange(mesh.num_faces)
        if mesh.dimension == 2:
            keys = [faces[:, 0], faces[:, 1]]
            face_ids = [ids, ids]
            forward = [np.ones(len(ids), bool), np.zeros(len(ids), bool)]
            order_key = np.column_stack(keys).ravel()
            order_face = np.column_stack(face_ids).ravel()
            order_fwd = np.column_stack(forward).ravel()
        else:
            per = []
            for k in range(4):
                has = sizes > k
                a = faces[has, k]
                nxt = np.where(k + 1 < sizes[has], k + 1, 0)
                b = faces[has][np.arange(int(has.sum())), nxt]
                lo, hi = np.minimum(a, b), np.maximum(a, b)
                per.append((ids[has], k, lo * (1 << 32) + hi, a < b))
            face_all = np.concatenate([p[0] for p in per])
            k_all = np.concatenate([np.full(len(p[0]), p[1]) for p in per])
            emit = np.lexsort((k_all, face_all))  # face order, then corner.
            order_face = face_all[emit]
            order_key = np.concatenate([p[2] for p in per])[emit]
            order_fwd = np.concatenate([p[3] for p in per])[emit]
        sort = np.argsort(order_key, kind="stable")
        key = order_key[sort]
        self.use_face = order_face[sort]
        self.use_forward = order_fwd[sort]
        new_run = np.ones(len(key), dtype=bool)
        new_run[1:] = key[1:] != key[:-1]
        starts: IntArray = np.flatnonzero(new_run)
        counts = np.diff(np.append(starts, len(key)))
        self.run_starts, self.run_counts = starts, counts
        self.mesh_closed = bool(np.all(counts == 2))
        self.boundary_edges = int(np.count_nonzero(counts == 1))
        vertex = key[starts] >> 32 if mesh.dimension == 3 else key[starts]
        odd = counts != 2
        comp = self.of_vertex[vertex[odd]]
        self.closed = np.ones(self.count, dtype=bool)
        self.closed[comp] = False
        self.component_boundary_edges = np.bincount(
            comp[counts[odd] == 1], minlength=self.count)

    def _signed_volumes(self) -> None:
        """SignedVolumeOfFaces of each component (relative to its first
        face's first corner), and of the whole mesh (SignedVolume)."""
        mesh = self.mesh
        self.volume = self._volumes(
            self.of_face[mesh.element_face],
            mesh.faces[self.first_face, 0], self.count)
        self.mesh_volume = (float(self._volumes(
            np.zeros(len(mesh.element_face), np.int64),
            mesh.faces[:1, 0], 1)[0]) if mesh.num_faces else 0.0)

    def _volumes(self, group: IntArray, origin: IntArray, groups: int
                 ) -> FloatArray:
        mesh = self.mesh
        cols = mesh.columns
        v = mesh.element_vertices
        o = _at(cols, origin[group])
        a = _minus(_at(cols, v[:, 0]), o)
        b = _minus(_at(cols, v[:, 1]), o)
        if mesh.segments:
            terms = (a[0] * b[1] - b[0] * a[1]) / 2
        else:
            c = _minus(_at(cols, np.maximum(v[:, 2], 0)), o)
            terms = _dot(a, _cross(b, c)) / 6
        return _grouped_sums(terms, group, groups)

    @property
    def depth(self) -> IntArray:
        """NestingDepths: how many other closed components enclose each
        (winding number at its first face's centroid >= 1/2 in
        magnitude), among those whose box contains its box."""
        if self._depth is None:
            self._depth = self._nesting()
        return self._depth

    def _nesting(self) -> IntArray:
        mesh = self.mesh
        depth = np.zeros(self.count, dtype=np.int64)
        closed = np.flatnonzero(self.closed)
        if len(closed) < 2:
            return depth
        p = mesh.positions
        corners = mesh.faces
        lo = np.full((self.count, 3), np.inf)
        hi = np.full((self.count, 3), -np.inf)
        for k in range(4):
            has = corners[:, k] >= 0
            np.minimum.at(lo, self.of_face[has], p[corners[has, k]])
            np.maximum.at(hi, self.of_face[has], p[corners[has, k]])
        elem_comp = self.of_face[mesh.element_face]
        for i in closed:
            f = int(self.first_face[i])
            point = np.zeros(3)
            for k in range(int(mesh.sizes[f])):
                point = point + p[corners[f, k]]
            point = point / mesh.sizes[f]
            for j in closed:
                if j == i or not (np.all(lo[j] <= lo[i])
                                  and np.all(hi[i] <= hi[j])):
                    continue
                if abs(self._winding(elem_comp == j, point)) >= 0.5:
                    depth[i] += 1
        return depth

    def _winding(self, elements: BoolArray, point: FloatArray) -> float:
        """WindingNumber of the elements about point."""
        mesh = self.mesh
        cols = mesh.columns
        v = mesh.element_vertices[elements]
        q = (np.float64(point[0]), np.float64(point[1]), np.float64(point[2]))
        a = _minus(_at(cols, v[:, 0]), q)
        b = _minus(_at(cols, v[:, 1]), q)
        if mesh.segments:
            angles = _libm(math.atan2, a[0] * b[1] - a[1] * b[0],
                           a[0] * b[0] + a[1] * b[1])
            return sequential_sum(angles) / (2 * math.pi)
        c = _minus(_at(cols, v[:, 2]), q)
        la, lb, lc = _norm(*a), _norm(*b), _norm(*c)
        numerator = _dot(a, _cross(b, c))
        denominator = (la * lb * lc + _dot(a, b) * lc + _dot(a, c) * lb
                       + _dot(b, c) * la)
        angles = 2 * _libm(math.atan2, numerator, denominator)
        return sequential_sum(angles) / (4 * math.pi)

    def inverted(self, c: int) -> bool:
        if not self.closed[c]:
            return False
        return bool(self.volume[c] < 0 if self.depth[c] % 2 == 0
                    else self.volume[c] > 0)

    def inconsistent(self) -> BoolArray:
        """Per component: an edge used by exactly two faces in the same
        direction (DiagnoseMesh's inconsistent_components)."""
        out = np.zeros(self.count, dtype=bool)
        pairs = self.run_starts[self.run_counts == 2]
        a, b = self.use_face[pairs], self.use_face[pairs + 1]
        same = (a != b) & (self.use_forward[pairs]
                           == self.use_forward[pairs + 1])
        out[self.of_face[a[same]]] = True
        return out


def _too_small(extent: float) -> str:
    return ("it is %.3g across, below the %.0e the ray tracer resolves: its "
            "single-precision intersection tests underflow there and rays "
            "lose their hits (NO_HIT); scale the mesh up (e.g. to "
            "millimetres or micrometres)" % (extent, MIN_TRACED_EXTENT))


def _likely_missing_cause(mesh: WholeMesh, no_hit: int, degenerate: int
                          ) -> str:
    """LikelyMissingCause (missing_values.cc)."""
    p = mesh.positions
    extent = (float(np.max(p.max(axis=0) - p.min(axis=0)))
              if len(p) else 0.0)
    if 0 < extent < MIN_TRACED_EXTENT:
        return "the mesh is tiny: " + _too_small(extent)
    c = mesh.components()
    if c.mesh_closed and c.mesh_volume < 0:
        return ("the mesh is closed with a negative signed volume, so its "
                "faces point inward and the cones look outside: reorient it "
                "(--reorient)")
    if degenerate > no_hit:
        return ("most of those vertices have a degenerate normal "
                "(DEGENERATE_NORMAL): the mesh is probably double-sided "
                "(coincident opposite faces)")
    if not c.mesh_closed:
        if c.boundary_edges == 0:
            return ("the mesh has no boundary, but edges shared by more "
                    "than two faces (duplicated, double-sided or touching "
                    "faces), where normals cancel or point astray: remove "
                    "the duplicates")
        return ("the mesh is open or planar, so most rays escape (NO_HIT): "
                "close it, or give the open regions an OUTWARD direction")
    return "the mesh is closed and outward, so " + _CORNER_RAYS_LOST


def _cause(c: _Components, k: int, span: float, diagonal: float,
           mixed: bool, no_hit: int, degenerate: int,
           flat_sheet: bool) -> str:
    """Cause (missing_diagnosis.cc) for component k."""
    if 0 < span < MIN_TRACED_EXTENT:
        return _too_small(span)
    if span < _UNRESOLVED_SHARE * diagonal:
        return ("it spans %.3g while the mesh spans %.3g, where the ray "
                "tracer's single-precision coordinates step by about %.3g "
                "(trace it on its own, or bring the parts closer)"
                % (span, diagonal, diagonal * 2.0 ** -23))
    if c.inverted(k):
        return ("it is closed and turned inside out (an outer shell with a "
                "negative signed volume, or a cavity's shell facing out of "
                "its cavity): its faces point into the solid and the cones "
                "look out of the material (--reorient, or reorient in the "
                "Python client)")
    if mixed:
        return ("neighbouring faces disagree on orientation, so normals "
                "there are wrong or cancel (--reorient makes it "
                "consistent)")
    if degenerate > no_hit:
        return ("most of its missing vertices have a degenerate normal: "
                "double-sided or folded faces whose normals cancel")
    closed = bool(c.closed[k])
    if not closed and c.component_boundary_edges[k] == 0:
        return ("it has no open end, but vertices shared by more than two "
                "segments (a duplicated or touching segment), where normals "
                "cancel or point astray (remove the duplicates)"
                if c.mesh.dimension == 2 else
                "it has no boundary, but edges shared by more than two "
                "faces (a duplicated, double-sided or touching face), where "
                "normals cancel or point astray (remove the duplicates)")
    if c.mesh.dimension == 3 and not closed and flat_sheet:
        return ("it is a flat sheet with no inside, so the rays escape "
                "(thicken it, or give its region an OUTWARD cone)")
    if not closed:
        return ("it is open, so rays escape through its holes (close it, or "
                "give open regions an OUTWARD cone)")
    return "it is closed and outward, so " + _CORNER_RAYS_LOST


def _vertex_warnings(mesh: WholeMesh, values: FloatArray, status: IntArray,
                     warn: float) -> List[str]:
    """MissingValueWarnings(mesh, values, status): per component missing
    more than `warn` of the surface, the five with the most missing
    measure, its share and likely cause."""
    finite = np.isfinite(values)
    if warn >= 0 and finite.all():
        return []
    c = mesh.components()
    p = mesh.positions
    elem_comp = c.of_face[mesh.element_face]
    elem_ok = mesh.element_finite(finite, False)
    measure = mesh.measure
    total = sequential_sum(measure)
    area = _grouped_sums(measure, elem_comp, c.count)
    missing_area = _grouped_sums(measure[~elem_ok], elem_comp[~elem_ok],
                                 c.count)
    flagged = [k for k in range(c.count)
               if total > 0 and missing_area[k] > warn * total]
    if not flagged:
        return []
    flagged.sort(key=lambda k: (-missing_area[k], k))
    v = mesh.element_vertices
    lo = np.full((c.count, 3), 1e300)
    hi = np.full((c.count, 3), -1e300)
    for i in range(3):
        has = v[:, i] >= 0
        np.minimum.at(lo, elem_comp[has], p[v[has, i]])
        np.maximum.at(hi, elem_comp[has], p[v[has, i]])
    tri = v[:, 2] >= 0
    cols = mesh.columns
    a = _at(cols, v[tri, 0])
    n = _cross(_minus(_at(cols, v[tri, 1]), a),
               _minus(_at(cols, v[tri, 2]), a))
    n = (n[0] * 0.5, n[1] * 0.5, n[2] * 0.5)
    area_vector = [_grouped_sums(x, elem_comp[tri], c.count) for x in n]
    area_norms = _grouped_sums(_norm(*n), elem_comp[tri], c.count)
    missing_vertex = (c.of_vertex >= 0) & ~finite
    where = c.of_vertex[missing_vertex]
    missing_vertices = np.bincount(where, minlength=c.count)
    no_hit = np.bincount(where[status[missing_vertex] == _NO_HIT],
                         minlength=c.count)
    degenerate = np.bincount(
        where[status[missing_vertex] == _DEGENERATE_NORMAL], minlength=c.count)
    mixed = c.inconsistent()
    used = p[mesh.faces[mesh.faces >= 0]]
    diagonal = _norm_of(used.max(axis=0) - used.min(axis=0))
    out = []
    for k in flagged[:5]:
        span = _norm_of(hi[k] - lo[k])
        vector = _norm_of([x[k] for x in area_vector])
        out.append(
            "component %d (%d faces): %.3g%% of its %s (%.3g%% of the "
            "mesh's) has no value, %d vertices: %s" % (
                k, c.face_counts[k], 100 * missing_area[k] / area[k],
                "length" if mesh.dimension == 2 else "area",
                100 * missing_area[k] / total, missing_vertices[k],
                _cause(c, k, span, diagonal, bool(mixed[k]),
                       int(no_hit[k]), int(degenerate[k]),
                       vector >= (1 - 1e-9) * area_norms[k])))
    if len(flagged) > 5:
        out.append("%d more components have more than %.3g%% of the surface "
                   "without values" % (len(flagged) - 5, 100 * warn))
    return out


def missing_warnings(mesh: WholeMesh, values: FloatArray, status: IntArray,
                     faces: bool, missing_fraction: float, missing_faces: int,
                     warn: float = WARN_MISSING_FRACTION) -> List[str]:
    """MissingValueWarnings(mesh, result): per component for vertex
    samples (none without a component pass while the missing share is
    under the threshold); one sentence for face samples."""
    if not faces:
        if warn >= 0 and missing_fraction <= warn * (1 - 1e-9):
            return []
        return _vertex_warnings(mesh, values, status, warn)
    if not missing_fraction > warn:
        return []
    return ["%d faces (%.2f%% of the surface) have no value: %s" % (
        missing_faces, 100 * missing_fraction, _likely_missing_cause(
            mesh, int(np.count_nonzero(status == _NO_HIT)),
            int(np.count_nonzero(status == _DEGENERATE_NORMAL))))]
