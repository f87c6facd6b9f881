"""The clients against a fake server that answers wrongly: what an older or
broken server sends must end in DATA_LOSS, never in values read as others.

The fake is the generated servicer with GetSession (the counts of the
octahedron), ComputeSdf (the reply the test sets, or for a range call the
range's reply of a function the test sets), ComputeVjp (a ranged reply of
zeros), ComputePenalty (the reply of a function the test sets) and GetMesh
(the octahedron); ComputeSdf, ComputeVjp and ComputePenalty record their
requests' metadata, so that the fan-out's routing keys are seen."""

import os
import subprocess
import tempfile
import unittest
from concurrent import futures
from typing import Any, Callable, Dict, List, Optional

import grpc
import numpy as np

from meshgauge_client import AbortedError, DataLossError, MeshGaugeClient
from meshgauge_client._stubs import pb, pb_grpc

CLI = os.environ.get("MESHGAUGE_CLI", "")

# The regular octahedron: 6 vertices, 8 faces.
OCTAHEDRON_OFF = """OFF
6 8 0
1 0 0
-1 0 0
0 1 0
0 -1 0
0 0 1
0 0 -1
3 0 2 4
3 2 1 4
3 1 3 4
3 3 0 4
3 2 0 5
3 1 2 5
3 3 1 5
3 0 3 5
"""


def chunk_and_summary(n: int, samples: int) -> List[Any]:
    """A well-formed reply of n OK samples whose summary names `samples`."""
    chunk = pb.SdfChunk(vertex_begin=0, vertex_end=n, values=[1.0] * n,
                        status=[pb.VERTEX_STATUS_OK] * n, hits=[1] * n,
                        kept=[1] * n, normalized=[0.5] * n)
    return [pb.ComputeSdfResponse(chunk=chunk),
            pb.ComputeSdfResponse(summary=pb.SdfSummary(ok=n, samples=samples))]


OCTAHEDRON_POSITIONS = [1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1]
OCTAHEDRON_FACES = [0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1,
                    5, 0, 3, 5]


def range_reply(request: Any, generation: int = 0) -> List[Any]:
    """A well-formed reply to a range call on the octahedron: sample i has
    the value 1 + i / 8 (its status OK), the summary echoes the range."""
    b, e = request.range.begin, request.range.end
    n = e - b
    chunk = pb.SdfChunk(vertex_begin=b, vertex_end=e,
                        values=[1 + i / 8 for i in range(b, e)],
                        status=[pb.VERTEX_STATUS_OK] * n, hits=[1] * n,
                        kept=[1] * n, normalized=[0.5] * n)
    return [pb.ComputeSdfResponse(chunk=chunk),
            pb.ComputeSdfResponse(summary=pb.SdfSummary(
                ok=n, samples=request.params.samples or pb.SAMPLE_SET_VERTICES,
                generation=generation, rays=n,
                range=pb.SampleRange(begin=b, end=e)))]


# A ranged penalty reply's partial sums: each range's rounded value 1 and
# its tail 3 * 2^-54. Exactly summed over K ranges and rounded once, then
# plus the measure part 0.5: K + 0.5 + 2^-51 for K = 2, 3 (summed in
# doubles, or without the tails, 2.5 for K = 2).
PENALTY_TAIL = 3 * 2.0 ** -54


def penalty_reply(request: Any, generation: int = 0) -> Any:
    """A well-formed reply to a penalty range call on the octahedron: the
    partial sums above, the measure part 0.5 from the range at 0."""
    reply = pb.ComputePenaltyResponse(
        generation=generation, value=2.5, sdf_min=1.0, dimension=3,
        world_frame_vertices=1, missing=pb.MissingValues(vertices=1),
        skipped_faces=0)
    if request.with_gradient:
        reply.gradient.extend([1.0] * 18)
        reply.tail_counts.extend([1] * 18)
        reply.tails.extend([PENALTY_TAIL] * 18)
        if request.range.begin == 0:
            reply.measure_gradient.extend([0.5] * 18)
    return reply


