"""A plain gRPC client of the stack, written from the proto directory alone.

Stubs are generated from proto/meshgauge/v1/meshgauge.proto into a temporary
directory (protoc, grpc_python_plugin), and the retry policy is the service
config beside it; no meshgauge package is used. Its only fault
handling is gRPC's retry policy for UNAVAILABLE. It keeps one session per
--sessions, named by itself (so every call carries x-meshgauge-session),
and loops UpdatePositions -> ComputeSdf until SIGTERM, then prints its
counts as JSON: calls, not_found (a session lost or misrouted), other
errors by code.

  /usr/bin/python3 deploy/plain_client.py --target 127.0.0.1:50051 \
      --ca deploy/secrets/ca.crt --token-file deploy/secrets/token
"""

import argparse
import collections
import json
import math
import os
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time
import uuid
import zlib

import grpc

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# The retry policy every client uses, from the proto's directory; this
# client also waits for the channel to be ready.
with open(os.path.join(ROOT, "proto", "meshgauge", "v1",
                       "service_config.json")) as _f:
    _CONFIG = json.load(_f)
for _method in _CONFIG["methodConfig"]:
    _method["waitForReady"] = True
RETRY = json.dumps(_CONFIG)


def stubs():
    out = tempfile.mkdtemp(prefix="meshgauge-plain-")
    subprocess.run(["protoc", f"--proto_path={ROOT}/proto",
                    f"--python_out={out}", f"--grpc_out={out}",
                    "--plugin=protoc-gen-grpc=" + shutil.which("grpc_python_plugin"),
                    "meshgauge/v1/meshgauge.proto"], check=True)
    sys.path.insert(0, out)
    from meshgauge.v1 import meshgauge_pb2, meshgauge_pb2_grpc
    return meshgauge_pb2, meshgauge_pb2_grpc


def open_channel(target, ca, options):
    """A channel to target: TLS trusting the CA file `ca`, else plaintext."""
    if ca:
        with open(ca, "rb") as f:
            creds = grpc.ssl_channel_credentials(root_certificates=f.read())
        return grpc.secure_channel(target, creds, options=options)
    return grpc.insecure_channel(target, options=options)


def octahedron_sphere(levels):
    """A unit sphere: an octahedron subdivided `levels` times."""
    verts = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
    faces = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4),
             (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
    for _ in range(levels):
        mid = {}

        def m(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                p = [(verts[a][k] + verts[b][k]) / 2 for k in range(3)]
                n = math.sqrt(sum(c * c for c in p))
                verts.append(tuple(c / n for c in p))
                mid[key] = len(verts) - 1
            return mid[key]
        new = []
        for a, b, c in faces:
            ab, bc, ca = m(a, b), m(b, c), m(c, a)
            new += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
        faces = new
    return verts, faces


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--target", default="127.0.0.1:50051")
    ap.add_argument("--ca", help="TLS, trusting this CA (else plaintext)")
    ap.add_argument("--token-file")
    ap.add_argument("--sessions", type=int, default=2)
    ap.add_argument("--out", required=True, help="JSON counts written here")
    args = ap.parse_args()
    pb, pb_grpc = stubs()
    channel = open_channel(args.target, args.ca, [
        ("grpc.enable_retries", 1), ("grpc.service_config", RETRY)])
    token = ""
    if args.token_file:
        with open(args.token_file) as f:
            token = f.read().strip()
    stub = pb_grpc.MeshGaugeStub(channel)
    verts, faces = octahedron_sphere(3)
    counts = collections.Counter()
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))

    def call(method, request, sid, stream=False):
        md = [("x-meshgauge-session", sid)]
        if token:
            md.append(("authorization", "Bearer " + token))
        try:
            counts["calls"] += 1
            r = method(request, metadata=md, timeout=60)
            return list(r) if stream else r
        except grpc.RpcError as e:
            key = "not_found" if e.code() == grpc.StatusCode.NOT_FOUND else e.code().name
            counts[key] += 1
            return None

    sessions = []
    for i in range(args.sessions):
        sid = f"plain-{uuid.uuid4().hex[:12]}-{i}"
        req = pb.CreateSessionRequest
        positions = [c for v in verts for c in v]
        indices = [i for f in faces for i in f]
        crc = zlib.crc32(struct.pack(f"<{len(positions)}d", *positions))
        crc = zlib.crc32(struct.pack(f"<{len(faces)}i", *[3] * len(faces)), crc)
        crc = zlib.crc32(struct.pack(f"<{len(indices)}i", *indices), crc)
        parts = [
            req(header=req.Header(session_id=sid, dimension=3,
                                  num_vertices=len(verts), num_faces=len(faces))),
            req(chunk=req.Chunk(positions=positions, face_sizes=[3] * len(faces),
                                face_indices=indices)),
            req(footer=req.Footer(num_vertices=len(verts), num_faces=len(faces),
                                  crc32=crc))]
        if call(stub.CreateSession, iter(parts), sid) is not None:
            sessions.append([sid, 0])
    step = 0
    while not stop and sessions:
        step += 1
        for s in sessions:
            a = 0.01 * math.sin(0.3 * step)
            pos = [c * (1 + a) for v in verts for c in v]
            r = call(stub.UpdatePositions, pb.UpdatePositionsRequest(
                session_id=s[0], expected_generation=s[1], positions=pos), s[0])
            if r is not None:
                s[1] = r.generation
            elif counts["ABORTED"]:
                info = call(stub.GetSession, pb.GetSessionRequest(session_id=s[0]), s[0])
                if info is not None:
                    s[1] = info.session.generation
            call(stub.ComputeSdf, pb.ComputeSdfRequest(session_id=s[0]), s[0], True)
        time.sleep(0.05)
    for s in sessions:
        call(stub.DeleteSession, pb.DeleteSessionRequest(session_id=s[0]), s[0])
    counts["sessions"] = len(sessions)
    with open(args.out, "w") as f:
        json.dump(dict(counts), f)
    print(json.dumps(dict(counts)))


if __name__ == "__main__":
    main()
