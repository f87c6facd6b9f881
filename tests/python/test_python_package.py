"""The meshgauge-client package as a user installs and uses it: a venv
install that the end-to-end tests then run against (no PYTHONPATH), mypy
--strict, frozen typed results, the sparse Jacobian, and a Session that
survives a server restart in the middle of an optimisation with the same
result as an undisturbed run."""

import dataclasses
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import unittest

import numpy as np
import scipy.sparse

import meshgauge_client
from meshgauge_client import (FailedPreconditionError, InvalidArgumentError,
                              MeshGaugeClient, NotFoundError, PenaltyResult,
                              SdfResult, VertexStatus)

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.abspath(os.path.join(HERE, "..", ".."))
MESHES = os.environ.get("MESHGAUGE_MESH_DIR",
                        os.path.join(SOURCE, "data", "meshes"))
sys.path.insert(0, os.path.join(SOURCE, "client", "python", "examples"))
import thicken_dumbbell  # noqa: E402
from server_fixture import ServerProcess  # noqa: E402


def descend(client, steps, on_step=None):
    """A fixed-step gradient descent on the dumbbell's penalty: a
    deterministic optimisation whose result depends on every value."""
    x0, segments = thicken_dumbbell.dumbbell(neck=0.3, h=0.05)
    x = x0.copy()
    with client.session(x0, segments) as s:
        for k in range(steps):
            s.update(x)
            pen = s.penalty(0.7)
            x = x - 0.02 * pen.gradient
            if on_step:
                on_step(k)
        return x, pen.value, s.recreated


class PackageTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.server = ServerProcess()
        cls.client = MeshGaugeClient(cls.server.target, retry_seconds=20)

    @classmethod
    def tearDownClass(cls):
        cls.client.close()
        cls.server.close()

    def test_session_survives_a_server_restart_with_the_same_result(self):
        undisturbed, p0, n0 = descend(self.client, 12)
        self.assertEqual(n0, 0)

        def restart(k):
            if k == 5:
                self.server.kill()
                self.server.start()

        disturbed, p1, n1 = descend(self.client, 12, restart)
        self.assertEqual(n1, 1, "the session was re-created once")
        np.testing.assert_array_equal(disturbed, undisturbed)
        self.assertEqual(p1, p0)

    def test_results_are_frozen_typed_and_numpy(self):
        v, f = thicken_dumbbell.dumbbell(neck=0.3, h=0.1)
        with self.client.session(v, f) as s:
            r = s.sdf()
            self.assertIsInstance(r, SdfResult)
            self.assertEqual(r.values.shape, (len(v),))
            self.assertEqual(r.values.dtype, np.float64)
            self.assertTrue(all(VertexStatus(x) == VertexStatus.OK
                                for x in r.status))
            self.assertEqual(set(r.status_names()), {"OK"})
            with self.assertRaises(dataclasses.FrozenInstanceError):
                r.values = None
            pen = s.penalty(0.6)
            self.assertIsInstance(pen, PenaltyResult)
            self.assertEqual(pen.gradient.shape, (len(v), 2))
            self.assertEqual(pen.missing_fraction, 0.0)
            g = s.constraint(0.6, rho=40)
            self.assertEqual(g.form, "ks")
            self.assertGreater(g.value, 0)
            cal = s.calibrate(0.6)
            self.assertEqual(cal.compared, len(v))
            # The inscribed ball never exceeds the normal ray's chord.
            self.assertEqual(cal.ball_compared, len(v))
            self.assertEqual(cal.ball_higher, 0)
            self.assertEqual(int(cal.ball_histogram.sum()), len(v))

    def test_jacobian_is_a_sparse_matrix_consistent_with_the_vjp(self):
        v, f = thicken_dumbbell.dumbbell(neck=0.3, h=0.1)
        with self.client.session(v, f) as s:
            jac = s.jacobian()
            self.assertTrue(scipy.sparse.isspmatrix_csr(jac))
            self.assertEqual(jac.shape, (len(v), 2 * len(v)))
            g = np.cos(np.arange(len(v)))
            np.testing.assert_allclose((jac.T @ g).reshape(-1, 2), s.vjp(g),
                                       rtol=1e-12, atol=1e-12)

    def test_errors_are_status_subclasses_and_argument_errors_come_first(self):
        with self.assertRaises(NotFoundError):
            self.client.info("nobody")
        v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
        with self.client.session(v, [[0, 1, 2]]) as s:  # a planar sheet
            with self.assertRaises(FailedPreconditionError) as e:
                s.penalty(1.0)
            self.assertIn("open or planar", e.exception.details)
            with self.assertRaises(ValueError):
                s.penalty(1.0, form="cones")
            with self.assertRaises(ValueError):
                s.penalty(-1.0)
            with self.assertRaises(ValueError):
                s.update(np.zeros((2, 3)))

    def test_generated_ids_and_deletion_on_exit(self):
        v, f = thicken_dumbbell.dumbbell(neck=0.3, h=0.1)
        with self.client.session(v, f) as s:
            sid = s.session_id
            self.assertTrue(sid.startswith("py-"))
            self.assertIn(sid, [i.session_id for i in self.client.list()])
        self.assertNotIn(sid, [i.session_id for i in self.client.list()])

    def test_a_file_session_reads_as_the_cli_and_survives_loss(self):
        path = os.path.join(MESHES, "fandisk.obj")
        with self.client.session_from_file(path, reorient=True) as s:
            info = s.info()
            self.assertEqual(s.positions.shape, (info.num_vertices, 3))
            self.assertEqual(len(s.faces), info.num_faces)
            first = s.sdf().values
            # The CLI reads the same file to the same values, bit for bit.
            with tempfile.TemporaryDirectory() as tmp:
                csv = os.path.join(tmp, "v.csv")
                subprocess.run([os.environ["MESHGAUGE_CLI"], "sdf", path,
                                "--reorient", "--csv", csv], check=True,
                               capture_output=True)
                cli = np.genfromtxt(csv, delimiter=",", skip_header=1,
                                    usecols=4)
            np.testing.assert_array_equal(first, cli)
            # Lost by the server: the file is sent again, same values.
            self.client.delete(s.session_id)
            np.testing.assert_array_equal(s.sdf().values, first)
            self.assertEqual(s.recreated, 1)
        with tempfile.NamedTemporaryFile(suffix=".obj") as bad:
            bad.write(b"v 0 0 0\nf 1 2 3\n")
            bad.flush()
            with self.assertRaises(InvalidArgumentError) as e:
                self.client.session_from_file(bad.name)
            # Named by the path as given, with its line.
            self.assertIn(bad.name + ": line 2", e.exception.details)
        with self.assertRaises(ValueError):
            self.client.session_from_file(path.replace(".obj", ".3ds"))
        with tempfile.TemporaryDirectory() as tmp:
            fifo = os.path.join(tmp, "pipe.obj")
            os.mkfifo(fifo)  # would block a reader forever
            with self.assertRaises(ValueError):
                self.client.session_from_file(fifo)

    def test_a_file_session_is_re_created_from_the_bytes_it_sent(self):
        tetra = (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                 b"f 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n")
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "tetra.obj")
            with open(path, "wb") as f:
                f.write(tetra)
            with self.client.session_from_file(path) as s:
                first = s.sdf().values
                with open(path, "wb") as f:  # the file changes...
                    f.write(tetra.replace(b"v 0 0 1", b"v 0 0 3"))
                self.client.delete(s.session_id)  # ...and the server lost it
                np.testing.assert_array_equal(s.sdf().values, first)
                self.assertEqual(s.recreated, 1)

    def test_mesh_objects_with_polygons_and_the_repairs(self):
        hexagon = [(np.cos(k * np.pi / 3), np.sin(k * np.pi / 3))
                   for k in range(6)]
        vertices = np.array([(x, y, z) for z in (0.0, 1.0)
                             for x, y in hexagon])
        faces = [[5, 4, 3, 2, 1, 0], [6, 7, 8, 9, 10, 11]] + [
            [k, (k + 1) % 6, (k + 1) % 6 + 6, k + 6] for k in range(6)]

        class Prism:  # trimesh-like: .vertices and ragged .faces
            pass

        prism = Prism()
        prism.vertices = vertices
        prism.faces = faces
        with self.client.session(prism) as s:
            self.assertEqual(s.info().num_faces, 14)
            self.assertTrue(all(len(f) in (3, 4) for f in s.faces))
            self.assertAlmostEqual(s.info().signed_volume,
                                   1.5 * np.sqrt(3), places=12)
            self.assertTrue(np.isfinite(s.sdf().values).all())
        # Inward faces: reorient=True turns them outward and says so.
        inward = [list(reversed(f)) for f in faces]
        with self.client.session(vertices, inward, reorient=True) as s:
            self.assertGreater(s.info().signed_volume, 0)
            self.assertTrue(any("inward-oriented closed components reversed"
                                in w for w in s.warnings))
        # Indices are integers in int32 range, never truncated.
        with self.assertRaises(ValueError):
            self.client.session(vertices, [[0.9, 2.9, 1.9]] + faces[1:])
        with self.assertRaises(ValueError):
            self.client.session(vertices, [[0, 1, 2**31]] + faces[1:])

        class Block:
            def __init__(self, kind, data):
                self.type, self.data = kind, data

        class SecondOrder:  # meshio-like, with a quadratic triangle block
            points = vertices
            cells = [Block("triangle6", [[0, 1, 2, 6, 7, 8]])]

        with self.assertRaises(ValueError):
            self.client.session(SecondOrder())
        # A zero-area face (collinear corners): refused, or dropped when
        # asked.
        centre = np.vstack([vertices, [[0.0, 0.0, 0.0]]])
        flat = faces + [[0, 12, 3]]
        with self.assertRaises(InvalidArgumentError) as e:
            self.client.session(centre, flat)
        self.assertIn("drop_degenerate_faces=True", e.exception.details)
        with self.client.session(centre, flat,
                                 drop_degenerate_faces=True) as s:
            self.assertEqual(s.info().num_faces, 14)

    def test_the_retry_policy_is_the_file_next_to_the_proto(self):
        from meshgauge_client import client as client_module
        with open(os.path.join(SOURCE, "proto", "meshgauge", "v1",
                               "service_config.json")) as f:
            self.assertEqual(json.loads(client_module._SERVICE_CONFIG),
                             json.load(f))

    def test_the_readme_file_example_runs(self):
        with open(os.path.join(SOURCE, "README.md")) as f:
            snippet = re.search(r"```python\n(.*?session_from_file.*?)```",
                                f.read(), re.S).group(1)
        snippet = snippet.replace("127.0.0.1:50051", self.server.target)
        snippet = snippet.replace(
            '"part.obj"', repr(os.path.join(MESHES, "fandisk.obj")))
        p = subprocess.run([sys.executable, "-c", snippet],
                           capture_output=True, text=True, timeout=120)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertRegex(p.stdout, r"\) [0-9.e+-]+\n$")

    def test_mypy_strict_is_clean(self):
        mypy = shutil.which("mypy", path="/usr/bin")
        self.assertIsNotNone(mypy, "Debian's mypy is needed (install_deps)")
        package = os.path.dirname(meshgauge_client.__file__)
        p = subprocess.run(
            [mypy, "--config-file",
             os.path.join(SOURCE, "client", "python", "pyproject.toml"),
             "-p", "meshgauge_client"], cwd=os.path.dirname(package),
            capture_output=True, text=True, timeout=300)
        self.assertEqual(p.returncode, 0, p.stdout + p.stderr)


