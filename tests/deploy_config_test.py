"""The deployment's files: monitoring, balancer health check, stack.sh.

Every metric in the alert rules and the Grafana dashboard must be one that
server/metrics.cc registers (or Prometheus' own `up`, or the Redis
exporter's `redis_up`), the dashboard must be Grafana JSON with a Prometheus
target per panel, and the rules must cover replica down, error ratio, p95
latency and Redis down. The balancer's health check, raw HTTP/2 frames in
hex, must be deploy/haproxy/health_check.py's output and decode to a
grpc.health.v1.Health/Check call that passes only on SERVING. Swarm and
compose name their volumes apart, and stack.sh refuses bad arguments before
it calls Docker.
"""

import json
import os
import re
import subprocess
import sys
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXTERNAL = {"up", "redis_up"}


def read(*path):
    with open(os.path.join(ROOT, *path)) as f:
        return f.read()


def exported():
    src = read("server", "metrics.cc")
    names = set(re.findall(r'\.Name\("([a-z_]+)"\)', src))
    # Histograms also export _bucket, _sum and _count.
    return names | {n + s for n in names for s in ("_bucket", "_sum", "_count")}


def recorded():
    """Recording rules: deploy/stack.sh's (the desired replica count) and
    the alert file's own."""
    return set(re.findall(r"record: ([a-z0-9_:]+)",
                          read("deploy", "stack.sh")
                          + read("deploy", "prometheus", "alerts.yml")))


def metrics_in(expr):
    words = set(re.findall(
        r"(?<![\w:])([a-z_][a-z0-9_:]*)\b(?=\s*[{\[)]|\s*$|\s*[=<>])", expr))
    return {w for w in words
            if w.startswith(("meshgauge_", "meshgauge:", "redis_", "process_"))
            or w == "up"}


class DeployConfigTest(unittest.TestCase):
    def test_alert_rules_use_exported_metrics(self):
        text = read("deploy", "prometheus", "alerts.yml")
        # Each rule's expression: up to its `for:` or the next rule.
        exprs = re.findall(
            r"expr: \|?\n?((?:.+\n)+?)\s+(?:for:|- alert:|- record:)", text)
        self.assertGreaterEqual(len(exprs), 5)
        known = exported() | EXTERNAL | recorded()
        self.assertIn("meshgauge:replicas_desired", recorded())
        for e in exprs:
            used = metrics_in(e)
            self.assertTrue(used, e)
            self.assertLessEqual(used, known, e)
        for alert in ("MeshgaugeReplicasBelowDesired",
                      "MeshgaugeReplicaRestarting", "MeshgaugeReplicaDown",
                      "MeshgaugeErrorRatio", "MeshgaugeLatencyP95",
                      "MeshgaugeRedisDown"):
            self.assertIn(f"alert: {alert}", text)

    def test_dashboard_is_grafana_json_with_exported_metrics(self):
        dash = json.loads(read("deploy", "grafana", "meshgauge-dashboard.json"))
        self.assertEqual(dash["uid"], "meshgauge")
        self.assertGreaterEqual(len(dash["panels"]), 6)
        known = exported() | EXTERNAL | recorded()
        for p in dash["panels"]:
            self.assertTrue(p["targets"], p["title"])
            for t in p["targets"]:
                used = metrics_in(t["expr"])
                self.assertTrue(used, t["expr"])
                self.assertLessEqual(used, known, t["expr"])

    def test_balancer_health_check_is_the_generators_output(self):
        cfg = read("deploy", "haproxy", "haproxy.cfg")
        block = re.search(r"# BEGIN health_check.py\n(.*?)\n\s*# END "
                          r"health_check.py", cfg, re.S)
        self.assertIsNotNone(block)
        generated = subprocess.run(
            [sys.executable,
             os.path.join(ROOT, "deploy", "haproxy", "health_check.py")],
            check=True, capture_output=True, text=True).stdout
        self.assertEqual(block.group(1), generated.rstrip("\n"))

    def test_swarm_and_compose_volumes_are_named_apart(self):
        compose = re.search(r"\nvolumes:\n((?:  .*\n)+)",
                            read("deploy", "docker-compose.yml")).group(1)
        swarm = re.search(r"\nvolumes:\n((?:  .*\n)+)",
                          read("deploy", "stack.yml")).group(1)
        # Compose prefixes its project name: meshgauge_redis-data.
        compose_names = {f"meshgauge_{v}"
                         for v in re.findall(r"^  ([\w-]+):", compose, re.M)}
        swarm_names = set(re.findall(r"name: ([\w-]+)", swarm))
        self.assertEqual(len(swarm_names), 2, swarm)
        self.assertFalse(compose_names & swarm_names)

    def test_stack_refuses_bad_arguments_before_docker(self):
        """stack.sh exits 2 on a count that is not a number and an unknown
        `down` flag, before it calls Docker (the docker commands on PATH
        here only say they were called)."""
        env = dict(os.environ)
        bin_dir = subprocess.run(["mktemp", "-d"], capture_output=True,
                                 text=True, check=True).stdout.strip()
        for tool in ("docker", "docker-compose"):
            path = os.path.join(bin_dir, tool)
            with open(path, "w") as f:
                f.write("#!/bin/sh\necho called >&2\nexit 99\n")
            os.chmod(path, 0o755)
        env["PATH"] = bin_dir + ":/usr/bin:/bin"
        for args in (["scale", "two"], ["scale", "-1"], ["up", "2x"],
                     ["down", "--bogus"]):
            r = subprocess.run(["bash", os.path.join(ROOT, "deploy", "stack.sh"),
                                *args],
                               capture_output=True, text=True, env=env,
                               timeout=60)
            self.assertEqual(r.returncode, 2, (args, r.stderr))
            self.assertNotIn("called", r.stderr, args)

    def test_balancer_health_check_is_a_grpc_health_call(self):
        cfg = read("deploy", "haproxy", "haproxy.cfg")
        sent = bytes.fromhex("".join(
            re.findall(r"^\s*tcp-check send-binary ([0-9a-f]+)", cfg, re.M)))
        preface = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n"
        self.assertTrue(sent.startswith(preface))
        frames = h2_frames(sent[len(preface):])
        self.assertEqual([(t, f, sid) for t, f, sid, _ in frames],
                         [(H2_SETTINGS, 0, 0), (H2_HEADERS, END_HEADERS, 1),
                          (H2_DATA, END_STREAM, 1)])
        self.assertEqual(frames[0][3], b"")
        self.assertEqual(hpack_fields(frames[1][3]), [
            (":method", "POST"), (":scheme", "http"),
            (":path", "/grpc.health.v1.Health/Check"),
            (":authority", "meshgauge"),
            ("content-type", "application/grpc"), ("te", "trailers")])
        # An empty HealthCheckRequest: not compressed, length 0.
        self.assertEqual(frames[2][3], b"\0" + (0).to_bytes(4, "big"))
        # Healthy: a 2-byte HealthCheckResponse, status (field 1, varint) =
        # SERVING (1). The first expect waits for the reply up to the
        # status value (HAProxy matches rbinary on upper-case hex, from a
        # byte boundary); the second decides: NOT_SERVING (draining) is a
        # conditional pass (out of the rotation, calls in flight go on).
        serving = b"\0" + (2).to_bytes(4, "big") + bytes([1 << 3 | 0, 1])
        expects = re.findall(r"^\s*tcp-check expect (.+?) comment", cfg, re.M)
        self.assertEqual(expects, [
            "rbinary ^([0-9A-F]{2})*" + serving[:-1].hex().upper(),
            "min-recv 0 error-status L7OKC binary " + serving.hex()])
        server = re.search(r"^\s*default-server (.*)$", cfg, re.M).group(1)
        self.assertTrue(server.startswith("proto h2 check check-proto none "))
        # A replica marked DOWN (no answer: hung) has its calls ended.
        self.assertIn("on-marked-down shutdown-sessions", server)
        self.assertRegex(cfg, r"\n\s*option tcp-check\n\s*tcp-check connect\n")


