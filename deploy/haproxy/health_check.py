#!/usr/bin/python3
"""Prints the balancer's gRPC health check as HAProxy tcp-check lines.

HAProxy 2.6's http-check cannot send a body with NUL bytes (a gRPC message
has some), so the check is raw cleartext HTTP/2 written as hex: the client
preface, an empty SETTINGS frame, the HEADERS of stream 1 (HPACK: indexed
static fields and literals without indexing, no Huffman coding) for
POST /grpc.health.v1.Health/Check, and a DATA frame that ends the stream with
an empty HealthCheckRequest. Healthy is a HealthCheckResponse of status
SERVING. haproxy.cfg holds this script's output between its markers;
tests/deploy_config_test.py checks that it does and decodes the frames.

Usage: deploy/haproxy/health_check.py > lines (paste between the markers).
"""

PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n"
DATA, HEADERS, SETTINGS = 0, 1, 4
END_STREAM, END_HEADERS = 0x1, 0x4
# RFC 7541 Appendix A: the static entries the request uses.
INDEXED = {(":method", "POST"): 3, (":scheme", "http"): 6}
NAME_INDEX = {":authority": 1, ":path": 4, "content-type": 31}


def frame(kind, flags, stream, payload):
    """An HTTP/2 frame (RFC 9113 4.1)."""
    return (len(payload).to_bytes(3, "big") + bytes([kind, flags]) +
            stream.to_bytes(4, "big") + payload)


def integer(value, prefix_bits, first=0):
    """An HPACK integer (RFC 7541 5.1) with `first`'s high bits."""
    mask = (1 << prefix_bits) - 1
    if value < mask:
        return bytes([first | value])
    out = [first | mask]
    value -= mask
    while value >= 0x80:
        out.append(value & 0x7F | 0x80)
        value >>= 7
    return bytes(out + [value])


def string(text):
    raw = text.encode()
    return integer(len(raw), 7) + raw


def field(name, value):
    if (name, value) in INDEXED:
        return integer(INDEXED[(name, value)], 7, 0x80)
    if name in NAME_INDEX:  # literal without indexing, indexed name.
        return integer(NAME_INDEX[name], 4) + string(value)
    return b"\0" + string(name) + string(value)


def grpc_message(payload):
    """A gRPC length-prefixed message, not compressed."""
    return b"\0" + len(payload).to_bytes(4, "big") + payload


def lines():
    headers = b"".join(field(n, v) for n, v in [
        (":method", "POST"), (":scheme", "http"),
        (":path", "/grpc.health.v1.Health/Check"), (":authority", "meshgauge"),
        ("content-type", "application/grpc"), ("te", "trailers")])
    sends = [
        (PREFACE, "HTTP/2 preface"),
        (frame(SETTINGS, 0, 0, b""), "SETTINGS"),
        (frame(HEADERS, END_HEADERS, 1, headers), "HEADERS"),
        (frame(DATA, END_STREAM, 1, grpc_message(b"")),
         "DATA: HealthCheckRequest"),
    ]
    # HealthCheckResponse: status (field 1, varint) = SERVING (1).
    serving = grpc_message(bytes([1 << 3 | 0, 1]))
    out = [f"  tcp-check send-binary {data.hex()} comment \"{what}\""
           for data, what in sends]
    # The first expect waits for the reply up to the status value (HAProxy
    # matches rbinary on upper-case hex, from a byte boundary): no reply
    # (a hung replica: timeout) or no connection marks the replica DOWN,
    # which ends its calls (on-marked-down). The second decides at once:
    # NOT_SERVING (a draining replica) is a conditional pass, L7OKC, which
    # takes the replica out of the rotation (NOLB) while its calls finish.
    out.append("  tcp-check expect rbinary ^([0-9A-F]{2})*" +
               serving[:-1].hex().upper() + " comment \"no HealthCheckResponse\"")
    out.append("  tcp-check expect min-recv 0 error-status L7OKC binary " +
               serving.hex() + " comment \"not SERVING\"")
    return out


if __name__ == "__main__":
    print("\n".join(lines()))
