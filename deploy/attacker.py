"""The chaos test's attacker (deploy/chaos-test.sh, phase attack), written
from the proto alone like plain_client.py. While the measured clients run,
it plays the attacks the hardening issue named, against their sessions:

  refused   UpdatePositions of every position x 1e14 (beyond the ray
            tracer's range) on each measured session, at its current
            generation: each must be refused (INVALID_ARGUMENT, or ABORTED
            when a measured client moved the session first) and change
            nothing; the measured clients' bit-for-bit checks see any
            committed refusal.
  stalled   ComputeSdf streams on the measured sessions that are never read
            for --stall-seconds: they must not block the measured clients'
            updates (their latency bound is the phase's).
  anonymous UpdatePositions of --anonymous-mib MiB without a token, two at
            once: refused from the metadata before the message is read, so
            the client is still sending when the refusal comes: directly
            it sees UNAUTHENTICATED; behind HAProxy 2.6, which answers a
            server's early reply to a client still sending by resetting the
            client's stream, CANCELLED. Never OK, never anything else.

Prints one JSON line of counts; exits 1 when a refused update was accepted,
no update was refused INVALID_ARGUMENT, or an anonymous call was not
refused (UNAUTHENTICATED or CANCELLED).

  /usr/bin/python3 deploy/attacker.py --target 127.0.0.1:50251 \
      --ca CA --token-file TOKEN --sessions chaos-attack-0,chaos-attack-1
"""

import argparse
import collections
import json
import sys
import threading
import time

import grpc

from plain_client import open_channel, stubs


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--target", required=True)
    ap.add_argument("--ca", help="TLS, trusting this CA (else plaintext)")
    ap.add_argument("--token-file", required=True)
    ap.add_argument("--sessions", required=True, help="ids, comma-separated")
    ap.add_argument("--stall-seconds", type=float, default=15)
    ap.add_argument("--anonymous-mib", type=int, default=100)
    args = ap.parse_args()
    pb, pb_grpc = stubs()
    channel = open_channel(args.target, args.ca, [
        ("grpc.max_send_message_length", -1),
        ("grpc.max_receive_message_length", -1)])
    with open(args.token_file) as f:
        token = f.read().strip()
    stub = pb_grpc.MeshGaugeStub(channel)
    sessions = args.sessions.split(",")
    counts = collections.Counter()
    lock = threading.Lock()

    def count(key):
        with lock:
            counts[key] += 1

    def md(sid):
        return [("x-meshgauge-session", sid),
                ("authorization", "Bearer " + token)]

    def refused(sid):
        """Refused updates until one is INVALID_ARGUMENT (at most 20)."""
        for _ in range(20):
            try:
                s = stub.GetSession(pb.GetSessionRequest(session_id=sid),
                                    metadata=md(sid), timeout=30).session
                n = s.num_vertices * 3
                stub.UpdatePositions(pb.UpdatePositionsRequest(
                    session_id=sid, expected_generation=s.generation,
                    positions=[1e14 * (1 + (i % 7)) for i in range(n)]),
                    metadata=md(sid), timeout=30)
                count("refused_update_accepted")
                return
            except grpc.RpcError as e:
                count("refused_update_" + e.code().name)
                if e.code() == grpc.StatusCode.INVALID_ARGUMENT:
                    return
            time.sleep(0.2)

    def stalled(sid):
        """A ComputeSdf stream nobody reads, then cancelled."""
        call = stub.ComputeSdf(pb.ComputeSdfRequest(session_id=sid),
                               metadata=md(sid), timeout=120)
        time.sleep(args.stall_seconds)
        call.cancel()
        count("stalled_streams")

    def anonymous():
        """The request's bytes are built by hand (a 100 MiB repeated field
        would take seconds to fill in Python): session_id, then packed
        positions."""
        def field(number, payload):
            n, size = len(payload), b""
            while True:
                low, n = n & 0x7F, n >> 7
                if not n:
                    size += bytes([low])
                    break
                size += bytes([low | 0x80])
            return bytes([(number << 3) | 2]) + size + payload
        request = (field(1, sessions[0].encode()) +
                   field(4, bytes(args.anonymous_mib << 20)))
        update = channel.unary_unary("/meshgauge.v1.MeshGauge/UpdatePositions")
        try:
            update(request, metadata=[("x-meshgauge-session", sessions[0])],
                   timeout=120)
            count("anonymous_OK")
        except grpc.RpcError as e:
            count("anonymous_" + e.code().name)

    threads = [threading.Thread(target=stalled, args=(sid,))
               for sid in sessions[:3]]
    threads += [threading.Thread(target=anonymous) for _ in range(2)]
    for t in threads:
        t.start()
    for sid in sessions:
        refused(sid)
    for t in threads:
        t.join()
    print(json.dumps(dict(counts), sort_keys=True))
    bad = (counts["refused_update_accepted"] or
           not counts["refused_update_INVALID_ARGUMENT"] or
           counts["anonymous_UNAUTHENTICATED"] +
           counts["anonymous_CANCELLED"] != 2)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