H2_DATA, H2_HEADERS, H2_SETTINGS = 0, 1, 4
END_STREAM, END_HEADERS = 0x1, 0x4


def h2_frames(data):
    """(type, flags, stream id, payload) of each HTTP/2 frame (RFC 9113 4.1)."""
    frames = []
    while data:
        n = int.from_bytes(data[:3], "big")
        sid = int.from_bytes(data[5:9], "big") & 0x7FFFFFFF
        frames.append((data[3], data[4], sid, data[9:9 + n]))
        data = data[9 + n:]
    return frames


HPACK_STATIC = {1: ":authority", 2: (":method", "GET"), 3: (":method", "POST"),
                4: ":path", 6: (":scheme", "http"), 7: (":scheme", "https"),
                31: "content-type"}


def hpack_fields(block):
    """The fields of an HPACK block (RFC 7541) made of indexed static fields
    and literals without indexing, without Huffman coding (what the check
    sends); anything else fails."""
    pos = 0

    def integer(prefix_bits):  # RFC 7541 5.1
        nonlocal pos
        mask = (1 << prefix_bits) - 1
        value = block[pos] & mask
        pos += 1
        if value < mask:
            return value
        shift = 0
        while True:  # continuation bytes, 7 bits each, low first
            byte = block[pos]
            pos += 1
            value += (byte & 0x7F) << shift
            shift += 7
            if not byte & 0x80:
                return value

    def string():
        nonlocal pos
        assert not block[pos] & 0x80, "Huffman-coded string"
        n = integer(7)
        text, pos = block[pos:pos + n].decode(), pos + n
        return text

    fields = []
    while pos < len(block):
        if block[pos] & 0x80:  # indexed field
            fields.append(HPACK_STATIC[integer(7)])
        elif block[pos] & 0xF0 == 0:  # literal without indexing
            index = integer(4)
            name = HPACK_STATIC[index] if index else string()
            fields.append((name, string()))
        else:
            raise AssertionError(f"unexpected HPACK representation {block[pos]:#x}")
    return fields


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]])
