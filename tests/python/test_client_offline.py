"""The Python client without a meshgauge server: the weld map's pure
functions, the KS margin and the final thickness check, a client with no
server at all (it fails within its retry budget, naming the target), and a
fake server (the generated servicer) for what the client sends and how it
reads the replies: closed sessions, file errors naming the path, welded
sessions in the caller's indexing, face samples in the penalty."""

import inspect
import math
import os
import socket
import tempfile
import time
import unittest
from concurrent import futures
from typing import Any, List

import grpc
import numpy as np
import scipy.sparse

from meshgauge_client import (CancelledError, InvalidArgumentError,
                              MeshGaugeClient,
                              SessionClosedError, UnavailableError,
                              thickness)
from meshgauge_client import _weld
from meshgauge_client import client as client_module
from meshgauge_client._stubs import pb, pb_grpc
from meshgauge_client.results import SdfResult, SdfSummary


def free_port() -> int:
    """A loopback port nothing listens on (bound, then released)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


# 0 1 2 3 4 5 6 uploaded -> 0 1 0 2 1 3 0 session (4 session vertices).
MAP = [0, 1, 0, 2, 1, 3, 0]


class ImportGraphTest(unittest.TestCase):
    """The package's modules import each other without a cycle, counting
    imports inside functions too (only `if TYPE_CHECKING:` blocks, which
    never run, are left out): client.py and session.py used to import each
    other, one of them from inside functions."""

    def test_the_modules_import_each_other_without_a_cycle(self):
        import ast
        import meshgauge_client
        package = os.path.dirname(meshgauge_client.__file__)
        graph = {}
        for name in os.listdir(package):
            if not name.endswith(".py") or name == "__init__.py":
                continue
            with open(os.path.join(package, name)) as f:
                tree = ast.parse(f.read())
            skipped = set()
            for node in ast.walk(tree):
                if (isinstance(node, ast.If) and
                        "TYPE_CHECKING" in ast.unparse(node.test)):
                    skipped.update(id(n) for b in node.body
                                   for n in ast.walk(b))
            deps = set()
            for node in ast.walk(tree):
                if id(node) in skipped:
                    continue
                if isinstance(node, ast.ImportFrom) and node.module:
                    if node.module == "meshgauge_client":
                        deps.update(a.name for a in node.names)
                    elif node.module.startswith("meshgauge_client."):
                        deps.add(node.module.split(".")[1])
            graph[name[:-3]] = deps & {n[:-3] for n in os.listdir(package)}
        state = {}

        def visit(module, path):
            if state.get(module) == "done":
                return
            self.assertNotEqual(state.get(module), "open",
                                " -> ".join(path + [module]))
            state[module] = "open"
            for dep in sorted(graph.get(module, ())):
                visit(dep, path + [module])
            state[module] = "done"

        self.assertIn("session", graph["client"])  # the test sees imports.
        for module in sorted(graph):
            visit(module, [])


class WeldMapTest(unittest.TestCase):
    def setUp(self) -> None:
        self.m = _weld.weld_map(MAP, 4, 7)

    def test_first_copies(self) -> None:
        np.testing.assert_array_equal(self.m.first, [0, 1, 3, 5])
        self.assertEqual((self.m.uploaded, self.m.session), (7, 4))

    def test_values_are_expanded_per_uploaded_vertex(self) -> None:
        values = np.array([10.0, 11.0, np.nan, 13.0])
        np.testing.assert_array_equal(_weld.expand(values, self.m),
                                      [10, 11, 10, np.nan, 11, 13, 10])
        rows = np.arange(12.0).reshape(4, 3)
        np.testing.assert_array_equal(_weld.expand(rows, self.m)[4], rows[1])

    def test_weights_are_summed_onto_session_vertices(self) -> None:
        g = np.array([1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0])
        np.testing.assert_array_equal(_weld.sum_weights(g, self.m),
                                      [69.0, 18.0, 8.0, 32.0])
        with self.assertRaises(ValueError):
            _weld.sum_weights(g[:4], self.m)

    def test_gradients_go_to_the_lowest_numbered_copy(self) -> None:
        grad = np.arange(1.0, 13.0).reshape(4, 3)
        out = _weld.scatter_gradient(grad, self.m)
        self.assertEqual(out.shape, (7, 3))
        for s, i in enumerate([0, 1, 3, 5]):
            np.testing.assert_array_equal(out[i], grad[s])
        for i in (2, 4, 6):
            np.testing.assert_array_equal(out[i], 0)

    def test_the_chain_rule_through_the_positions_sent(self) -> None:
        # f(x_session) with x_session = gather(x_uploaded): the gradient in
        # the uploaded coordinates is the scattered session gradient, and
        # a VJP with summed weights is the transpose of the expanded
        # Jacobian.
        rng = np.random.default_rng(1)
        x_up = rng.normal(size=(7, 3))
        grad_s = rng.normal(size=(4, 3))

        def f(x: Any) -> float:
            return float(np.sum(grad_s * _weld.gather_positions(x, self.m)))

        fd = np.zeros((7, 3))
        for i in range(7):
            for c in range(3):
                e = np.zeros((7, 3))
                e[i, c] = 1e-6
                fd[i, c] = (f(x_up + e) - f(x_up - e)) / 2e-6
        np.testing.assert_allclose(_weld.scatter_gradient(grad_s, self.m),
                                   fd, atol=1e-8)
        j = scipy.sparse.random(4, 12, density=0.5, random_state=2,
                                format="csr")
        g_up = rng.normal(size=7)
        j_up = _weld.jacobian(j, self.m, 3, vertex_rows=True)
        self.assertEqual(j_up.shape, (7, 21))
        vjp_session = (j.T @ _weld.sum_weights(g_up, self.m)).reshape(4, 3)
        np.testing.assert_allclose(
            (j_up.T @ g_up).reshape(7, 3),
            _weld.scatter_gradient(vjp_session, self.m), atol=1e-12)
        # Face rows stay; columns move to the first copies.
        faces = _weld.jacobian(j, self.m, 3, vertex_rows=False)
        self.assertEqual(faces.shape, (4, 21))
        np.testing.assert_array_equal(faces[:, 15:18].toarray(),
                                      j[:, 9:12].toarray())

    def test_positions_sent_are_the_first_copies(self) -> None:
        p = np.arange(21.0).reshape(7, 3)
        np.testing.assert_array_equal(_weld.gather_positions(p, self.m),
                                      p[[0, 1, 3, 5]])
        idx, q = _weld.session_update([6, 3, 0, 4], p[[6, 3, 0, 4]], self.m)
        np.testing.assert_array_equal(idx, [2, 0])  # 6 and 4 are copies.
        np.testing.assert_array_equal(q, p[[3, 0]])
        pos, faces = _weld.uploaded_mesh(p[:4], [np.array([0, 1, 2])],
                                         self.m)
        np.testing.assert_array_equal(pos[6], p[0])
        np.testing.assert_array_equal(faces[0], [0, 1, 3])
        self.assertEqual(_weld.uploaded_vertex(2, self.m), 3)
        self.assertEqual(_weld.uploaded_vertex(-1, self.m), -1)
        self.assertEqual(_weld.session_vertices([6, 2, 3], self.m), [0, 2])

    def test_bad_maps_and_options(self) -> None:
        with self.assertRaises(ValueError):
            _weld.weld_map([0, 1, 3], 4)  # vertex 2 has no copy
        with self.assertRaises(ValueError):
            _weld.weld_map([0, 1, 4], 4)
        with self.assertRaises(ValueError):
            _weld.weld_map(MAP, 4, 6)
        self.assertEqual(_weld.options(False), (False, 0.0))
        self.assertEqual(_weld.options(True), (True, 0.0))
        self.assertEqual(_weld.options(1e-4), (True, 1e-4))
        for bad in (0.02, -1e-3, 1e-13, math.nan):
            with self.assertRaises(ValueError):
                _weld.options(bad)
        with self.assertRaises(TypeError):
            _weld.options("yes")


def ks(values: Any, areas: Any, t_min: float, rho: float) -> float:
    """The face-sampled KS constraint as the server evaluates it."""
    s = 1 - np.asarray(values) / t_min
    m = float(s.max())
    return m + math.log(float(np.sum(areas * np.exp(rho * (s - m))))
                        / float(np.sum(areas))) / rho


class ThicknessTest(unittest.TestCase):
    def test_the_slack_of_g_le_0_and_the_margin_that_holds(self) -> None:
        # One thin face of 400 equal ones: G(t_min) = 0 with that face
        # ln(400)/50 = 12 % under t_min.
        areas = np.ones(400)
        t_min, rho = 1.0, 50.0
        values = np.full(400, 10.0)
        lo, hi = 0.0, 1.0
        for _ in range(100):  # the thin value where G(t_min) = 0
            mid = (lo + hi) / 2
            values[0] = mid
            lo, hi = (mid, hi) if ks(values, areas, t_min, rho) > 0 \
                else (lo, mid)
        self.assertAlmostEqual(values[0], 1 - math.log(400) / rho, places=6)
        # With the margin, G <= 0 keeps every face at or above t_min, for
        # any spread of areas and values.
        rng = np.random.default_rng(3)
        for _ in range(50):
            n = int(rng.integers(2, 300))
            areas = rng.uniform(0.01, 1.0, n)
            shape = rng.uniform(0.2, 3.0, n)
            target = thickness.ks_t_min(t_min, rho, areas.min() / areas.sum())
            lo, hi = 0.0, 100.0
            for _ in range(200):  # the scale where G(target) = 0
                mid = (lo + hi) / 2
                lo, hi = (lo, mid) if ks(mid * shape, areas, target, rho) < 0 \
                    else (mid, hi)
            self.assertGreaterEqual((hi * shape).min(), t_min * (1 - 1e-12))
        with self.assertRaises(ValueError):
            thickness.ks_t_min(1.0, 5.0, 1e-3)  # rho <= ln(1000)

    def test_the_smallest_weights_of_the_constraint(self) -> None:
        # A unit square as a quad (two triangles of 1/2) and a triangle of
        # 1/2 beside it.
        v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]],
                     dtype=float)
        faces = [[0, 1, 2, 3], [1, 4, 2]]
        self.assertAlmostEqual(thickness.min_weight_fraction(v, faces), 1 / 3)
        self.assertAlmostEqual(
            thickness.min_weight_fraction(v, faces, "vertices"), 1 / 9)
        segments = np.array([[0.0, 0], [1, 0], [1, 3]])
        self.assertAlmostEqual(
            thickness.min_weight_fraction(segments, [[0, 1], [1, 2]],
                                          "vertices"), 1 / 8)

    def test_the_final_check(self) -> None:
        def result(values: Any) -> SdfResult:
            v = np.asarray(values, dtype=float)
            return SdfResult(v, np.ones(len(v), dtype=np.int64),
                             np.zeros(len(v), dtype=np.int64),
                             np.zeros(len(v), dtype=np.int64), v,
                             SdfSummary(0, len(v), 0, 0, 0, 0, 0, 0, 0, 0, 0,
                                        0, False, 0, 0, 0, 0.0))

        values = np.linspace(0.9, 3.0, 101)
        c = thickness.check(result(values), 1.0)
        self.assertFalse(c.ok)
        self.assertAlmostEqual(c.measured, 0.9)
        self.assertAlmostEqual(c.ratio, 1 / 0.9)
        c5 = thickness.check(result(values), 1.0, quantile=0.05)
        self.assertTrue(c5.ok)
        self.assertAlmostEqual(c5.measured, 1.005)
        self.assertEqual(c5.ratio, 1.0)
        missing = thickness.check(result([1.5, np.nan]), 1.0)
        self.assertEqual(missing.missing, 1)
        self.assertFalse(missing.ok)


class NoServerTest(unittest.TestCase):
    """Nothing listens on the target: every call fails UNAVAILABLE within
    the client's budget, naming the target and the refused connection."""

    def assert_unavailable(self, call: Any, target: str, within: float
                           ) -> None:
        start = time.monotonic()
        with self.assertRaises(UnavailableError) as e:
            call()
        self.assertLess(time.monotonic() - start, within)
        message = str(e.exception)
        self.assertIn(target, message)
        self.assertIn("unavailable", message)
        self.assertIn("connection refused", message)

    def test_every_call_fails_fast_naming_the_target(self) -> None:
        target = f"127.0.0.1:{free_port()}"
        v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
        f = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]
        with tempfile.TemporaryDirectory() as tmp, \
                MeshGaugeClient(target, connect_seconds=0.5,
                                retry_seconds=0.5) as client:
            path = os.path.join(tmp, "tetra.obj")
            with open(path, "w") as out:
                out.write("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                          "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n")
            calls = [
                lambda: client.upload(v, f), lambda: client.session(v, f),
                lambda: client.session(v, f, weld=True),
                lambda: client.upload_file(path),
                lambda: client.session_from_file(path),
                lambda: client.sdf("s"), lambda: client.vjp("s", np.ones(4)),
                lambda: client.penalty("s", 1.0),
                lambda: client.constraint("s", 1.0),
                lambda: client.update_positions("s", v, 0),
                lambda: client.info("s"), lambda: client.list(),
                lambda: client.mesh("s"), lambda: client.delete("s"),
                lambda: client.server_info(),
                lambda: client.calibrate("s", 1.0),
                lambda: client.gradcheck("s")]
            # At once: each waits out its own connect and retry budget.
            with futures.ThreadPoolExecutor(len(calls)) as pool:
                for done in [pool.submit(self.assert_unavailable, call,
                                         target, 5) for call in calls]:
                    done.result()

    def test_the_default_budget_is_bounded(self) -> None:
        # docs/python.md: at most 30 s of retries.
        self.assertLessEqual(client_module.RETRY_SECONDS, 30)
        self.assertLessEqual(client_module.CONNECT_SECONDS,
                             client_module.RETRY_SECONDS)
        defaults = inspect.signature(MeshGaugeClient).parameters
        self.assertEqual(defaults["retry_seconds"].default,
                         client_module.RETRY_SECONDS)
        self.assertEqual(defaults["connect_seconds"].default,
                         client_module.CONNECT_SECONDS)
        self.assertLess(defaults["deadline"].default, math.inf)
        target = f"127.0.0.1:{free_port()}"
        with MeshGaugeClient(target) as client:
            self.assert_unavailable(
                lambda: client.upload(np.eye(3), [[0, 1, 2]]), target, 35)


class FakeServer(pb_grpc.MeshGaugeServicer):
    """CreateSession, DeleteSession, GetMesh, UpdatePositions, ComputeSdf,
    ComputeVjp and ComputePenalty with the replies the test sets; the
    requests are kept."""

    def __init__(self) -> None:
        self.headers: List[Any] = []
        self.requests: List[Any] = []
        self.create_error: Any = None  # (code, details)
        self.welded: List[int] = []
        self.session_vertices = 4
        self.mesh: Any = None
        self.deleted: List[str] = []
        self.live: "set[str]" = set()
        self.values: List[float] = []
        self.gradient: List[float] = []
        self.thin_vertex = -1

    def CreateSession(self, request_iterator: Any, context: Any) -> Any:
        header = None
        for r in request_iterator:
            if r.HasField("header"):
                header = r.header
        self.headers.append(header)
        if self.create_error:
            context.abort(*self.create_error)
        self.live.add(header.session_id)
        return pb.CreateSessionResponse(
            session=pb.SessionInfo(session_id=header.session_id, dimension=3,
                                   num_vertices=self.session_vertices,
                                   num_faces=4),
            welded_vertex=self.welded)

    def DeleteSession(self, request: Any, context: Any) -> Any:
        self.deleted.append(request.session_id)
        self.live.discard(request.session_id)
        return pb.DeleteSessionResponse()

    def GetMesh(self, request: Any, context: Any) -> Any:
        return self.mesh

    def UpdatePositions(self, request: Any, context: Any) -> Any:
        self.requests.append(request)
        return pb.UpdatePositionsResponse(
            generation=request.expected_generation + 1)

    def ComputeSdf(self, request: Any, context: Any) -> Any:
        self.requests.append(request)
        if request.session_id not in self.live:
            context.abort(grpc.StatusCode.NOT_FOUND,
                          f"no session '{request.session_id}'")
        n = len(self.values)
        ok = [pb.VERTEX_STATUS_OK if math.isfinite(x) else
              pb.VERTEX_STATUS_NO_HIT for x in self.values]
        yield pb.ComputeSdfResponse(chunk=pb.SdfChunk(
            vertex_begin=0, vertex_end=n, values=self.values, status=ok,
            hits=range(n), kept=range(n), normalized=self.values))
        yield pb.ComputeSdfResponse(summary=pb.SdfSummary(
            ok=sum(1 for x in ok if x == pb.VERTEX_STATUS_OK),
            no_hit=sum(1 for x in ok if x != pb.VERTEX_STATUS_OK),
            samples=request.params.samples or pb.SAMPLE_SET_VERTICES))

    def ComputeVjp(self, request: Any, context: Any) -> Any:
        self.requests.append(request)
        return pb.ComputeVjpResponse(gradient=self.gradient)

    def ComputePenalty(self, request: Any, context: Any) -> Any:
        self.requests.append(request)
        r = pb.ComputePenaltyResponse(value=0.5, gradient=self.gradient)
        if request.with_thin_regions:
            r.thin.min_vertex = self.thin_vertex
            r.thin.min_point.extend([0, 0, 0])
        return r


class FakeServerTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls) -> None:
        cls.fake = FakeServer()
        cls.server = grpc.server(futures.ThreadPoolExecutor(max_workers=2))
        pb_grpc.add_MeshGaugeServicer_to_server(cls.fake, cls.server)
        cls.port = cls.server.add_insecure_port("127.0.0.1:0")
        cls.server.start()
        cls.target = f"127.0.0.1:{cls.port}"
        cls.client = MeshGaugeClient(cls.target, deadline=30, retry_seconds=5)

    @classmethod
    def tearDownClass(cls) -> None:
        cls.client.close()
        cls.server.stop(None)

    def setUp(self) -> None:
        self.fake.__init__()

    # A tetrahedron uploaded as 7 vertices (MAP: 4 session vertices).
    V7 = np.array([[0.0, 0, 0], [1, 0, 0], [0, 0, 0], [0, 1, 0], [1, 0, 0],
                   [0, 0, 1], [0, 0, 0]])
    F7 = [[0, 3, 1], [2, 4, 5], [1, 3, 5], [6, 5, 3]]

    def test_an_upload_the_server_cancelled_says_so(self) -> None:
        # A stream the server cancels carries no status of its own: the
        # client, which never cancels an upload, names the likely reasons.
        self.fake.create_error = (grpc.StatusCode.CANCELLED,
                                  "Cancelled on the server side")
        with self.assertRaises(CancelledError) as e:
            self.client.upload(self.V7, self.F7, session_id="c")
        self.assertIn("--upload_idle_seconds", str(e.exception))
        self.assertIn("server cancelled the upload", e.exception.details)

    def test_a_closed_session_refuses_every_call(self) -> None:
        v, f = self.V7[[0, 1, 3, 5]], [[0, 2, 1], [0, 1, 3], [1, 2, 3],
                                       [0, 3, 2]]
        self.fake.values = [1.0] * 4
        with self.client.session(v, f, session_id="closed") as s:
            self.assertEqual(len(s.sdf().values), 4)
            # Lost by the server while open: re-created.
            self.client.delete("closed")
            self.assertEqual(len(s.sdf().values), 4)
            self.assertEqual(s.recreated, 1)
        self.assertEqual(self.fake.deleted, ["closed", "closed"])
        calls = [s.sdf, s.info, s.jacobian, lambda: s.update(v),
                 lambda: s.vjp(np.ones(4)), lambda: s.penalty(1.0),
                 lambda: s.constraint(1.0), lambda: s.calibrate(1.0),
                 lambda: s.gradcheck(), lambda: s.check_thickness(1.0),
                 s.__enter__]
        for call in calls:
            with self.assertRaises(SessionClosedError) as e:
                call()
            self.assertIn("session closed is closed", str(e.exception))
        # Never re-created, and closing again does nothing.
        s.close()
        self.assertEqual(len(self.fake.headers), 2)
        self.assertEqual(self.fake.deleted, ["closed", "closed"])
        self.assertTrue(s.closed)
        np.testing.assert_array_equal(s.positions, v)  # still readable.
        s2 = self.client.session(v, f, session_id="closed-2")
        s2.close()
        with self.assertRaises(SessionClosedError):
            s2.sdf()
        self.assertEqual(len(self.fake.headers), 3)

    def test_file_errors_name_the_path(self) -> None:
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "bad.obj")
            with open(path, "w") as out:
                out.write("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
            # The server's message names what it was sent (the path), or
            # not at all: both name the path, once.
            for details, expect in [
                    ("CreateSession: the mesh has 2 faces of zero area",
                     f"{path}: CreateSession: the mesh has 2 faces"),
                    (f"{path}: line 4: index 3 out of range",
                     f"INVALID_ARGUMENT: {path}: line 4")]:
                self.fake.create_error = (grpc.StatusCode.INVALID_ARGUMENT,
                                          details)
                for call in (lambda: self.client.upload_file(path),
                             lambda: self.client.session_from_file(path)):
                    with self.assertRaises(InvalidArgumentError) as e:
                        call()
                    self.assertIn(expect, str(e.exception))
                    self.assertEqual(str(e.exception).count(path), 1)
            self.assertEqual(self.fake.headers[-1].file_name, path)
            self.fake.create_error = (grpc.StatusCode.RESOURCE_EXHAUSTED,
                                      "CreateSession: 9 vertices exceed 8")
            with self.assertRaises(Exception) as e:
                self.client.upload_file(path)
            self.assertIn(path, str(e.exception))
            # Local checks name it too.
            for name, content in [("empty.obj", ""), ("none.obj", None),
                                  ("mesh.3ds", "x")]:
                p = os.path.join(tmp, name)
                if content is not None:
                    with open(p, "w") as out:
                        out.write(content)
                for call in (lambda: self.client.upload_file(p),
                             lambda: self.client.session_from_file(p)):
                    with self.assertRaises((ValueError, OSError)) as e:
                        call()
                    self.assertIn(p, str(e.exception))
            with self.assertRaises(ValueError) as e:
                self.client.session_from_file(tmp + "/")
            self.assertIn(tmp, str(e.exception))

    def test_weld_arguments_go_in_the_header(self) -> None:
        v, f = self.V7, self.F7
        self.fake.welded = MAP
        for weld, want in [(False, (False, 0.0)), (True, (True, 0.0)),
                           (2e-3, (True, 2e-3))]:
            self.client.upload(v, f, weld=weld)
            h = self.fake.headers[-1]
            self.assertEqual((h.weld, h.weld_tolerance), want)
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "m.obj")
            with open(path, "w") as out:
                out.write("v 0 0 0\n")
            self.client.upload_file(path, weld=1e-3)
            self.assertTrue(self.fake.headers[-1].weld)
            self.assertEqual(self.fake.headers[-1].weld_tolerance, 1e-3)
        with self.assertRaises(ValueError):
            self.client.upload(v, f, weld=0.5)
        with self.assertRaises(ValueError):
            self.client.session(v, f, weld=-1.0)

    def test_a_welded_session_speaks_the_uploaded_indexing(self) -> None:
        v, f = self.V7, self.F7
        self.fake.welded = MAP
        m = _weld.weld_map(MAP, 4)
        with self.client.session(v, f, weld=True, session_id="w") as s:
            info = self.client.weld_map("w")
            assert info is not None
            np.testing.assert_array_equal(info.vertex, MAP)
            np.testing.assert_array_equal(s.positions, v)
            # SDF: one value per uploaded vertex.
            self.fake.values = [1.0, 2.0, math.nan, 4.0]
            r = s.sdf()
            np.testing.assert_array_equal(r.values,
                                          [1, 2, 1, np.nan, 2, 4, 1])
            np.testing.assert_array_equal(r.status, np.array(
                [1, 1, 1, 2, 1, 1, 1]))
            self.assertEqual(r.summary.ok, 3)  # session vertices
            # Face samples keep the faces' indexing.
            self.assertEqual(len(s.sdf(samples="faces").values), 4)
            # VJP: weights summed, gradient at the first copies.
            self.fake.gradient = list(np.arange(1.0, 13.0))
            g = s.vjp(np.arange(7.0))
            np.testing.assert_array_equal(self.fake.requests[-1].weights,
                                          [8.0, 5.0, 3.0, 5.0])
            np.testing.assert_array_equal(
                g, _weld.scatter_gradient(np.arange(1.0, 13.0).reshape(4, 3),
                                          m))
            with self.assertRaises(ValueError):
                s.vjp(np.ones(4))
            self.fake.values = [1.0] * 4
            s.vjp(np.ones(4), samples="faces")  # one weight per face
            np.testing.assert_array_equal(self.fake.requests[-1].weights,
                                          [1.0] * 4)
            # Penalty and constraint: gradient and thinnest vertex.
            self.fake.thin_vertex = 2
            for pen in (s.penalty(1.0, thin_regions=True),
                        s.constraint(1.0, samples="faces")):
                self.assertEqual(pen.gradient.shape, (7, 3))
                np.testing.assert_array_equal(pen.gradient[[2, 4, 6]], 0)
                np.testing.assert_array_equal(pen.gradient[3], [7, 8, 9])
            self.assertEqual(s.penalty(1.0, thin_regions=True).thin.min_vertex,
                             3)
            # Positions sent: the first copies'.
            x = v + 0.25
            s.update(x)
            sent = np.asarray(self.fake.requests[-1].positions).reshape(-1, 3)
            np.testing.assert_array_equal(sent, x[[0, 1, 3, 5]])
            np.testing.assert_array_equal(s.positions, x)
            with self.assertRaises(ValueError):
                s.update(x[:4])
            self.client.update_positions("w", x[[6, 5]], s.generation,
                                         indices=[6, 5])
            req = self.fake.requests[-1]
            self.assertEqual(list(req.indices), [3])
            np.testing.assert_array_equal(req.positions, x[5])

    def test_a_welded_file_session_in_the_files_indexing(self) -> None:
        self.fake.welded = MAP
        self.fake.mesh = pb.GetMeshResponse(
            dimension=3, positions=self.V7[[0, 1, 3, 5]].ravel(),
            face_sizes=[3] * 4, face_indices=[0, 2, 1, 0, 1, 3, 1, 2, 3, 0,
                                              3, 2])
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "m.obj")
            with open(path, "w") as out:
                out.write("v 0 0 0\n")
            with self.client.session_from_file(path, weld=True) as s:
                np.testing.assert_array_equal(s.positions, self.V7)
                np.testing.assert_array_equal(s.faces[0], [0, 3, 1])
                self.fake.values = [1.0, 2.0, 3.0, 4.0]
                self.assertEqual(s.sdf().values.shape, (7,))

    def test_penalty_and_constraint_send_face_samples(self) -> None:
        v, f = self.V7[[0, 1, 3, 5]], [[0, 2, 1], [0, 1, 3], [1, 2, 3],
                                       [0, 3, 2]]
        self.fake.gradient = [0.0] * 12
        sid = self.client.upload(v, f).session_id
        for call in (self.client.penalty, self.client.constraint):
            pen = call(sid, 1.0, samples="faces")
            self.assertEqual(self.fake.requests[-1].params.samples,
                             pb.SAMPLE_SET_FACES)
            self.assertEqual(pen.gradient.shape, (4, 3))  # per vertex
            call(sid, 1.0)
            self.assertEqual(self.fake.requests[-1].params.samples,
                             pb.SAMPLE_SET_VERTICES)