def release_version():
    with open(os.path.join(SOURCE, "VERSION")) as f:
        return f.readline().strip()


class VersionTest(unittest.TestCase):
    def test_cli_server_and_package_say_the_version_of_VERSION(self):
        version = release_version()
        self.assertRegex(version, r"^\d+\.\d+\.\d+$")
        self.assertEqual(meshgauge_client.__version__, version)
        cli = subprocess.run([os.environ["MESHGAUGE_CLI"], "--version"],
                             capture_output=True, text=True, check=True)
        self.assertTrue(cli.stdout.startswith(f"meshgauge {version} ("),
                        cli.stdout)
        server = subprocess.run([os.environ["MESHGAUGE_SERVER"], "--version"],
                                capture_output=True, text=True)
        self.assertEqual(server.returncode, 0, server.stderr)
        self.assertEqual(server.stdout.strip(), f"meshgauge-server {version}")


class VenvInstallTest(unittest.TestCase):
    def test_the_readme_install_and_the_e2e_tests_against_it(self):
        # The README's two lines as written, run by the shell with the
        # caller's PATH (where another python3 may come first), from a copy
        # of the folders they name.
        with open(os.path.join(SOURCE, "README.md")) as f:
            readme = f.read()
        lines = re.search(r"```sh\n(\S*python3 -m venv[^\n]*\n[^\n]*pip "
                          r"install[^\n]*)\n```", readme).group(1)
        work = tempfile.mkdtemp()
        # web/: the report page's scripts (Session.report), bundled by
        # scripts/install_web_deps.sh.
        for part in ("client", "proto", "web"):
            shutil.copytree(os.path.join(SOURCE, part), os.path.join(work, part),
                            ignore=shutil.ignore_patterns("build", "*.egg-info",
                                                          "node_modules"))
        shutil.copy(os.path.join(SOURCE, "VERSION"), work)
        p = subprocess.run(["bash", "-ec", lines + " -q"], cwd=work,
                           capture_output=True, text=True, timeout=300)
        self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
        venv = os.path.join(work, ".venv")
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        python = os.path.join(venv, "bin", "python")
        where = subprocess.run(
            [python, "-c", "import meshgauge_client, importlib.util;"
             "print(meshgauge_client.__file__);"
             "print(importlib.util.find_spec('meshgauge'))"],
            capture_output=True, text=True, env=env, cwd=tempfile.gettempdir(),
            check=True).stdout.split()
        self.assertTrue(where[0].startswith(venv), where)
        self.assertEqual(where[1], "None", "no top-level meshgauge package")
        installed = subprocess.run(
            [python, "-c", "import meshgauge_client as m, importlib.metadata "
             "as md; print(m.__version__, md.version('meshgauge-client'))"],
            capture_output=True, text=True, env=env, cwd=tempfile.gettempdir(),
            check=True).stdout.split()
        self.assertEqual(installed, [release_version()] * 2)
        p = subprocess.run([python, "-m", "unittest", "test_remote_e2e"],
                           capture_output=True, text=True, env=env, cwd=HERE,
                           timeout=300)
        self.assertEqual(p.returncode, 0, p.stderr[-3000:])


if __name__ == "__main__":
    unittest.main(verbosity=2)
