"""End to end against a real meshgauge-server process on loopback: the
Python client, error mapping, Prometheus over HTTP, the remote optimiser
example, and a graceful SIGTERM drain."""

import dataclasses
import json
import os
import signal
import struct
import subprocess
import sys
import unittest
import urllib.request
import warnings

import numpy as np

from meshgauge_client import (InvalidArgumentError, MeshGaugeClient,
                              MeshGaugeError, NotFoundError)

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "client", "python", "examples"))
import thicken_dumbbell  # noqa: E402
import thicken_plate  # noqa: E402
import min_thickness_slsqp  # noqa: E402
from server_fixture import ServerProcess  # noqa: E402

import grpc  # noqa: E402
from html import unescape as html_unescape  # noqa: E402


def octahedron(scale=1.0):
    v = scale * np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0],
                          [0, 0, 1], [0, 0, -1]], dtype=float)
    f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4],
                  [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    return v, f


def unwelded_cube(n):
    """The unit cube as six n x n quad grids, each with its own (n+1)^2
    vertices, faces outward."""
    g = np.linspace(0.0, 1.0, n + 1)
    vertices, faces = [], []
    for axis in range(3):
        b, c = (axis + 1) % 3, (axis + 2) % 3  # e_b x e_c = e_axis
        for side in (0.0, 1.0):
            base = len(vertices)
            for i in range(n + 1):
                for j in range(n + 1):
                    p = [0.0, 0.0, 0.0]
                    p[axis], p[b], p[c] = side, g[i], g[j]
                    vertices.append(p)
            for i in range(n):
                for j in range(n):
                    q = [base + i * (n + 1) + j, base + (i + 1) * (n + 1) + j,
                         base + (i + 1) * (n + 1) + j + 1,
                         base + i * (n + 1) + j + 1]
                    faces.append(q if side == 1.0 else q[::-1])
    return np.array(vertices), np.array(faces)


def welded_box(n, lo, hi, outward=True, open_top=False):
    """An axis-aligned box of n x n quads a side, its vertices shared, faces
    outward (or inward); open_top leaves out its +z side."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    g = np.linspace(0.0, 1.0, n + 1)
    index, vertices, faces = {}, [], []

    def vertex(p):
        key = tuple(np.round(p, 12))
        if key not in index:
            index[key] = len(vertices)
            vertices.append(p)
        return index[key]

    for axis in range(3):
        b, c = (axis + 1) % 3, (axis + 2) % 3
        for side in (0.0, 1.0):
            if open_top and axis == 2 and side == 1.0:
                continue
            for i in range(n):
                for j in range(n):
                    q = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        u = np.zeros(3)
                        u[axis], u[b], u[c] = side, g[i + di], g[j + dj]
                        q.append(vertex(lo + u * (hi - lo)))
                    q = q if (side == 1.0) == outward else q[::-1]
                    faces.append(q)
    return np.array(vertices), faces


def octahedron_at(centre, r, inward=False, flip_first=False):
    v, f = octahedron(r)
    f = [list(q) for q in (f[:, ::-1] if inward else f)]
    if flip_first:
        f[0] = f[0][::-1]
    return v + centre, f


def sheet(n, lo, hi, double_sided=False):
    """An n x n quad grid in the plane z = 0 (each quad twice, opposite,
    with double_sided)."""
    g = np.linspace(0.0, 1.0, n + 1)
    v = np.array([[lo[0] + (hi[0] - lo[0]) * x, lo[1] + (hi[1] - lo[1]) * y,
                   0.0] for x in g for y in g])
    f = []
    for i in range(n):
        for j in range(n):
            q = [i * (n + 1) + j, (i + 1) * (n + 1) + j,
                 (i + 1) * (n + 1) + j + 1, i * (n + 1) + j + 1]
            f += [q, q[::-1]] if double_sided else [q]
    return v, f


def tetrahedra_on_an_edge(centre, r):
    """Two tetrahedra sharing an edge: it is used by four faces."""
    v = np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0.5], [0, 1, 0.5],
                  [-1, 0, 0.5], [0, -1, 0.5]], float) * r + centre
    return v, [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3],
               [1, 4, 0], [5, 1, 0], [4, 5, 0], [5, 4, 1]]


def circle(centre, r, n, clockwise=False, open_=False):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    v = np.column_stack([centre[0] + r * np.cos(t), centre[1] + r * np.sin(t)])
    f = [[i, (i + 1) % n] for i in range(n - 1 if open_ else n)]
    return v, [q[::-1] for q in f] if clockwise else f


def figure_eight(centre, r, n):
    """Two circles of n segments touching at one vertex, used by four."""
    a, _ = circle(centre, r, n)
    b, _ = circle([centre[0] + 2 * r, centre[1]], r, n)
    b = np.delete(b, n // 2, axis=0)  # its point at angle pi: a's vertex 0.
    ring = [0 if i == n // 2 else n + i - (i > n // 2) for i in range(n)]
    return np.vstack([a, b]), ([[i, (i + 1) % n] for i in range(n)]
                               + [[ring[i], ring[(i + 1) % n]]
                                  for i in range(n)])


def combined(*parts):
    vertices, faces, base = [], [], 0
    for v, f in parts:
        vertices.append(v)
        faces += [[base + i for i in q] for q in f]
        base += len(v)
    return np.vstack(vertices), faces


def missing_values_meshes():
    """Meshes whose values go missing (with max_distance 3) in components
    of every kind the summary's warnings tell apart: (name, vertices,
    faces)."""
    return [
        ("parts", *combined(
            welded_box(3, [30, 0, 0], [31, 1, 1]),  # small: has values.
            welded_box(4, [-10] * 3, [10] * 3),  # a shell around ...
            welded_box(3, [-4] * 3, [4] * 3),  # ... one facing out: inverted.
            sheet(4, [40, 0], [48, 8]),
            sheet(2, [60, 0], [66, 6], double_sided=True),
            welded_box(2, [80, 0, 0], [86, 6, 6], open_top=True),
            octahedron_at([100, 0, 0], 5.0, flip_first=True),
            octahedron_at([0, 100, 0], 5.0, inward=True),
            octahedron_at([0, 0, 200], 1e-6))),
        ("sheets", *combined(
            sheet(6, [0, 0], [20, 20]),
            sheet(4, [40, 0], [60, 20], double_sided=True),
            tetrahedra_on_an_edge([80, 0, 0], 10.0),
            welded_box(2, [0, 40, 0], [1, 41, 1]))),
        ("curves", *combined(
            circle([30, 0], 1, 24), circle([0, 0], 10, 64),
            circle([0, 0], 4, 32), circle([50, 0], 5, 40, clockwise=True),
            circle([80, 0], 5, 40, open_=True),
            figure_eight([0, 40], 5, 16))),
    ]


def bits(x):
    return struct.pack("<d", x)


class RemoteEndToEnd(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.server = ServerProcess("--drain_notice_seconds=0.2",
                                   "--shutdown_grace_seconds=10",
                                   metrics=True)
        cls.tmp = cls.server.tmp
        cls.metrics_port = cls.server.metrics_port
        cls.target = cls.server.target
        cls.client = MeshGaugeClient(cls.target)

    @classmethod
    def tearDownClass(cls):
        cls.client.close()
        if cls.server.proc.poll() is None:
            cls.server.proc.kill()
        cls.server.close()

    def test_1_values_vjp_penalty_numpy(self):
        v, f = octahedron()
        info = self.client.upload(v, f, session_id="octa")
        self.assertEqual(info.num_vertices, 6)
        r = self.client.sdf("octa", rays=50)
        self.assertEqual(r.values.shape, (6,))
        self.assertTrue(np.all(np.isfinite(r.values)))
        self.assertEqual(r.summary.ok, 6)
        g = self.client.vjp("octa", np.ones(6), rays=50)
        self.assertEqual(g.shape, (6, 3))
        # Scaling the shape scales the SDF: d(sum SDF)/dx . x = sum SDF.
        self.assertAlmostEqual(float(np.sum(g * v)), float(np.sum(r.values)),
                               places=9)
        gen = self.client.update_positions("octa", 2 * v, 0)
        self.assertEqual(gen, 1)
        r2 = self.client.sdf("octa", rays=50, expected_generation=1)
        np.testing.assert_allclose(r2.values, 2 * r.values, rtol=1e-12)
        pen = self.client.penalty("octa", t_min=5.0)
        self.assertGreater(pen.value, 0)
        self.assertEqual(pen.gradient.shape, (6, 3))
        self.assertIn("octa", [s.session_id for s in self.client.list()])

    def test_1b_sphere_values_vjp_and_opposite_points(self):
        v, f = octahedron()
        sid = self.client.upload(v, f).session_id
        r = self.client.sdf(sid, method="sphere", opposite_points=True)
        self.assertEqual(r.summary.ok, 6)
        self.assertEqual(r.opposite.shape, (6, 3))
        # The touching point is on the ball: |q - x| <= its diameter.
        dist = np.linalg.norm(r.opposite - v, axis=1)
        self.assertTrue(np.all((dist > 0) & (dist <= r.values * (1 + 1e-12))))
        self.assertIsNone(self.client.sdf(sid, method="sphere").opposite)
        # Degree-1 homogeneity through the RPC's sphere derivative.
        g = self.client.vjp(sid, np.ones(6), method="sphere")
        self.assertAlmostEqual(float(np.sum(g * v)), float(np.sum(r.values)),
                               places=9)
        narrow = self.client.sdf(sid, method="sphere", contact_angle=30.0)
        self.assertEqual(narrow.summary.ok, 6)
        with self.assertRaises(ValueError):
            self.client.sdf(sid, method="sphere", contact_angle=90.0)
        with self.assertRaises(TypeError):
            self.client.sdf(sid, opposite_points="yes")

    def test_1c_face_samples(self):
        # SPEC v2 §5c: one value per face, at its centroid along its normal.
        # On the regular octahedron every face's normal ray runs through the
        # centre to the opposite face's centroid: 2 / sqrt(3).
        v, f = octahedron()
        sid = self.client.upload(v, f).session_id
        r = self.client.sdf(sid, samples="faces", method="normal",
                            opposite_points=True, jacobian=True)
        self.assertEqual(r.summary.samples, "faces")
        self.assertEqual(r.values.shape, (8,))
        np.testing.assert_allclose(r.values, 2 / np.sqrt(3), rtol=1e-12)
        centroids = v[f].mean(axis=1)
        np.testing.assert_allclose(r.opposite, -centroids, atol=1e-12)
        self.assertEqual(r.jacobian.shape, (8, 18))
        # Degree-1 homogeneity through the face samples' derivatives, with
        # one weight per face.
        g = self.client.vjp(sid, np.ones(8), method="normal", samples="faces")
        self.assertEqual(g.shape, (6, 3))
        self.assertAlmostEqual(float(np.sum(g * v)), float(np.sum(r.values)),
                               places=9)
        np.testing.assert_allclose(r.jacobian.sum(axis=0).A1.reshape(6, 3), g,
                                   atol=1e-12)
        with self.assertRaises(InvalidArgumentError) as e:
            self.client.vjp(sid, np.ones(6), samples="faces")
        self.assertIn("one per face", e.exception.details)
        # The penalty and the constraint of the face samples, their
        # gradient per vertex: d/ds P(s x) at s = 1 is g . x (central
        # differences through UpdatePositions).
        for form in ("one-sided", "ks"):
            pen = self.client.penalty(sid, 5.0, form=form, samples="faces",
                                      method="normal")
            self.assertEqual(pen.gradient.shape, (6, 3))
            self.assertAlmostEqual(pen.sdf_min, 2 / np.sqrt(3), places=12)
            h = 1e-6
            gen = self.client.info(sid).generation
            ends = []
            for scale in (1 + h, 1 - h):
                gen = self.client.update_positions(sid, scale * v, gen)
                ends.append(self.client.penalty(
                    sid, 5.0, form=form, samples="faces", method="normal",
                    gradient=False).value)
            gen = self.client.update_positions(sid, v, gen)
            self.assertAlmostEqual((ends[0] - ends[1]) / (2 * h),
                                   float(np.sum(pen.gradient * v)), places=5)
        self.assertEqual(self.client.constraint(
            sid, 5.0, samples="faces", method="normal").form, "ks")
        with self.assertRaises(ValueError):
            self.client.sdf(sid, samples="edges")
        # The server's finite-difference check of the face derivatives.
        report = self.client.gradcheck(sid, samples="faces", probes=2,
                                       method="normal")
        self.assertTrue(report.ok, report.verdict)
        self.assertGreater(len(report.rows), 0)
        self.assertTrue(all(r.row < 8 for r in report.rows))
        with self.assertRaises(TypeError):
            self.client.gradcheck(sid, samples=3, probes=12)

    def test_1d_welded_cube_of_six_grids(self):
        # A unit cube exported as six separate 4 x 4 quad grids (each with
        # its own vertices, as per-face exports are): 150 vertices, 98 once
        # welded. Every result keeps the 150 uploaded vertices' indexing.
        v, f = unwelded_cube(4)
        self.assertEqual(len(v), 150)
        info = self.client.upload(v, f, weld=True, session_id="cube-weld")
        self.assertEqual(info.num_vertices, 98)
        self.assertEqual(len(info.welded_vertex), 150)
        np.testing.assert_array_equal(
            v, v[self.client.weld_map("cube-weld").first][info.welded_vertex])
        self.client.delete("cube-weld")
        with self.client.session(v, f, weld=True) as s:
            r = s.sdf(method="normal")
            self.assertEqual(r.values.shape, (150,))
            # A face's inner vertices: the normal ray crosses the cube.
            inner = np.sum((v > 0) & (v < 1), axis=1) == 2
            self.assertEqual(int(inner.sum()), 6 * 9)
            np.testing.assert_allclose(r.values[inner], 1.0, rtol=1e-12)
            # Copies share their vertex's value.
            same = np.all(v[:, None] == v[None, :], axis=2)
            for i, j in zip(*np.nonzero(same)):
                self.assertTrue(r.values[i] == r.values[j]
                                or np.isnan(r.values[i]) and
                                np.isnan(r.values[j]))
            # Degree-1 homogeneity through weights per uploaded vertex:
            # sum_i g_i . x_i = sum_i w_i SDF_i (the gradient of each
            # welded vertex at its lowest-numbered copy, 0 at the others).
            w = np.where(np.isfinite(r.values), 1.0, 0.0)
            g = s.vjp(w, method="normal")
            self.assertEqual(g.shape, (150, 3))
            first = self.client.weld_map(s.session_id).first
            others = np.setdiff1d(np.arange(150), first)
            self.assertEqual(len(others), 52)
            np.testing.assert_array_equal(g[others], 0)
            self.assertAlmostEqual(float(np.sum(g * v)),
                                   float(np.nansum(r.values)), places=9)
            pen = s.penalty(2.0, method="normal")
            self.assertEqual(pen.gradient.shape, (150, 3))
            np.testing.assert_array_equal(pen.gradient[others], 0)
            # Positions per uploaded vertex: twice the cube, twice the SDF.
            s.update(2 * v)
            np.testing.assert_allclose(s.sdf(method="normal").values,
                                       2 * r.values, rtol=1e-12)
        # A relative tolerance merges copies a little apart; True only
        # exact duplicates (none here: nothing merged, no map).
        rng = np.random.default_rng(5)
        near = v + rng.uniform(-1e-9, 1e-9, v.shape)
        self.assertEqual(self.client.upload(near, f, weld=1e-6).num_vertices,
                         98)
        exact = self.client.upload(near, f, weld=True)
        self.assertEqual(exact.num_vertices, 150)
        self.assertIsNone(exact.welded_vertex)
        # The same cube from a file: the file's vertices are the uploaded.
        path = os.path.join(self.tmp, "cube.obj")
        with open(path, "w") as out:
            out.writelines(f"v {x!r} {y!r} {z!r}\n" for x, y, z in v)
            out.writelines("f " + " ".join(str(i + 1) for i in q) + "\n"
                           for q in f)
        with self.client.session_from_file(path, weld=True) as s:
            np.testing.assert_array_equal(s.positions, v)
            np.testing.assert_array_equal(s.sdf(method="normal").values,
                                          r.values)

    def test_1e_fanned_out_vjp_is_the_whole_call(self):
        """fan_out=K: the ranges' exact partial sums merged (math.fsum)
        are the whole call's bits, for K = 1, 2, 3, 7 and vertex and face
        samples; a range outside the mesh is INVALID_ARGUMENT."""
        knight = os.path.join(os.environ["MESHGAUGE_MESH_DIR"],
                              "decimated-knight.off")
        with self.client.session_from_file(knight) as s:
            for samples, n in (("vertices", s.positions.shape[0]),
                               ("faces", len(s.faces))):
                g = np.cos(0.37 * np.arange(n)) * 10
                whole = s.vjp(g, rays=30, samples=samples)
                for k in (1, 2, 3, 7):
                    fanned = s.vjp(g, fan_out=k, rays=30, samples=samples)
                    self.assertEqual(fanned.tobytes(), whole.tobytes(),
                                     f"{samples} K={k}")
            with self.assertRaises(InvalidArgumentError):
                self.client._vjp_ranges(
                    s.session_id, self.client._params({}), np.ones(600),
                    None, 2)

    def assert_same_sdf(self, whole, fanned, label):
        """Every array (NaNs included, by their bytes), the Jacobian and
        every summary field but the call's time and reuse, bit for bit."""
        for name in ("values", "status", "hits", "kept", "normalized",
                     "opposite"):
            a, b = getattr(whole, name), getattr(fanned, name)
            if a is None or b is None:
                self.assertIs(a, b, f"{label}: {name}")
                continue
            self.assertEqual((a.dtype, a.shape, a.tobytes()),
                             (b.dtype, b.shape, b.tobytes()),
                             f"{label}: {name}")
        self.assertEqual(whole.jacobian is None, fanned.jacobian is None)
        if whole.jacobian is not None:
            self.assertEqual(whole.jacobian.shape, fanned.jacobian.shape)
            for name in ("indptr", "indices", "data"):
                self.assertEqual(getattr(whole.jacobian, name).tobytes(),
                                 getattr(fanned.jacobian, name).tobytes(),
                                 f"{label}: jacobian {name}")
        for field in dataclasses.fields(whole.summary):
            if field.name in ("seconds", "reused_hits"):
                continue
            a = getattr(whole.summary, field.name)
            b = getattr(fanned.summary, field.name)
            if isinstance(a, float):
                self.assertEqual(bits(a), bits(b),
                                 f"{label}: {field.name} {a!r} {b!r}")
            else:
                self.assertEqual(a, b, f"{label}: {field.name}")

    def test_1f_fanned_out_sdf_is_the_whole_call(self):
        """sdf(fan_out=K): K range calls merged, summary recomputed from
        every value, are the whole call's bits for K = 2, 3, 7, vertex and
        face samples, with the Jacobian and opposite points."""
        knight = os.path.join(os.environ["MESHGAUGE_MESH_DIR"],
                              "decimated-knight.off")
        with self.client.session_from_file(knight) as s:
            for samples in ("vertices", "faces"):
                kw = dict(rays=30, samples=samples, jacobian=True,
                          opposite_points=True)
                whole = s.sdf(**kw)
                self.assertGreater(whole.summary.integral, 0)
                for k in (2, 3, 7):
                    self.assert_same_sdf(whole, s.sdf(fan_out=k, **kw),
                                         f"{samples} K={k}")
            # At a later generation, through the client's own call.
            gen = s.update(1.5 * s.positions)
            whole = self.client.sdf(s.session_id, expected_generation=gen,
                                    rays=30)
            self.assert_same_sdf(whole, self.client.sdf(
                s.session_id, expected_generation=gen, rays=30, fan_out=3),
                "generation 1")
            with self.assertRaises(ValueError):
                s.sdf(fan_out=0)

    def test_1g_fanned_out_sdf_with_missing_values_and_warnings(self):
        """The missing counts, the integral over the faces with values and
        the warnings, naming the components and causes, computed by the
        client from the ranges' values are the server's, bit for bit and
        word for word: nested shells, an inside-out and an inconsistent
        octahedron, an open box, flat, double-sided and non-manifold
        parts, 2D curves; vertex and face samples."""
        said = []
        for name, v, f in missing_values_meshes():
            with self.client.session(v, f) as s:
                for samples in ("vertices", "faces"):
                    kw = dict(rays=20, samples=samples, max_distance=3.0)
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        whole = s.sdf(**kw)
                    self.assertGreater(whole.summary.missing_faces, 0)
                    self.assertGreater(whole.summary.ok, 0)
                    self.assertTrue(whole.summary.warnings)
                    said += whole.summary.warnings
                    for k in (2, 3, 7):
                        with warnings.catch_warnings(record=True) as caught:
                            warnings.simplefilter("always")
                            fanned = s.sdf(fan_out=k, **kw)
                        self.assert_same_sdf(whole, fanned,
                                             f"{name} {samples} K={k}")
                        self.assertEqual(
                            tuple(str(w.message) for w in caught),
                            whole.summary.warnings)
        # The causes the meshes meant to reach.
        for cause in ("vertices: it is closed and outward",
                      "vertices: it is closed and turned inside out",
                      "vertices: neighbouring faces disagree",
                      "vertices: it is open, so rays escape",
                      "vertices: most of its missing vertices have a degen",
                      "vertices: it has no boundary, but edges shared",
                      "vertices: it has no open end, but vertices shared",
                      "vertices: it is a flat sheet",
                      "more components have more than 1% of the surface",
                      "have no value: the mesh is open or planar"):
            self.assertTrue(any(cause in w for w in said), cause)

    def test_1h_fanned_out_sdf_of_a_welded_session(self):
        """A welded session's fanned-out sdf: merged on the session's
        vertices, then given the uploaded vertices' indexing, as one
        call's."""
        v, f = unwelded_cube(4)
        with self.client.session(v, f, weld=True) as s:
            for samples in ("vertices", "faces"):
                kw = dict(method="normal", samples=samples, jacobian=True)
                whole = s.sdf(**kw)
                self.assertEqual(len(whole.values),
                                 150 if samples == "vertices" else 96)
                for k in (2, 3, 7):
                    self.assert_same_sdf(whole, s.sdf(fan_out=k, **kw),
                                         f"{samples} K={k}")

    def recorded(self, method):
        """The requests of this test's client's `method` calls from now on
        (until the test ends): the stub's callable wrapped."""
        stub = self.client._stub
        real = getattr(stub, method)
        calls = []

        def record(request, **kwargs):
            calls.append(request)
            return real(request, **kwargs)

        setattr(stub, method, record)
        self.addCleanup(setattr, stub, method, real)
        return calls

    def assert_same_penalty(self, whole, fanned, label):
        """Every field but reused_hits, floats by their bits, the gradient
        by its bytes, the thin regions field by field."""
        def exact(x):
            if isinstance(x, float):
                return bits(x)
            if isinstance(x, (tuple, list)):
                return [exact(y) for y in x]
            return x

        for field in dataclasses.fields(whole):
            if field.name == "reused_hits":
                continue
            a, b = getattr(whole, field.name), getattr(fanned, field.name)
            if field.name == "gradient":
                self.assertEqual(a is None, b is None, label)
                if a is not None:
                    self.assertEqual((a.dtype, a.shape), (b.dtype, b.shape))
                    self.assertTrue(
                        a.tobytes() == b.tobytes(),
                        f"{label}: {np.count_nonzero(a != b)} gradient "
                        f"values differ, by up to {np.abs(a - b).max()}")
            elif field.name == "thin":
                self.assertEqual(a is None, b is None, label)
                if a is not None:
                    self.assertEqual(exact(dataclasses.astuple(a)),
                                     exact(dataclasses.astuple(b)),
                                     f"{label}: thin")
            else:
                self.assertEqual(exact(a), exact(b),
                                 f"{label}: {field.name} {a!r} {b!r}")

    def check_fanned_out_penalty(self, s, samples, n, label, **kw):
        """penalty(fan_out=K) of both forms, with the gradient and thin
        regions and without, at t_min the median of the SDF values, is
        penalty()'s bit for bit for K = 2, 3, 7, and is K ranged calls."""
        t_min = float(np.nanmedian(s.sdf(samples=samples, **kw).values))
        sdf_calls = self.recorded("ComputeSdf")
        calls = self.recorded("ComputePenalty")
        for form in ("one-sided", "ks"):
            for gradient in (True, False):
                args = dict(form=form, samples=samples, gradient=gradient,
                            thin_regions=True, **kw)
                del calls[:]
                whole = s.penalty(t_min, **args)
                self.assertFalse(calls[0].HasField("range"))
                if form == "one-sided":
                    self.assertGreater(whole.value, 0, label)
                    self.assertTrue(whole.thin.regions, label)
                if gradient:
                    self.assertGreater(np.abs(whole.gradient).max(), 0)
                for k in (2, 3, 7):
                    what = (f"{label} {samples} {form} "
                            f"gradient={gradient} K={k}")
                    del calls[:], sdf_calls[:]
                    fanned = s.penalty(t_min, fan_out=k, **args)
                    self.assert_same_penalty(whole, fanned, what)
                    # K ranges of the pass, then K penalty ranges, each
                    # with every sample's value.
                    for c in (sdf_calls, calls):
                        self.assertEqual(
                            sorted((r.range.begin, r.range.end) for r in c),
                            [(n * i // k, n * (i + 1) // k)
                             for i in range(k)], what)
                    self.assertTrue(all(len(r.values) == n for r in calls))

    def test_1i_fanned_out_penalty_is_the_whole_call(self):
        """penalty(fan_out=K): the fanned-out pass's values sent with K
        ComputePenalty ranges, merged (exact partial sums rounded once,
        then the measure part): the whole call's value, gradient, missing
        counts, sdf_min and thin regions, bit for bit, for K = 2, 3, 7,
        forms one-sided and ks, vertex and face samples, at a later
        generation too."""
        knight = os.path.join(os.environ["MESHGAUGE_MESH_DIR"],
                              "decimated-knight.off")
        with self.client.session_from_file(knight) as s:
            nv, nf = s.positions.shape[0], len(s.faces)
            for samples, n in (("vertices", nv), ("faces", nf)):
                self.check_fanned_out_penalty(s, samples, n, "knight",
                                              rays=30)
            s.update(1.5 * s.positions)
            self.assertEqual(s.generation, 1)
            self.check_fanned_out_penalty(s, "vertices", nv, "generation 1",
                                          rays=30)
            with self.assertRaises(ValueError):
                s.penalty(1.0, fan_out=0)
            with self.assertRaises(ValueError):
                s.constraint(1.0, fan_out=1.5)

    def test_1j_fanned_out_penalty_of_a_welded_session(self):
        """A welded session's fanned-out penalty: its ranges carry the
        session's own values (98 vertices, not the 150 uploaded), and the
        result, scattered to the uploaded vertices, is one call's."""
        v, f = unwelded_cube(4)
        with self.client.session(v, f, weld=True) as s:
            self.assertEqual(s.info().num_vertices, 98)
            self.check_fanned_out_penalty(s, "vertices", 98, "welded cube",
                                          rays=40)
            self.check_fanned_out_penalty(s, "faces", 96, "welded cube",
                                          rays=40)
            self.assertEqual(s.penalty(1.0, fan_out=3).gradient.shape,
                             (150, 3))

    def test_2_errors_map_to_status_codes(self):
        with self.assertRaises(MeshGaugeError) as e:
            self.client.info("missing")
        self.assertEqual(e.exception.code, grpc.StatusCode.NOT_FOUND)
        v, f = octahedron()
        self.client.upload(v, f, session_id="dup")
        with self.assertRaises(MeshGaugeError) as e:
            self.client.upload(v, f, session_id="dup")
        self.assertEqual(e.exception.code, grpc.StatusCode.ALREADY_EXISTS)
        with self.assertRaises(MeshGaugeError) as e:
            self.client.update_positions("dup", v, expected_generation=7)
        self.assertEqual(e.exception.code, grpc.StatusCode.ABORTED)
        # Argument errors are raised before any call.
        with self.assertRaises(ValueError):
            self.client.sdf("dup", cone_angle=200)
        with self.assertRaises(ValueError):
            self.client.sdf("dup", method="cones")
        with self.assertRaises(TypeError):
            self.client.sdf("dup", rays="many")
        with self.assertRaises(ValueError):
            self.client.upload(v[:, 0], f)
        # Every status has its own subclass, keeping code and details.
        with self.assertRaises(NotFoundError) as nf:
            self.client.info("missing")
        self.assertIn("no session 'missing'", nf.exception.details)
        bad = v.copy()
        bad[2] = bad[0]  # face (0, 2, 4) collapses
        with self.assertRaises(MeshGaugeError) as e:
            self.client.upload(bad, f, session_id="bad")
        self.assertEqual(e.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
        self.assertIn("zero area", e.exception.details)

    def test_3_remote_optimiser_reaches_t_min(self):
        out = open(os.path.join(self.tmp, "optimiser.log"), "w")
        history = thicken_dumbbell.optimise(self.client, t_min=0.6, neck=0.3,
                                            max_iterations=150, out=out)
        out.close()
        print(open(os.path.join(self.tmp, "optimiser.log")).read()[-400:])
        self.assertLess(history[0], 0.35)
        self.assertGreaterEqual(history[-1], 0.6)

    def test_3b_slsqp_ks_constraint_on_z_up_plate_converges(self):
        out = open(os.path.join(self.tmp, "plate.log"), "w")
        result, g, sdf_min, target = thicken_plate.optimise(self.client,
                                                            out=out)
        out.close()
        with open(os.path.join(self.tmp, "plate.log")) as log:
            print(log.read()[-300:])
        self.assertTrue(result.success, result.message)
        self.assertLessEqual(g, 1e-6)
        # From 0.08 (SDF 0.081) to t_min = 0.15 itself (within 1 %): the
        # target had to grow past t_min, where the KS slack left ~10 % below.
        self.assertGreaterEqual(sdf_min, 0.99 * 0.15)
        self.assertGreater(target, 0.15)

    def test_3b2_slsqp_minimum_thickness_holds(self):
        # min_thickness_slsqp.py: the measured minimum (of the samples the
        # constraint used) ends >= t_min, not within a tolerance. With
        # face samples the a-priori margin (ks_t_min) does it in one run.
        for samples, runs in (("faces", 1), ("vertices", 4)):
            out = open(os.path.join(self.tmp, f"min-{samples}.log"), "w")
            check, targets, moved = min_thickness_slsqp.optimise(
                self.client, t_min=0.15, samples=samples, out=out)
            out.close()
            self.assertTrue(check.ok, (samples, check, targets))
            self.assertGreaterEqual(check.measured, 0.15)
            self.assertEqual(check.missing, 0)
            self.assertLessEqual(len(targets), runs)
            self.assertGreater(targets[-1], 0.15)
        self.assertEqual(min_thickness_slsqp.main(
            ["--server", self.target]), 0)

    def test_3c_ks_form_and_missing_values(self):
        v, f = octahedron()
        sid = self.client.upload(v, f, session_id="ks-octa").session_id
        g = self.client.constraint(sid, 5.0, rho=20)
        self.assertGreater(g.value, 0)  # every SDF is below t_min = 5
        self.assertEqual(g.gradient.shape, (6, 3))
        self.assertEqual(g.missing_vertices, 0)
        self.assertEqual(g.form, "ks")
        with self.assertRaises(ValueError):
            self.client.penalty(sid, 1.0, form="cones")
        # Inside out: the cones look outside, every value is missing.
        sid2 = self.client.upload(v, f[:, ::-1], session_id="ks-inside-out").session_id
        with self.assertRaises(MeshGaugeError) as e:
            self.client.penalty(sid2, 1.0, form="ks")
        self.assertEqual(e.exception.code, grpc.StatusCode.FAILED_PRECONDITION)
        self.assertIn("reorient", e.exception.details)
        self.client.delete(sid)
        self.client.delete(sid2)

    def test_4_prometheus_over_http(self):
        text = urllib.request.urlopen(
            f"http://127.0.0.1:{self.metrics_port}/metrics", timeout=5).read().decode()
        self.assertIn('meshgauge_rpc_requests_total{code="OK",method="ComputePenalty"}', text)
        self.assertIn("meshgauge_bvh_refits_total", text)
        self.assertIn("meshgauge_rays_traced_total", text)
        self.assertNotIn("octa", text)  # no session ids as labels

    def test_5_cli_remote_verbs(self):
        cli = os.environ["MESHGAUGE_CLI"]
        knight = os.path.join(os.environ["MESHGAUGE_MESH_DIR"],
                              "decimated-knight.off")

        def run(*args, ok=True):
            p = subprocess.run([cli, "remote", *args, "--server", self.target,
                                "--json"], capture_output=True, text=True,
                               timeout=60)
            if ok:
                self.assertEqual(p.returncode, 0, p.stderr)
            return p

        # --threads bounds the local checks before the upload, as with
        # the other verbs.
        info = json.loads(run("upload", knight, "--session-id", "cli",
                              "--threads", "1").stdout)
        self.assertEqual(info["vertices"], 502)
        on = ("--session-id", "cli")
        sdf = json.loads(run("sdf", knight, *on).stdout)
        self.assertEqual(sdf["ok"], 502)
        grad = json.loads(run("grad", knight, *on).stdout)
        self.assertGreater(grad["vjp_max_norm"], 0)
        pen = json.loads(run("penalty", knight, *on, "--t-min", "0.1").stdout)
        self.assertGreater(pen["penalty"], 0)
        # The session is kept, at the generation it was uploaded.
        self.assertEqual(json.loads(run("info", "cli").stdout)["generation"], 0)
        up = json.loads(run("update", "cli", "--positions", knight).stdout)
        self.assertEqual(up["generation"], 1)
        ids = [s["session_id"] for s in json.loads(run("list").stdout)]
        self.assertIn("cli", ids)
        # Every verb prints one JSON object or array with --json.
        self.assertEqual(json.loads(run("health").stdout),
                         {"status": "SERVING"})
        self.assertEqual(json.loads(run("delete", "cli").stdout),
                         {"session_id": "cli", "deleted": True})
        missing = run("info", "cli", ok=False)
        self.assertEqual(missing.returncode, 1)
        self.assertIn("no session 'cli'", missing.stderr)

    def test_6_thin_regions_are_the_cli_reports_typed(self):
        from meshgauge_client import ThinRegion, ThinSurface
        cli = os.environ["MESHGAUGE_CLI"]
        knight = os.path.join(os.environ["MESHGAUGE_MESH_DIR"],
                              "decimated-knight.off")
        subprocess.run([cli, "remote", "upload", knight, "--session-id",
                        "thin", "--server", self.target], check=True,
                       capture_output=True, timeout=60)
        out = os.path.join(self.tmp, "report")
        subprocess.run([cli, "report", knight, "--t-min", "0.1", "--rays",
                        "20", "--min-region-area", "0.001", "--out", out],
                       check=True, capture_output=True, timeout=60)
        with open(os.path.join(out, "report.json")) as f:
            report = json.load(f)["thin"]
        pen = self.client.penalty("thin", 0.1, rays=20, thin_regions=True,
                                  min_region_area=0.001, gradient=False)
        thin = pen.thin
        self.assertIsInstance(thin, ThinSurface)
        self.assertEqual(thin.region_count, len(report["regions"]))
        self.assertEqual(thin.thin_area, report["thin_area"])
        self.assertEqual(thin.total_area, report["total_area"])
        self.assertEqual(thin.thin_fraction, report["thin_fraction"])
        self.assertEqual(thin.min_vertex, report["thinnest"]["vertex"])
        self.assertGreater(len(thin.regions), 1)
        for got, want in zip(thin.regions, report["regions"]):
            self.assertIsInstance(got, ThinRegion)
            for name, value in want.items():
                expect = tuple(value) if isinstance(value, list) else value
                self.assertEqual(getattr(got, name), expect, name)
        # The largest few only, and arguments checked before the call.
        top = self.client.penalty("thin", 0.1, rays=20, thin_regions=True,
                                  max_thin_regions=2, gradient=False).thin
        self.assertEqual(len(top.regions), 2)
        self.assertEqual(top.region_count, thin.region_count)
        self.assertIsNone(self.client.penalty("thin", 0.1, rays=20).thin)
        with self.assertRaises(ValueError):
            self.client.penalty("thin", 0.1, thin_regions=True,
                                max_thin_regions=0)
        with self.assertRaises(ValueError):
            self.client.penalty("thin", 0.1, thin_regions=True,
                                min_region_area=-1)

    def test_6b_session_report_writes_the_interactive_page(self):
        """Session.report writes the CLI's interactive page for the
        session's iteration: bands adding up, the server's thin share; in
        headless Chromium (when installed) its slider's thin share for
        another t_min is the server's penalty's for it."""
        import re
        import shutil
        knight = os.path.join(os.environ["MESHGAUGE_MESH_DIR"],
                              "decimated-knight.off")
        out = os.path.join(self.tmp, "py_report")
        with self.client.session_from_file(knight) as s:
            report = s.report(out, t_min=0.1, rays=20)
            other = s.penalty(0.05, rays=20, thin_regions=True,
                              gradient=False).thin.thin_fraction
        with open(os.path.join(out, "report.json")) as f:
            self.assertEqual(json.load(f)["thin"], report["thin"])
        total = report["thin"]["total_area"]
        self.assertAlmostEqual(sum(b["area"] for b in report["bands"]),
                               total, delta=1e-12 * total)
        self.assertAlmostEqual(report["bands"][0]["area"],
                               report["thin"]["thin_area"],
                               delta=1e-12 * total)
        with open(os.path.join(out, "index.html")) as f:
            page = f.read()
        for part in ('id="mg-data"', 'id="mg-bands"', 'data-region="0"',
                     "MIT License", report["sentence"]):
            self.assertIn(part, page)
        # With the CLI ($MESHGAUGE_CLI here) the page is the CLI's, its
        # pictures included; without one, the interactive page alone.
        for picture in ("views.png", "histogram.png", "colored.ply"):
            self.assertTrue(os.path.exists(os.path.join(out, picture)))
        self.assertTrue("data:image/png;base64," in page)
        bare = os.path.join(self.tmp, "py_report_bare")
        with self.client.session_from_file(knight) as s:
            alone = s.report(bare, t_min=0.1, rays=20, cli="")
        self.assertFalse(os.path.exists(os.path.join(bare, "views.png")))
        self.assertEqual(alone["thin"]["thin_fraction"],
                         report["thin"]["thin_fraction"])
        # A CLI without meshgauge-remote beside it fails; the report an
        # earlier call left in the directory is not returned for this one.
        lone = os.path.join(self.tmp, "lone_cli")
        os.makedirs(lone, exist_ok=True)
        shutil.copy(os.environ["MESHGAUGE_CLI"], lone)
        with self.client.session_from_file(knight) as s:
            with self.assertRaisesRegex(RuntimeError, "meshgauge-remote"):
                s.report(out, t_min=0.2, rays=20,
                         cli=os.path.join(lone, "meshgauge"))
        self.assertFalse(os.path.exists(os.path.join(out, "report.json")))
        chromium = shutil.which("chromium")
        if not chromium:
            return
        run = subprocess.run(
            [chromium, "--headless", "--no-sandbox", "--disable-gpu",
             "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
             "--disable-background-networking", "--no-first-run",
             "--user-data-dir=" + os.path.join(self.tmp, "chromium"),
             "--dump-dom", "file://" + os.path.join(out, "index.html") +
             "#selftest=0.05"], capture_output=True, text=True, timeout=120)
        m = re.search(r'<pre id="mg-selftest">(.*?)</pre>', run.stdout)
        self.assertIsNotNone(m, run.stderr[-2000:])
        result = json.loads(html_unescape(m.group(1)))
        self.assertEqual(result["errors"], [])
        self.assertTrue(result["webgl"])
        self.assertAlmostEqual(result["steps"][0]["thin_fraction"], other,
                               delta=1e-9 * other)
        self.assertTrue(result["clicked_row"])

    def test_7_missing_values_warn_with_their_cause(self):
        import warnings
        from meshgauge_client import MissingValuesWarning
        v, f = octahedron()
        self.client.upload(v, f[:, ::-1], session_id="inward")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            r = self.client.sdf("inward", rays=20)
        self.assertTrue(np.all(np.isnan(r.values)))
        self.assertEqual(len(r.summary.warnings), 1)
        self.assertIn("negative signed volume", r.summary.warnings[0])
        self.assertEqual([w.category for w in caught], [MissingValuesWarning])
        self.assertIn("component 0 (8 faces): 100% of its area",
                      str(caught[0].message))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            self.client.upload(v, f, session_id="outward")
            ok = self.client.sdf("outward", rays=20)
        self.assertEqual(ok.summary.warnings, ())
        self.assertEqual(caught, [])

    def test_8_server_info_and_its_limits_checked_before_calls(self):
        info = self.client.server_info()
        assert info is not None
        with open(os.path.join(HERE, "..", "..", "VERSION")) as f:
            self.assertEqual(info.version, f.read().strip())
        self.assertEqual(info.api, "meshgauge.v1")
        self.assertEqual(info.max_rays, 1024)  # the server's default.
        self.assertGreater(info.max_vertices, 0)
        v, f = octahedron()
        self.client.upload(v, f, session_id="limits")
        # 2000 passes the wire's 4096 but not this server's --max_rays.
        with self.assertRaises(ValueError) as e:
            self.client.sdf("limits", rays=2000)
        self.assertIn("at most 1024 on this server", str(e.exception))
        self.assertEqual(self.client.sdf("limits", rays=1024).summary.ok, 6)
        # A server older than GetServerInfo: no limits known, calls work.

        class Unimplemented(grpc.RpcError):
            def code(self):
                return grpc.StatusCode.UNIMPLEMENTED

            def details(self):
                return "Method not found"

        def old_server(*args, **kwargs):
            raise Unimplemented()

        with MeshGaugeClient(self.target) as old:
            old._stub.GetServerInfo = old_server
            self.assertIsNone(old.server_info())
            self.assertEqual(old.sdf("limits", rays=20).summary.ok, 6)

    def test_8b_sessions_from_mesh_objects(self):
        import types
        v, f = octahedron()
        reference = self.client.sdf(self.client.upload(v, f).session_id,
                                    rays=20).values
        trimesh_like = types.SimpleNamespace(vertices=v, faces=f)
        open3d_like = types.SimpleNamespace(vertices=list(v),
                                            triangles=list(f))
        meshio_like = types.SimpleNamespace(points=v, cells=[
            types.SimpleNamespace(type="triangle", data=f[:4]),
            types.SimpleNamespace(type="triangle", data=f[4:])])
        for mesh in (trimesh_like, open3d_like, meshio_like):
            with self.client.session(mesh) as s:
                np.testing.assert_array_equal(s.sdf(rays=20).values,
                                              reference)
        with self.assertRaises(TypeError) as e:
            self.client.session(object())
        self.assertIn("is not a mesh", str(e.exception))
        with self.assertRaises(ValueError):
            self.client.session(types.SimpleNamespace(points=v, cells=[
                types.SimpleNamespace(type="tetra", data=[[0, 1, 2, 3]])]))

    def test_8c_sdf_options_typed_frozen_and_checked(self):
        import dataclasses
        from meshgauge_client import SdfOptions
        v, f = octahedron()
        sid = self.client.upload(v, f).session_id
        opts = SdfOptions(rays=40, cone_angle_degrees=45.0)
        with self.assertRaises(dataclasses.FrozenInstanceError):
            opts.rays = 3  # type: ignore[misc]
        by_options = self.client.sdf(sid, options=opts).values
        by_keywords = self.client.sdf(sid, rays=40, cone_angle=45.0).values
        np.testing.assert_array_equal(by_options, by_keywords)
        with self.assertRaises(TypeError) as e:
            self.client.sdf(sid, ray=40)
        self.assertIn("unknown SDF option 'ray'; options are", str(e.exception))
        with self.assertRaises(TypeError):
            self.client.sdf(sid, options=opts, rays=40)
        with self.assertRaises(ValueError):
            SdfOptions(cone_angle_degrees=180)
        with self.assertRaises(ValueError):
            SdfOptions(method="cones")
        s = self.client.session(v, f)
        self.assertEqual(s.vjp(np.ones(6), options=opts).shape, (6, 3))
        s.close()

    def test_8d_gradcheck_is_the_clis(self):
        """The server's finite-difference check from Python: the CLI's
        local `gradcheck --json` on the same file, entry for entry (doubles
        bit for bit), with and without a penalty; bad options are
        ValueError before any call."""
        cli = os.environ["MESHGAUGE_CLI"]
        knight = os.path.join(os.environ["MESHGAUGE_MESH_DIR"],
                              "decimated-knight.off")
        with self.client.session_from_file(knight) as s:
            for flags, kwargs in [
                    ([], {}),
                    (["--t-min", "0.3", "--form", "ks"],
                     {"penalty": {"t_min": 0.3, "form": "ks"}})]:
                local = json.loads(subprocess.run(
                    [cli, "gradcheck", knight, "--rays", "20", "--samples",
                     "3", "--json", *flags], check=True, capture_output=True,
                    text=True).stdout)
                report = s.gradcheck(samples=3, rays=20, **kwargs)
                self.assertTrue(report.ok)
                self.assertEqual(report.verdict, local["verdict"])
                rows = report.rows + report.penalty_rows
                self.assertEqual(len(rows), len(local["rows"]))
                self.assertEqual(len(report.vjp_rows), len(local["vjp_rows"]))
                self.assertGreater(len(report.vjp_rows), 0)
                for mine, theirs in zip(rows + report.vjp_rows,
                                        local["rows"] + local["vjp_rows"]):
                    self.assertEqual((mine.row, mine.vertex, mine.analytic,
                                      mine.fd, mine.clean),
                                     (theirs["row"], theirs["vertex"],
                                      theirs["analytic"], theirs["fd"],
                                      theirs["clean"]))
                    self.assertEqual("xyz"[mine.coordinate],
                                     theirs["coordinate"])
                self.assertEqual(report.rays_traced, local["rays_traced"])
                self.assertEqual(report.probe_repeats, local["probe_repeats"])
            for bad in [{"samples": 0}, {"samples": 1001},
                        {"relative_step": 0.5}, {"vertices": [-1]},
                        {"penalty": {"t_min": 0.1, "shape": 2}}]:
                with self.assertRaises(ValueError):
                    s.gradcheck(**bad)

    def test_9_sigterm_drains_and_exits_cleanly(self):
        self.server.proc.send_signal(signal.SIGTERM)
        self.assertEqual(self.server.proc.wait(timeout=20), 0)
        log = self.server.stderr()
        self.assertIn("draining", log)
        self.assertIn("stopped", log)


if __name__ == "__main__":
    unittest.main(verbosity=2)