class RestartTest(unittest.TestCase):
    def test_a_restart_within_the_budget_is_waited_for_and_then_not(
            self) -> None:
        fake = FakeServer()

        def serve(port: int) -> Any:
            server = grpc.server(futures.ThreadPoolExecutor(max_workers=2))
            pb_grpc.add_MeshGaugeServicer_to_server(fake, server)
            bound = server.add_insecure_port(f"127.0.0.1:{port}")
            server.start()
            return server, bound

        server, port = serve(0)
        target = f"127.0.0.1:{port}"
        with MeshGaugeClient(target, retry_seconds=3,
                             connect_seconds=1) as client:
            client.delete("a")
            server.stop(None)
            # Back after 1 s: the answered client waits (retry_seconds).
            restart = futures.ThreadPoolExecutor(max_workers=1).submit(
                lambda: (time.sleep(1), serve(port))[1])
            client.delete("b")
            server = restart.result()[0]
            self.assertEqual(fake.deleted, ["a", "b"])
            server.stop(None)
            start = time.monotonic()
            with self.assertRaises(UnavailableError) as e:
                client.delete("c")
            self.assertLess(time.monotonic() - start, 6)
            self.assertIn(target, str(e.exception))
            self.assertIn("retry_seconds=3", str(e.exception))


if __name__ == "__main__":
    unittest.main()