class FakeServer(pb_grpc.MeshGaugeServicer):
    def __init__(self) -> None:
        self.reply: List[Any] = []
        # Set: the reply to a ComputeSdf call with a range.
        self.ranged: Optional[Callable[[Any], List[Any]]] = None
        self.mesh_generation = 0
        # The reply to a ComputePenalty call.
        self.penalty: Callable[[Any], Any] = penalty_reply
        # (method, request, metadata) of each ComputeSdf, ComputeVjp and
        # ComputePenalty.
        self.calls: List[Any] = []

    def GetSession(self, request: Any, context: Any) -> Any:
        return pb.GetSessionResponse(session=pb.SessionInfo(
            session_id=request.session_id, dimension=3, num_vertices=6,
            num_faces=8))

    def GetMesh(self, request: Any, context: Any) -> Any:
        return pb.GetMeshResponse(
            dimension=3, generation=self.mesh_generation,
            positions=OCTAHEDRON_POSITIONS, face_sizes=[3] * 8,
            face_indices=OCTAHEDRON_FACES)

    def ComputeSdf(self, request: Any, context: Any) -> Any:
        self.calls.append(("ComputeSdf", request,
                           dict(context.invocation_metadata())))
        if request.HasField("range") and self.ranged is not None:
            yield from self.ranged(request)
        else:
            yield from self.reply

    def ComputeVjp(self, request: Any, context: Any) -> Any:
        self.calls.append(("ComputeVjp", request,
                           dict(context.invocation_metadata())))
        return pb.ComputeVjpResponse(gradient=[0.0] * 18, dimension=3,
                                     tail_counts=[0] * 18)

    def ComputePenalty(self, request: Any, context: Any) -> Any:
        self.calls.append(("ComputePenalty", request,
                           dict(context.invocation_metadata())))
        return self.penalty(request)


class WrongRepliesTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls) -> None:
        cls.fake = FakeServer()
        cls.server = grpc.server(futures.ThreadPoolExecutor(max_workers=2))
        pb_grpc.add_MeshGaugeServicer_to_server(cls.fake, cls.server)
        port = cls.server.add_insecure_port("127.0.0.1:0")
        cls.server.start()
        cls.target = f"127.0.0.1:{port}"
        cls.client = MeshGaugeClient(cls.target, deadline=30, retry_seconds=0)

    @classmethod
    def tearDownClass(cls) -> None:
        cls.client.close()
        cls.server.stop(None)

    def test_a_vertex_reply_to_a_face_request_is_data_loss(self) -> None:
        # An older server ignores SdfParameters.samples and sends its six
        # vertex values, with no sample set in the summary.
        self.fake.reply = chunk_and_summary(6, pb.SAMPLE_SET_UNSPECIFIED)
        with self.assertRaises(DataLossError) as e:
            self.client.sdf("fake", samples="faces")
        self.assertIn("face samples were asked for", e.exception.details)
        # The same reply to a vertex request is read.
        self.assertEqual(self.client.sdf("fake").values.shape, (6,))

    def test_a_face_reply_to_a_vertex_request_is_data_loss(self) -> None:
        self.fake.reply = chunk_and_summary(8, pb.SAMPLE_SET_FACES)
        with self.assertRaises(DataLossError):
            self.client.sdf("fake")
        self.assertEqual(self.client.sdf("fake", samples="faces").values.shape,
                         (8,))

    def test_opposite_points_other_than_asked_for_are_data_loss(self) -> None:
        # None when asked for (an older server), too few, or some unasked.
        self.fake.reply = chunk_and_summary(6, pb.SAMPLE_SET_VERTICES)
        with self.assertRaises(DataLossError) as e:
            self.client.sdf("fake", opposite_points=True)
        self.assertIn("0 opposite coordinates for 6 samples", e.exception.details)
        for count, asked in ((15, True), (18, False)):
            self.fake.reply = chunk_and_summary(6, pb.SAMPLE_SET_VERTICES)
            self.fake.reply[0].chunk.opposite.extend([0.5] * count)
            with self.assertRaises(DataLossError) as e:
                self.client.sdf("fake", opposite_points=asked)
            self.assertIn(f"{count} opposite coordinates", e.exception.details)
        self.fake.reply[0].chunk.opposite[:] = [0.5] * 18
        self.assertEqual(
            self.client.sdf("fake", opposite_points=True).opposite.shape,
            (6, 3))

    def test_a_reply_without_its_summary_or_of_other_counts_is_data_loss(
            self) -> None:
        self.fake.reply = chunk_and_summary(6, pb.SAMPLE_SET_VERTICES)[:1]
        with self.assertRaises(DataLossError) as e:
            self.client.sdf("fake")
        self.assertIn("without its summary", e.exception.details)
        self.fake.reply = chunk_and_summary(6, pb.SAMPLE_SET_VERTICES)
        self.fake.reply[1].summary.ok = 8
        with self.assertRaises(DataLossError) as e:
            self.client.sdf("fake")
        self.assertIn("the summary counts 8 samples", e.exception.details)
        self.fake.reply = chunk_and_summary(6, pb.SAMPLE_SET_VERTICES)
        self.fake.reply[1].summary.ok = 5
        self.fake.reply[1].summary.no_hit = 1
        with self.assertRaises(DataLossError):
            self.client.sdf("fake")

    def test_range_calls_carry_their_range_and_part(self) -> None:
        """Each range call of a fanned-out sdf or vjp carries
        x-meshgauge-range: BEGIN-END and x-meshgauge-part: I (its index
        among the K), beside the session's key."""
        self.fake.ranged = range_reply
        cases: List[Any] = [
            ("ComputeSdf", lambda: self.client.sdf("fake", fan_out=2),
             ["0-3", "3-6"]),
            ("ComputeSdf",
             lambda: self.client.sdf("fake", fan_out=3, samples="faces"),
             ["0-2", "2-5", "5-8"]),
            ("ComputeVjp",
             lambda: self.client.vjp("fake", np.ones(6), fan_out=3),
             ["0-2", "2-4", "4-6"]),
            ("ComputeVjp",
             lambda: self.client.vjp("fake", np.ones(8), fan_out=7,
                                     samples="faces"),
             ["0-1", "1-2", "2-3", "3-4", "4-5", "5-6", "6-8"])]
        for method, call, ranges in cases:
            self.fake.calls = []
            call()
            keys: Dict[str, str] = {}
            for name, request, metadata in self.fake.calls:
                self.assertEqual(name, method)
                self.assertEqual(metadata["x-meshgauge-session"], "fake")
                r = metadata["x-meshgauge-range"]
                self.assertEqual(r, f"{request.range.begin}-"
                                    f"{request.range.end}")
                keys[r] = metadata["x-meshgauge-part"]
            self.assertEqual(keys, {r: str(i) for i, r in enumerate(ranges)},
                             method)
        # A call that is not fanned out carries neither.
        self.fake.calls = []
        self.fake.reply = chunk_and_summary(6, pb.SAMPLE_SET_VERTICES)
        self.client.sdf("fake")
        self.assertNotIn("x-meshgauge-part", self.fake.calls[0][2])
        self.assertNotIn("x-meshgauge-range", self.fake.calls[0][2])

    def test_fanned_out_sdf_merges_and_checks_its_ranges(self) -> None:
        self.fake.ranged = range_reply
        r = self.client.sdf("fake", fan_out=4)
        np.testing.assert_array_equal(r.values, 1 + np.arange(6) / 8)
        self.assertEqual(r.summary.ok, 6)
        self.assertEqual(r.summary.rays, 6)  # the ranges' rays, summed.
        self.assertEqual(r.summary.sdf_median, 1 + 2.5 / 8)
        # normalized over every value, not each range's 0.5.
        self.assertEqual(r.normalized[0], 0.0)
        self.assertEqual(r.normalized[5], 1.0)
        with self.assertRaises(ValueError):
            self.client.sdf("fake", fan_out=0)
        # Ranges of different generations (the session moved between
        # them), or a mesh of another generation: ABORTED.
        self.fake.ranged = lambda q: range_reply(q, q.range.begin // 3)
        with self.assertRaises(AbortedError) as e:
            self.client.sdf("fake", fan_out=2)
        self.assertIn("generations [0, 1]", e.exception.details)
        self.fake.ranged = range_reply
        self.fake.mesh_generation = 1
        try:
            with self.assertRaises(AbortedError):
                self.client.sdf("fake", fan_out=2)
        finally:
            self.fake.mesh_generation = 0
        # A server older than ranges answers the whole call: DATA_LOSS.
        self.fake.ranged = None
        self.fake.reply = chunk_and_summary(6, pb.SAMPLE_SET_VERTICES)
        with self.assertRaises(DataLossError) as e:
            self.client.sdf("fake", fan_out=2)
        self.assertIn("older than ComputeSdfRequest.range", e.exception.details)

    def test_penalty_ranges_carry_range_values_and_part(self) -> None:
        """A fanned-out penalty: the fanned-out ComputeSdf's ranges, then
        one ComputePenalty per range, each with its range, every sample's
        value, the values' generation as expected_generation, and
        x-meshgauge-range and x-meshgauge-part; merged exactly."""
        self.fake.ranged = range_reply
        self.fake.penalty = penalty_reply
        try:
            for k, samples, n, ranges in (
                    (2, "vertices", 6, ["0-3", "3-6"]),
                    (3, "faces", 8, ["0-2", "2-5", "5-8"])):
                self.fake.calls = []
                r = self.client.penalty("fake", 1.0, fan_out=k, rays=9,
                                        samples=samples)
                sdf = [c for c in self.fake.calls if c[0] == "ComputeSdf"]
                pen = [c for c in self.fake.calls
                       if c[0] == "ComputePenalty"]
                self.assertEqual(len(sdf) + len(pen), len(self.fake.calls))
                for calls in (sdf, pen):
                    keys: Dict[str, str] = {}
                    for _, request, metadata in calls:
                        self.assertEqual(metadata["x-meshgauge-session"],
                                         "fake")
                        self.assertTrue(request.HasField("range"))
                        rng = metadata["x-meshgauge-range"]
                        self.assertEqual(rng, f"{request.range.begin}-"
                                              f"{request.range.end}")
                        keys[rng] = metadata["x-meshgauge-part"]
                        self.assertEqual(request.params.rays, 9)
                        self.assertEqual(
                            request.params.samples,
                            pb.SAMPLE_SET_FACES if samples == "faces"
                            else pb.SAMPLE_SET_VERTICES)
                    self.assertEqual(
                        keys, {x: str(i) for i, x in enumerate(ranges)})
                for _, request, _ in pen:
                    # Every sample's value (range_reply's 1 + i / 8), not
                    # the range's.
                    self.assertEqual(list(request.values),
                                     [1 + i / 8 for i in range(n)])
                    self.assertTrue(request.HasField("expected_generation"))
                    self.assertEqual(request.expected_generation, 0)
                    self.assertEqual(request.t_min, 1.0)
                    self.assertTrue(request.with_gradient)
                # The exact sum of the ranges' partial sums, rounded once,
                # then the measure part.
                expected = k + 0.5 + 2.0 ** -51
                self.assertEqual(r.gradient.shape, (6, 3))
                self.assertTrue(np.all(r.gradient == expected),
                                f"K={k}: {r.gradient[0, 0]!r}")
                self.assertEqual(r.value, 2.5)
                self.assertEqual(r.missing_vertices, 1)
                self.assertEqual(r.world_frame_vertices, k)
            # Without the gradient: the range at 0's numbers.
            self.fake.calls = []
            r = self.client.penalty("fake", 1.0, fan_out=2, gradient=False)
            self.assertIsNone(r.gradient)
            self.assertEqual((r.value, r.world_frame_vertices), (2.5, 2))
            # One call: no range, no values, no routing keys.
            self.fake.calls = []
            self.fake.penalty = lambda q: pb.ComputePenaltyResponse(
                value=3.0, dimension=3, gradient=[0.25] * 18)
            r = self.client.penalty("fake", 1.0)
            self.assertEqual(r.value, 3.0)
            (name, request, metadata), = self.fake.calls
            self.assertEqual(name, "ComputePenalty")
            self.assertFalse(request.HasField("range"))
            self.assertEqual(len(request.values), 0)
            self.assertNotIn("x-meshgauge-part", metadata)
            self.assertNotIn("x-meshgauge-range", metadata)
            for bad in (0, -1, True, 2.0, "2"):
                with self.assertRaises(ValueError):
                    self.client.penalty("fake", 1.0, fan_out=bad)
        finally:
            self.fake.penalty = penalty_reply
            self.fake.ranged = None

    def test_fanned_out_penalty_checks_its_ranges(self) -> None:
        """Ranges of different generations are ABORTED; a server older
        than penalty ranges (the whole call's reply to each range, no
        partial sums) or a range at 0 without the measure part is
        DATA_LOSS."""
        self.fake.ranged = range_reply
        try:
            self.fake.penalty = lambda q: penalty_reply(
                q, q.range.begin // 3)
            with self.assertRaises(AbortedError) as e:
                self.client.penalty("fake", 1.0, fan_out=2)
            self.assertIn("generations [0, 1]", e.exception.details)
            self.fake.penalty = lambda q: pb.ComputePenaltyResponse(
                value=3.0, dimension=3, gradient=[0.25] * 18)
            with self.assertRaises(DataLossError) as e:
                self.client.penalty("fake", 1.0, fan_out=2)
            self.assertIn("older than penalty ranges", e.exception.details)

            def without_measure(q: Any) -> Any:
                reply = penalty_reply(q)
                del reply.measure_gradient[:]
                return reply

            self.fake.penalty = without_measure
            with self.assertRaises(DataLossError) as e:
                self.client.penalty("fake", 1.0, fan_out=3)
            self.assertIn("0 measure values", e.exception.details)

            def without_tails(q: Any) -> Any:
                reply = penalty_reply(q)
                if q.range.begin > 0:
                    del reply.tail_counts[:]
                    del reply.tails[:]
                return reply

            self.fake.penalty = without_tails
            with self.assertRaises(DataLossError) as e:
                self.client.penalty("fake", 1.0, fan_out=2)
            self.assertIn("no exact partial sums", e.exception.details)
        finally:
            self.fake.penalty = penalty_reply
            self.fake.ranged = None

    @unittest.skipUnless(CLI, "MESHGAUGE_CLI is not set")
    def test_the_cli_refuses_a_reply_of_another_face_count(self) -> None:
        # The right sample set, the wrong count: the CLI's outputs index the
        # file's faces by the reply, so a short reply is refused.
        self.fake.reply = chunk_and_summary(3, pb.SAMPLE_SET_FACES)
        with tempfile.TemporaryDirectory() as d:
            mesh = os.path.join(d, "octahedron.off")
            with open(mesh, "w") as f:
                f.write(OCTAHEDRON_OFF)
            csv = os.path.join(d, "out.csv")

            def sdf_of_faces() -> Any:
                return subprocess.run(
                    [CLI, "remote", "sdf", "--server", self.target,
                     "--session-id", "fake", "--samples", "faces", "--csv",
                     csv, mesh], capture_output=True, text=True, timeout=60)

            run = sdf_of_faces()
            self.assertEqual(run.returncode, 1, run.stdout)
            self.assertIn("error: DATA_LOSS: the server sent 3 values for 8 "
                          "faces", run.stderr)
            self.assertFalse(os.path.exists(csv))
            # The full count passes the same check.
            self.fake.reply = chunk_and_summary(8, pb.SAMPLE_SET_FACES)
            run = sdf_of_faces()
            self.assertEqual(run.returncode, 0, run.stderr)
            with open(csv) as f:
                self.assertEqual(len(f.read().splitlines()), 9)


if __name__ == "__main__":
    unittest.main()
