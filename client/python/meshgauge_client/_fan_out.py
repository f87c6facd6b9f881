"""The fan-out of one call over sample ranges (docs/server.md, Fan-out): the
ranges the C++ client splits into (client/remote/fan_out.h, SplitSamples),
and the exact merge of a ranged ComputeVjp's partial sums."""

import math
from typing import Any, List, Sequence, Tuple

import grpc
import numpy as np

from meshgauge_client.errors import AbortedError, DataLossError
from meshgauge_client.results import FloatArray

RANGE_KEY = "x-meshgauge-range"


def split_samples(samples: int, k: int) -> List[Tuple[int, int]]:
    """k contiguous ranges of nearly equal size covering [0, samples)."""
    n = min(max(k, 1), samples)
    return [(samples * i // n, samples * (i + 1) // n) for i in range(n)]


def range_metadata(begin: int, end: int) -> Tuple[str, str]:
    """The balancer's key of a range call (with the session's)."""
    return (RANGE_KEY, f"{begin}-{end}")


def merge_vjp(replies: Sequence[Any]) -> Tuple[FloatArray, int]:
    """The whole gradient (flat, dimension values per vertex) and its
    generation from ranged ComputeVjpResponses: every value is the exact
    sum of each range's rounded value and tail, rounded once (math.fsum is
    correctly rounded, as the server's ExactSum), so it is the whole call's
    bit for bit."""
    generations = {r.generation for r in replies}
    if len(generations) != 1:
        raise AbortedError(
            grpc.StatusCode.ABORTED,
            "the session moved during a fanned-out call: ranges computed at "
            f"generations {sorted(generations)}; call again")
    size = len(replies[0].gradient)
    terms: List[List[float]] = [[] for _ in range(size)]
    for r in replies:
        if len(r.gradient) != size or len(r.tail_counts) != size:
            raise DataLossError(
                grpc.StatusCode.DATA_LOSS,
                "a range's reply has no exact partial sums of every vertex "
                "(is the server older than ranges?)")
        tails = list(r.tails)
        at = 0
        for i, (head, count) in enumerate(zip(r.gradient, r.tail_counts)):
            terms[i].append(head)
            terms[i].extend(tails[at:at + count])
            at += count
        if at != len(tails):
            raise DataLossError(grpc.StatusCode.DATA_LOSS,
                                "the reply's tails do not match its counts")
    return (np.array([math.fsum(t) for t in terms], dtype=np.float64),
            replies[0].generation)
