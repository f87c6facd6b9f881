"""The fan-out of one call over sample ranges (docs/server.md, Fan-out): the
ranges the C++ client splits into (client/remote/fan_out.h, SplitSamples),
the metadata of a range call, the exact merge of a ranged ComputeVjp's
partial sums, and the merge of ranged ComputeSdf streams into the whole
call's result (its summary recomputed from every value: _summary)."""

import dataclasses
import math
import numbers
from typing import Any, Iterable, Iterator, List, Optional, Sequence, Tuple

import grpc
import numpy as np

from meshgauge_client import _summary
from meshgauge_client._stubs import pb
from meshgauge_client.errors import AbortedError, DataLossError
from meshgauge_client.results import FloatArray, SdfSummary

RANGE_KEY = "x-meshgauge-range"
# The range's index 0..K-1 among the K ranges of its call (decimal): a
# balancer can route part I of every fanned-out call to replica I mod R.
PART_KEY = "x-meshgauge-part"


def check_fan_out(fan_out: Any) -> int:
    """fan_out as an int >= 1 (ValueError otherwise)."""
    if (isinstance(fan_out, bool) or not isinstance(fan_out, numbers.Integral)
            or fan_out < 1):
        raise ValueError(f"fan_out must be an int >= 1, got {fan_out!r}")
    return int(fan_out)


