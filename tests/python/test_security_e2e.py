"""The meshgauge-server process as an operator and an attacker meet it:
flags out of range exit 2 naming the flag, a taken or invalid address exits 1
with one line (no crash), reflection exists only with --reflection, and TLS
with tenant tokens works from the Python client and the CLI."""

import hashlib
import signal
import json
import os
import socket
import subprocess
import tempfile
import threading
import time
import unittest

import grpc
import numpy as np

from meshgauge_client import MeshGaugeClient, MeshGaugeError
from server_fixture import ServerProcess as Server

SERVER = os.environ["MESHGAUGE_SERVER"]
CLI = os.environ["MESHGAUGE_CLI"]
SANITIZED = bool(os.environ.get("MESHGAUGE_SANITIZED"))
HERE = os.path.dirname(os.path.abspath(__file__))
REFLECTION = "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo"


def octahedron():
    v = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1],
                  [0, 0, -1]], dtype=float)
    f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5],
                  [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    return v, f


def run_server(*flags, timeout=20):
    return subprocess.run([SERVER, "--metrics_address=", *flags],
                          capture_output=True, text=True, timeout=timeout)


def list_services_by_reflection(target, metadata=None, keep_open=False):
    """A raw reflection request (list_services = "", field 7): the response
    bytes, or the grpc error code. keep_open: the client does not half-close
    its stream after the request (as grpcurl does while it waits)."""
    release = threading.Event()

    def requests():
        yield b"\x3a\x00"
        if keep_open:
            release.wait(10)

    with grpc.insecure_channel(target) as channel:
        call = channel.stream_stream(REFLECTION)
        try:
            return b"".join(call(requests(), timeout=5, metadata=metadata))
        except grpc.RpcError as e:
            return e.code()
        finally:
            release.set()


class StartupAndFlags(unittest.TestCase):
    def test_limit_flags_out_of_range_exit_2_naming_the_flag(self):
        for flag, value in [("max_message_bytes", "-1"),
                            ("compute_threads", "-1"),
                            ("compute_threads", "5000"),
                            ("session_ttl_seconds", "-1"),
                            ("memory_budget_bytes", "-1"),
                            ("max_vertices", "-5"),
                            ("upload_idle_seconds", "0")]:
            p = run_server(f"--{flag}={value}", "--address=127.0.0.1:0")
            self.assertEqual(p.returncode, 2, (flag, value, p.stderr))
            self.assertIn(f"--{flag} must be in [", p.stderr)
            self.assertEqual(len(p.stderr.strip().splitlines()), 1, p.stderr)

    def test_taken_and_invalid_addresses_exit_1_with_one_line(self):
        with socket.socket() as holder:
            holder.bind(("127.0.0.1", 0))
            holder.listen()
            port = holder.getsockname()[1]
            p = run_server(f"--address=127.0.0.1:{port}")
            self.assertEqual(p.returncode, 1, p.stderr)
            self.assertIn(f"cannot listen on 127.0.0.1:{port}", p.stderr)
            # One line of ours naming the cause, none of gRPC's.
            self.assertIn("Address already in use", p.stderr)
            self.assertEqual(len(p.stderr.strip().splitlines()), 1, p.stderr)
        for address in ["this is not an address", "127.0.0.1:99999",
                        "127.0.0.1:", ":50051", "127.0.0.1:80x"]:
            p = run_server(f"--address={address}")
            self.assertEqual(p.returncode, 1, (address, p.stderr))
            self.assertIn(f"--address '{address}'", p.stderr)
            self.assertEqual(len(p.stderr.strip().splitlines()), 1, p.stderr)

    def test_malformed_numeric_flags_exit_2(self):
        for flag, value in [("max_rays", "abc"), ("max_message_bytes", "1e3x"),
                            ("session_ttl_seconds", "soon")]:
            p = run_server(f"--{flag}={value}", "--address=127.0.0.1:0")
            self.assertEqual(p.returncode, 2, (flag, p.stderr))
            self.assertIn(f"--{flag}", p.stderr)
            p = run_server(f"--{flag}", value, "--address=127.0.0.1:0")
            self.assertEqual(p.returncode, 2, (flag, p.stderr))

    def test_oversized_and_malformed_files_are_named(self):
        p = run_server("--address=127.0.0.1:0",
                       "--auth_tokens_file=/dev/zero")
        self.assertEqual(p.returncode, 1, p.stderr)
        self.assertIn("'/dev/zero' is larger than 1048576 bytes", p.stderr)
        with tempfile.NamedTemporaryFile("w", suffix=".pem") as junk:
            junk.write("not a certificate\n")
            junk.flush()
            p = run_server("--address=127.0.0.1:0",
                           f"--tls_cert_file={junk.name}",
                           f"--tls_key_file={junk.name}")
            self.assertEqual(p.returncode, 1, p.stderr)
            self.assertIn(f"--tls_cert_file file '{junk.name}' holds no PEM "
                          "certificate", p.stderr)
            self.assertEqual(len(p.stderr.strip().splitlines()), 1, p.stderr)

    def test_a_second_server_on_the_same_port_fails(self):
        first = Server()
        try:
            p = run_server(f"--address=127.0.0.1:{first.port}")
            self.assertEqual(p.returncode, 1, p.stderr)
            self.assertIn("cannot listen on", p.stderr)
        finally:
            first.stop()

    def test_reflection_only_with_the_flag(self):
        off = Server()
        try:
            self.assertEqual(list_services_by_reflection(off.target),
                             grpc.StatusCode.UNIMPLEMENTED)
            self.assertIn("reflection off", off.stderr())
        finally:
            off.stop()
        on = Server("--reflection")
        try:
            reply = list_services_by_reflection(on.target)
            self.assertIsInstance(reply, bytes)
            self.assertIn(b"meshgauge.v1.MeshGauge", reply)
        finally:
            on.stop()

    def test_reflection_needs_a_token_when_tokens_are_on(self):
        with tempfile.NamedTemporaryFile("w") as tokens:
            tokens.write("alice " + hashlib.sha256(b"s3cret").hexdigest() +
                         "\n")
            tokens.flush()
            on = Server("--reflection", f"--auth_tokens_file={tokens.name}")
            try:
                # Refused from the metadata, before the stream is read:
                # no schema, no waiting, a status of ours.
                for metadata, keep_open in [(None, False),
                                            ([("authorization",
                                               "Bearer wrong")], False),
                                            (None, True)]:
                    self.assertEqual(
                        list_services_by_reflection(on.target, metadata,
                                                    keep_open),
                        grpc.StatusCode.UNAUTHENTICATED)
                reply = list_services_by_reflection(
                    on.target, [("authorization", "Bearer s3cret")])
                self.assertIsInstance(reply, bytes)
                self.assertIn(b"meshgauge.v1.MeshGauge", reply)
            finally:
                on.stop()

    def test_open_mode_is_logged(self):
        s = Server()
        try:
            self.assertIn("UNAUTHENTICATED (open mode", s.stderr())
        finally:
            s.stop()


def _varint(n):
    out = b""
    while True:
        low, n = n & 0x7F, n >> 7
        if not n:
            return out + bytes([low])
        out += bytes([low | 0x80])


def _field(number, payload):
    """A length-delimited protobuf field."""
    return bytes([(number << 3) | 2]) + _varint(len(payload)) + payload


def _memory_mib(pid):
    """VmHWM (peak) and VmRSS of a process, in MiB."""
    out = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, value = line.split(":", 1)
            if key in ("VmHWM", "VmRSS"):
                out[key] = int(value.split()[0]) / 1024
    return out


class UploadMemory(unittest.TestCase):
    """Upload amplification, measured from the server's /proc: a header
    declaring 4 faces followed by chunks of packed face sizes (one byte each
    on the wire, four once parsed, and more while the array grows). Stated
    bound: per upload in flight, at most 8 x --max_upload_message_bytes above
    the idle server, and what a refused upload used is given back."""

    HEADER = _field(1, b"\x10\x03\x18\x04\x20\x04")  # 3D, 4 v, 4 f.
    LIMIT_MIB = 16  # --max_upload_message_bytes' default.
    HELD_MIB = 64  # what refused uploads may leave held.

    @staticmethod
    def chunk(mib):
        """A header declaring 4 faces, then mib MiB of packed face sizes."""
        return [UploadMemory.HEADER,
                _field(2, _field(2, b"\x03" * (mib << 20)))]

    def upload(self, target, messages, results):
        with grpc.insecure_channel(target) as channel:
            call = channel.stream_unary(
                "/meshgauge.v1.MeshGauge/CreateSession")
            try:
                call(iter(messages), timeout=60)
                results.append(("OK", ""))
            except grpc.RpcError as e:
                results.append((e.code(), e.details()))

    def run_uploads(self, messages, count, code, detail):
        """count concurrent uploads of `messages`, every one refused with
        code and detail; the server's peak and held memory above its idle
        size, in MiB."""
        s = Server("--memory_budget_bytes=268435456")
        try:
            base = _memory_mib(s.proc.pid)
            results = []
            threads = [threading.Thread(target=self.upload,
                                        args=(s.target, messages, results))
                       for _ in range(count)]
            for t in threads:
                t.start()
            for t in threads:
                t.join()
            # The replies come before the server frees the streams: wait
            # (up to 10 s) until it holds less than HELD_MIB, or say what
            # it still holds.
            deadline = time.time() + 10
            after = _memory_mib(s.proc.pid)
            while (not SANITIZED and time.time() < deadline and
                   after["VmRSS"] - base["VmRSS"] >= self.HELD_MIB):
                time.sleep(0.05)
                after = _memory_mib(s.proc.pid)
        finally:
            s.stop()
        self.assertEqual(len(results), count)
        for got, details in results:
            self.assertEqual(got, code)
            self.assertIn(detail, details)
        peak = after["VmHWM"] - base["VmRSS"]
        held = after["VmRSS"] - base["VmRSS"]
        print(f"{count} uploads of {len(messages[-1]) >> 20} MiB messages: "
              f"peak +{peak:.0f} MiB, held +{held:.0f} MiB")
        return peak, held

    def test_oversized_chunks_are_refused_before_they_are_parsed(self):
        peak, held = self.run_uploads(self.chunk(64), 8,
                                      grpc.StatusCode.RESOURCE_EXHAUSTED,
                                      "--max_upload_message_bytes")
        if SANITIZED:
            return  # ASan's shadow memory and quarantine change the sizes.
        self.assertLess(peak, 8 * 8 * self.LIMIT_MIB)
        self.assertLess(held, self.HELD_MIB)

    def test_chunks_over_the_declared_counts_are_refused_unstored(self):
        peak, _ = self.run_uploads(self.chunk(12), 4,
                                   grpc.StatusCode.INVALID_ARGUMENT,
                                   "more than the declared 4 faces")
        if not SANITIZED:
            self.assertLess(peak, 4 * 8 * self.LIMIT_MIB)

    def test_a_header_of_empty_sub_messages_is_refused_unparsed(self):
        # Just under 16 MiB of empty region directions (2 bytes each on the
        # wire, a heap object each once parsed).
        header = _field(1, b"\x10\x03\x18\x04\x20\x04" +
                        b"\x2a\x00" * 8_388_000)
        peak, held = self.run_uploads([header], 4,
                                      grpc.StatusCode.RESOURCE_EXHAUSTED,
                                      "region directions")
        if not SANITIZED:
            self.assertLess(peak, 4 * 8 * self.LIMIT_MIB)
            self.assertLess(held, self.HELD_MIB)


class AnonymousCalls(unittest.TestCase):
    """An attacker without a token sends big unary calls: the token is
    checked from the call's metadata before its message is read, so each
    costs the server O(1) memory (measured from its /proc), not the
    message's size."""

    MIB = 100
    BOUND_MIB = 100  # peak above the idle server for two such calls.

    def update(self, target, results):
        doubles = (self.MIB << 20) // 8
        request = (_field(1, b"s" * 16) +
                   _field(4, b"\x00" * (doubles * 8)))
        with grpc.insecure_channel(
                target,
                options=[("grpc.max_send_message_length", -1)]) as channel:
            call = channel.unary_unary("/meshgauge.v1.MeshGauge/"
                                       "UpdatePositions")
            try:
                call(request, timeout=60)
                results.append(("OK", ""))
            except grpc.RpcError as e:
                results.append((e.code(), e.details()))

    def test_two_anonymous_100_mib_updates_are_refused_unread(self):
        tokens = os.path.join(tempfile.mkdtemp(), "tokens")
        with open(tokens, "w") as f:
            f.write("a " + hashlib.sha256(b"secret").hexdigest() + "\n")
        s = Server(f"--auth_tokens_file={tokens}")
        try:
            base = _memory_mib(s.proc.pid)
            results = []
            threads = [threading.Thread(target=self.update,
                                        args=(s.target, results))
                       for _ in range(2)]
            for t in threads:
                t.start()
            for t in threads:
                t.join()
            after = _memory_mib(s.proc.pid)
            # Health stays open to balancers without a token.
            with grpc.insecure_channel(s.target) as channel:
                health = channel.unary_unary("/grpc.health.v1.Health/Check")
                self.assertEqual(health(b"", timeout=10), b"\x08\x01")
        finally:
            s.stop()
        self.assertEqual(len(results), 2)
        for got, details in results:
            self.assertEqual(got, grpc.StatusCode.UNAUTHENTICATED, details)
            self.assertIn("authorization", details)
        peak = after["VmHWM"] - base["VmRSS"]
        print(f"2 anonymous {self.MIB} MiB updates: peak +{peak:.0f} MiB")
        if not SANITIZED:
            self.assertLess(peak, self.BOUND_MIB)


class TokenRotation(unittest.TestCase):
    """SIGHUP re-reads the tokens file: a rotation lists the old and the new
    token, then the new one alone; calls in between work with either (and
    see the tenant's sessions), a malformed file keeps the tokens."""

    @staticmethod
    def write(path, *lines):
        with open(path, "w") as f:
            for tenant, token in lines:
                f.write(f"{tenant} {hashlib.sha256(token.encode()).hexdigest()}\n")

    def test_sighup_rotates_a_token_without_a_restart(self):
        tmp = tempfile.mkdtemp()
        tokens = os.path.join(tmp, "tokens")
        self.write(tokens, ("alice", "old"))
        server = Server(f"--auth_tokens_file={tokens}")
        try:
            def code(token):
                with MeshGaugeClient(server.target, token=token,
                                     deadline=10) as c:
                    try:
                        c.list()
                        return grpc.StatusCode.OK
                    except MeshGaugeError as e:
                        return e.code

            def await_code(token, want):
                deadline = time.time() + 10
                while code(token) != want and time.time() < deadline:
                    time.sleep(0.05)
                self.assertEqual(code(token), want, token)

            v, f = octahedron()
            with MeshGaugeClient(server.target, token="old") as c:
                c.upload(v, f, session_id="mine")
            self.assertEqual(code("new"), grpc.StatusCode.UNAUTHENTICATED)
            self.write(tokens, ("alice", "old"), ("alice", "new"))
            server.proc.send_signal(signal.SIGHUP)
            await_code("new", grpc.StatusCode.OK)
            self.assertEqual(code("old"), grpc.StatusCode.OK)
            with MeshGaugeClient(server.target, token="new") as c:
                self.assertEqual([s.session_id for s in c.list()], ["mine"])
            self.write(tokens, ("alice", "new"))
            server.proc.send_signal(signal.SIGHUP)
            await_code("old", grpc.StatusCode.UNAUTHENTICATED)
            with open(tokens, "w") as f:
                f.write("alice not-a-hash\n")
            server.proc.send_signal(signal.SIGHUP)
            deadline = time.time() + 10
            while ("tokens kept" not in server.stderr() and
                   time.time() < deadline):
                time.sleep(0.05)
            self.assertIn("tokens kept", server.stderr())
            self.assertEqual(code("new"), grpc.StatusCode.OK)
            self.assertIsNone(server.proc.poll())
        finally:
            server.stop()


class TlsAndTokens(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.pki = tempfile.mkdtemp()
        subprocess.run(["bash", os.path.join(HERE, "..", "make_test_pki.sh"),
                        cls.pki], check=True)
        tokens = os.path.join(cls.pki, "tokens")
        with open(tokens, "w") as f:
            for tenant in ("alice", "bob"):
                digest = hashlib.sha256(f"{tenant}-token".encode()).hexdigest()
                f.write(f"{tenant} {digest}\n")
        cls.server = Server(f"--tls_cert_file={cls.pki}/server.crt",
                            f"--tls_key_file={cls.pki}/server.key",
                            f"--tls_client_ca_file={cls.pki}/ca.crt",
                            f"--auth_tokens_file={tokens}")

    @classmethod
    def tearDownClass(cls):
        cls.server.stop()
        log = cls.server.stderr()
        assert "alice-token" not in log and "bob-token" not in log, log

    def client(self, token):
        p = self.pki
        return MeshGaugeClient(self.server.target, token=token, deadline=10,
                               tls_ca_file=f"{p}/ca.crt",
                               tls_cert_file=f"{p}/client.crt",
                               tls_key_file=f"{p}/client.key")

    def test_python_client_with_tls_and_tokens(self):
        v, f = octahedron()
        with self.client("alice-token") as alice, self.client("bob-token") as bob:
            sid = alice.upload(v, f, session_id="oct").session_id
            self.assertEqual(alice.sdf(sid).values.shape, (6,))
            with self.assertRaises(MeshGaugeError) as e:
                bob.sdf(sid)
            self.assertEqual(e.exception.code, grpc.StatusCode.NOT_FOUND)
            self.assertEqual(bob.list(), [])
            alice.delete(sid)
        with self.client("wrong") as mallory:
            with self.assertRaises(MeshGaugeError) as e:
                mallory.list()
            self.assertEqual(e.exception.code, grpc.StatusCode.UNAUTHENTICATED)

    def test_cli_with_tls_and_token_file_or_environment(self):
        knight = os.path.join(os.environ["MESHGAUGE_MESH_DIR"],
                              "decimated-knight.off")
        token_file = os.path.join(self.pki, "alice.token")
        with open(token_file, "w") as f:
            f.write("alice-token\n")
        tls = ["--server", self.server.target,
               "--tls-ca-file", f"{self.pki}/ca.crt",
               "--tls-cert-file", f"{self.pki}/client.crt",
               "--tls-key-file", f"{self.pki}/client.key"]
        env = dict(os.environ)
        env.pop("MESHGAUGE_TOKEN", None)
        up = subprocess.run([CLI, "remote", "upload", knight, "--session-id",
                             "k", "--token-file", token_file, *tls],
                            capture_output=True, text=True, env=env, timeout=60)
        self.assertEqual(up.returncode, 0, up.stderr)
        env["MESHGAUGE_TOKEN"] = "alice-token"
        info = subprocess.run([CLI, "remote", "info", "k", "--json", *tls],
                              capture_output=True, text=True, env=env,
                              timeout=60)
        self.assertEqual(info.returncode, 0, info.stderr)
        self.assertEqual(json.loads(info.stdout)["vertices"], 502)
        env["MESHGAUGE_TOKEN"] = "bob-token"
        other = subprocess.run([CLI, "remote", "info", "k", *tls],
                               capture_output=True, text=True, env=env,
                               timeout=60)
        self.assertEqual(other.returncode, 1)
        self.assertIn("no session 'k'", other.stderr)
        # Plain text to the TLS port: no connection, refused once
        # --connect-timeout has passed (20 s by default).
        start = time.monotonic()
        plain = subprocess.run([CLI, "remote", "list", "--server",
                                self.server.target, "--connect-timeout", "1"],
                               capture_output=True, text=True, env=env,
                               timeout=60)
        self.assertEqual(plain.returncode, 1)
        self.assertIn("unavailable", plain.stderr.lower())
        self.assertLess(time.monotonic() - start, 15)


if __name__ == "__main__":
    unittest.main(verbosity=2)
