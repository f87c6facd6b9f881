"""The clients against a fake server that answers wrongly: what an older or
broken server sends must end in DATA_LOSS, never in values read as others.

The fake is the generated servicer with two methods: GetSession (the counts
of the mesh the test gives) and ComputeSdf (the reply the test sets)."""

import os
import subprocess
import tempfile
import unittest
from concurrent import futures
from typing import Any, List

import grpc

from meshgauge_client import DataLossError, MeshGaugeClient
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


class FakeServer(pb_grpc.MeshGaugeServicer):
    def __init__(self) -> None:
        self.reply: List[Any] = []

    def GetSession(self, request: Any, context: Any) -> Any:
        return pb.GetSessionResponse(session=pb.SessionInfo(
            session_id=request.session_id, dimension=3, num_vertices=6,
            num_faces=8))

    def ComputeSdf(self, request: Any, context: Any) -> Any:
        yield from self.reply


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