def split_samples(samples: int, k: int) -> List[Tuple[int, int]]:
    """k contiguous ranges of nearly equal size covering [0, samples)."""
    n = min(max(k, 1), samples)
    return [(samples * i // n, samples * (i + 1) // n) for i in range(n)]


def range_metadata(part: int, begin: int, end: int) -> List[Tuple[str, str]]:
    """The balancer's keys of range `part` (0..K-1) of a fanned-out call,
    [begin, end) (sent with the session's)."""
    return [(RANGE_KEY, f"{begin}-{end}"), (PART_KEY, str(part))]


def _moved(generations: Sequence[int], what: str = "ranges") -> AbortedError:
    return AbortedError(
        grpc.StatusCode.ABORTED,
        f"the session moved during a fanned-out call: {what} computed at "
        f"generations {sorted(set(generations))}; call again")


def merge_vjp(replies: Sequence[Any]) -> Tuple[FloatArray, int]:
    """The whole gradient (flat, dimension values per vertex) and its
    generation from ranged ComputeVjpResponses: every value is the exact
    sum of each range's rounded value and tail, rounded once (math.fsum is
    correctly rounded, as the server's ExactSum), so it is the whole call's
    bit for bit."""
    generation = same_generation(replies)
    return exact_sums(replies, "ranges"), generation


def same_generation(replies: Sequence[Any]) -> int:
    """The generation of every range's reply (AbortedError when they
    differ: the session moved between them)."""
    generations = [r.generation for r in replies]
    if len(set(generations)) != 1:
        raise _moved(generations)
    return int(generations[0])


def exact_sums(replies: Sequence[Any], older: str) -> FloatArray:
    """Per value i, math.fsum of every reply's rounded gradient[i] and its
    tails (tail_counts[i] of them): the exact sum of the ranges' exact
    partial sums, rounded once. The replies are ranged ComputeVjpResponses
    or ComputePenaltyResponses (the same three fields); DataLossError when
    one lacks a value's partial sum (`older`: what a server that sends none
    is older than)."""
    size = len(replies[0].gradient)
    terms: List[List[float]] = [[] for _ in range(size)]
    for r in replies:
        if len(r.gradient) != size or len(r.tail_counts) != size:
            raise DataLossError(
                grpc.StatusCode.DATA_LOSS,
                "a range's reply has no exact partial sums of every vertex "
                f"(is the server older than {older}?)")
        tails = list(r.tails)
        at = 0
        for i, (head, count) in enumerate(zip(r.gradient, r.tail_counts)):
            terms[i].append(head)
            terms[i].extend(tails[at:at + count])
            at += count
        if at != len(tails):
            raise DataLossError(grpc.StatusCode.DATA_LOSS,
                                "the reply's tails do not match its counts")
    return np.array([math.fsum(t) for t in terms], dtype=np.float64)


def merge_penalty(replies: Sequence[Any], with_gradient: bool,
                  gradient_size: int) -> Any:
    """The whole call's ComputePenaltyResponse from its ranges' (in order:
    replies[0] is the range that begins at sample 0), as the C++ client's
    MergePenaltyReplies: the value, missing counts, sdf_min, skipped faces
    and thin regions of the range at 0 (every range computes them from
    every value), world_frame_vertices summed, reused_hits when every range
    reused its pass, the slowest range's time. With the gradient
    (`gradient_size` values: dimension per vertex), each value is the
    exact sum of every range's partial sums rounded once (exact_sums, as
    merge_vjp), plus the range at 0's measure_gradient with one float64
    addition: the server's PenaltyGradient, so the whole call's bits.
    AbortedError when the ranges are of different generations;
    DataLossError when a range lacks its partial sums or the range at 0
    its measure part (a server older than penalty ranges)."""
    same_generation(replies)
    out = pb.ComputePenaltyResponse()
    out.CopyFrom(replies[0])
    out.world_frame_vertices = sum(r.world_frame_vertices for r in replies)
    out.reused_hits = all(r.reused_hits for r in replies)
    out.seconds = max(r.seconds for r in replies)
    del out.gradient[:]
    del out.tail_counts[:]
    del out.tails[:]
    del out.measure_gradient[:]
    if not with_gradient:
        return out
    first = replies[0]
    if (gradient_size == 0 or len(first.gradient) != gradient_size
            or len(first.measure_gradient) != gradient_size):
        raise DataLossError(
            grpc.StatusCode.DATA_LOSS,
            f"the first range's penalty reply holds {len(first.gradient)} "
            f"partial sums and {len(first.measure_gradient)} measure values "
            f"for {gradient_size} gradient values (is the server older than "
            "penalty ranges?)")
    measure = np.asarray(first.measure_gradient, dtype=np.float64)
    out.gradient.extend(exact_sums(replies, "penalty ranges") + measure)
    return out


@dataclasses.dataclass
class SdfReply:
    """A ComputeSdf stream read: per-sample arrays from `first` on (the
    whole-mesh index of the first sample), the Jacobian's rows (CSR:
    offsets, vertex columns, `dimension` derivatives per entry) and the
    summary message."""

    first: int = 0
    values: List[float] = dataclasses.field(default_factory=list)
    status: List[int] = dataclasses.field(default_factory=list)
    hits: List[int] = dataclasses.field(default_factory=list)
    kept: List[int] = dataclasses.field(default_factory=list)
    normalized: List[float] = dataclasses.field(default_factory=list)
    opposite: List[float] = dataclasses.field(default_factory=list)
    rows: List[int] = dataclasses.field(default_factory=lambda: [0])
    cols: List[int] = dataclasses.field(default_factory=list)
    data: List[float] = dataclasses.field(default_factory=list)
    summary: Any = None

    def extend(self, values: Iterable[float], status: Iterable[int],
               hits: Iterable[int], kept: Iterable[int],
               opposite: Iterable[float], jacobian: bool,
               row_offsets: Sequence[int], cols: Iterable[int],
               data: Iterable[float]) -> None:
        """Appends samples and, with `jacobian`, their rows (row_offsets
        counted from 0, as a chunk's or another reply's)."""
        self.values.extend(values)
        self.status.extend(status)
        self.hits.extend(hits)
        self.kept.extend(kept)
        self.opposite.extend(opposite)
        if jacobian:
            base = self.rows[-1]
            self.rows.extend(base + o for o in list(row_offsets)[1:])
            self.cols.extend(cols)
            self.data.extend(data)


def sample_values(parts: Sequence["SdfReply"]) -> Tuple[List[float], int]:
    """Every sample's value and the generation from the checked replies
    of a fanned-out ComputeSdf's ranges (in order, tiling the samples):
    what a fanned-out penalty sends with each of its ranges."""
    generation = _sdf_generation(parts)
    values: List[float] = []
    for p in parts:
        _check_tiles(p, len(values))
        values.extend(p.values)
    return values, generation


def _sdf_generation(parts: Sequence["SdfReply"]) -> int:
    """The generation of every range's summary (AbortedError when they
    differ)."""
    generations = [p.summary.generation for p in parts]
    if len(set(generations)) != 1:
        raise _moved(generations)
    return int(generations[0])


def _check_tiles(part: "SdfReply", follows: int) -> None:
    """DataLossError unless the range's first sample is `follows`."""
    if part.first != follows:
        raise DataLossError(
            grpc.StatusCode.DATA_LOSS,
            f"the ranges do not tile the samples: [{part.first}, "
            f"{part.first + len(part.values)}) follows sample {follows}")


def read_sdf(messages: Iterator[Any], jacobian: bool,
             first: int = 0) -> SdfReply:
    """The chunks and summary of a ComputeSdf stream; chunks must continue
    one another from sample `first` (DataLossError otherwise)."""
    r = SdfReply(first)
    for msg in messages:
        if msg.HasField("summary"):
            r.summary = msg.summary
            continue
        if not msg.HasField("chunk"):
            continue  # progress.
        c = msg.chunk
        n = c.vertex_end - c.vertex_begin
        if (c.vertex_begin != first + len(r.values) or len(c.values) != n
                or len(c.status) != n or len(c.hits) != n
                or len(c.kept) != n or len(c.normalized) != n):
            raise DataLossError(
                grpc.StatusCode.DATA_LOSS,
                f"chunk [{c.vertex_begin}, {c.vertex_end}) does not continue "
                f"{len(r.values)} samples from sample {first}")
        r.extend(c.values, c.status, c.hits, c.kept, c.opposite, jacobian,
                 c.row_offsets, c.columns, c.derivatives)
        r.normalized.extend(c.normalized)
    return r


def check_sdf(r: SdfReply, faces: bool, opposite_points: bool,
              asked: Optional[Tuple[int, int]] = None) -> None:
    """DataLossError unless the reply is what was asked for: a summary
    counting the chunks' samples, the sample set, the opposite points, and
    a range call's range."""
    s = r.summary
    n = len(r.values)
    if s is None:
        raise DataLossError(grpc.StatusCode.DATA_LOSS,
                            "ComputeSdf stream ended without its summary")
    counted = s.ok + s.no_hit + s.no_faces + s.degenerate_normal
    if counted != n or s.ok != sum(
            1 for x in r.status if x == pb.VERTEX_STATUS_OK):
        raise DataLossError(
            grpc.StatusCode.DATA_LOSS,
            f"the summary counts {counted} samples ({s.ok} with a value), "
            f"the chunks carried {n}")
    if faces != (s.samples == pb.SAMPLE_SET_FACES):
        raise DataLossError(
            grpc.StatusCode.DATA_LOSS,
            ("face" if faces else "vertex") + " samples were asked for, the "
            "reply holds others (is the server older than "
            "SdfParameters.samples?)")
    if len(r.opposite) != (3 * n if opposite_points else 0):
        raise DataLossError(
            grpc.StatusCode.DATA_LOSS,
            f"the server sent {len(r.opposite)} opposite coordinates for {n} "
            "samples" + (" (is the server older than "
                         "SdfParameters.opposite_points?)"
                         if opposite_points and not r.opposite else ""))
    if asked is not None:
        held = ((s.range.begin, s.range.end) if s.HasField("range")
                else None)
        if held != asked or n != asked[1] - asked[0]:
            raise DataLossError(
                grpc.StatusCode.DATA_LOSS,
                f"samples [{asked[0]}, {asked[1]}) were asked for, the reply "
                f"holds {n} samples of range {held} (is the server older "
                "than ComputeSdfRequest.range?)")


def merge_sdf(parts: Sequence[SdfReply], mesh_reply: Any, faces: bool,
              jacobian: bool) -> Tuple[SdfReply, SdfSummary]:
    """The whole call's reply from its ranges' (in order, tiling the
    samples) and the session's mesh at their generation (GetMesh): arrays
    and Jacobian rows concatenated, `normalized`, the statistics, missing
    counts, integral and warnings computed from every value as the server
    computes them (_summary), rays and frame fallbacks summed, the slowest
    range's time. AbortedError when the ranges (or the mesh) are of
    different generations."""
    generation = _sdf_generation(parts)
    if mesh_reply.generation != generation:
        raise _moved([generation, mesh_reply.generation],
                     "the ranges and the mesh")
    try:
        mesh = _summary.WholeMesh(mesh_reply)
    except ValueError as e:
        raise DataLossError(grpc.StatusCode.DATA_LOSS,
                            f"GetMesh: {e}") from None
    out = SdfReply()
    for p in parts:
        _check_tiles(p, len(out.values))
        out.extend(p.values, p.status, p.hits, p.kept, p.opposite, jacobian,
                   p.rows, p.cols, p.data)
    samples = mesh.num_faces if faces else mesh.num_vertices
    if len(out.values) != samples:
        raise DataLossError(
            grpc.StatusCode.DATA_LOSS,
            f"the ranges cover {len(out.values)} of the mesh's {samples} "
            f"{'face' if faces else 'vertex'} samples")
    values = np.asarray(out.values, dtype=np.float64)
    status = np.asarray(out.status, dtype=np.int64)
    norm = _summary.normalized(values)
    out.normalized = norm.tolist()
    lo, hi, mean, median = _summary.value_stats(values)
    missing_vertices, missing_faces, fraction = _summary.count_missing(
        mesh, values, faces)
    first = parts[0].summary
    summary = SdfSummary(
        generation=first.generation,
        ok=int(np.count_nonzero(status == pb.VERTEX_STATUS_OK)),
        no_hit=int(np.count_nonzero(status == pb.VERTEX_STATUS_NO_HIT)),
        no_faces=int(np.count_nonzero(status == pb.VERTEX_STATUS_NO_FACES)),
        degenerate_normal=int(np.count_nonzero(
            status == pb.VERTEX_STATUS_DEGENERATE_NORMAL)),
        sdf_min=lo, sdf_median=median, sdf_max=hi, sdf_mean=mean,
        integral=_summary.integral(mesh, values, faces),
        rays=sum(p.summary.rays for p in parts),
        seconds=max(p.summary.seconds for p in parts),
        reused_hits=all(p.summary.reused_hits for p in parts),
        world_frame_vertices=sum(p.summary.world_frame_vertices
                                 for p in parts),
        missing_vertices=missing_vertices, missing_faces=missing_faces,
        missing_fraction=fraction,
        warnings=tuple(_summary.missing_warnings(
            mesh, values, status, faces, fraction, missing_faces)),
        samples="faces" if faces else "vertices")
    return out, summary
