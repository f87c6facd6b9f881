"""MeshGaugeClient: one meshgauge server, numpy in, numpy out.

Arrays: vertices (N, d) floats (d = 2 or 3); faces an (M, k) int array or a
list of index sequences (2 per segment in 2D; 3 to 256 corners in 3D,
polygons triangulated by the server). Mesh files are read by the server. Every call
of a session sends ``x-meshgauge-session`` (the balancer's routing key) and,
with a token, ``authorization: Bearer <token>``. The channel retries
UNAVAILABLE with exponential backoff; a call keeps retrying UNAVAILABLE for
``retry_seconds`` (``connect_seconds`` while the server has never answered),
then raises UnavailableError naming the target. Welded uploads
(``weld=``) keep the caller's vertex indexing in every result (_weld).
"""

import json
import os
import stat
import warnings
import time
import uuid
import zlib
from typing import (TYPE_CHECKING, Any, Callable, Iterator, List, Optional,
                    Sequence, Tuple, TypeVar)

import grpc
import numpy as np
import scipy.sparse

from meshgauge_client import _weld, _wire
from meshgauge_client._stubs import pb
from meshgauge_client._stubs import pb_grpc
from meshgauge_client.errors import (DataLossError, MeshGaugeError,
                                     MissingValuesWarning, UnavailableError,
                                     from_rpc_error)
from meshgauge_client.options import SdfOptions
from meshgauge_client.results import (Calibration, FloatArray,
                                      GradCheckReport, MeshData,
                                      PenaltyResult, SdfResult, ServerInfo,
                                      SessionInfo)

if TYPE_CHECKING:
    from meshgauge_client.session import Session

SESSION_KEY = "x-meshgauge-session"
T = TypeVar("T")

# Transparent retries of UNAVAILABLE (a restarting or draining server): the
# service config the C++ client uses too (proto/meshgauge/v1/
# service_config.json, shipped beside the stubs). Calls do not wait for a
# ready channel (wait_for_ready=False: gRPC would hold them for the whole
# deadline); MeshGaugeClient._retrying retries UNAVAILABLE within a bounded
# budget instead.
with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "_proto",
                       "service_config.json")) as _f:
    _SERVICE_CONFIG = json.dumps(json.load(_f))

# How long a call retries UNAVAILABLE by default: once the server has
# answered (a restart), and while it never has (a wrong address, a server
# not running). docs/python.md promises at most 30 s.
RETRY_SECONDS = 30.0
CONNECT_SECONDS = 10.0
# The channel tries to reconnect at least this often while the server is
# down (gRPC's default backoff grows to 120 s, past any retry budget).
MAX_RECONNECT_BACKOFF_MS = 2000


def mesh_crc32(vertices: Any, faces: Any, regions: Optional[Any] = None) -> int:
    """CRC-32 of a mesh in the upload footer's canonical order."""
    v = np.ascontiguousarray(vertices, dtype="<f8")
    face_list = [np.asarray(f, dtype=np.int64).ravel() for f in faces]
    sizes = np.array([len(f) for f in face_list], dtype="<i4")
    indices = (np.concatenate(face_list).astype("<i4") if face_list
               else np.zeros(0, "<i4"))
    crc = zlib.crc32(v.tobytes())
    crc = zlib.crc32(sizes.tobytes(), crc)
    crc = zlib.crc32(indices.tobytes(), crc)
    if regions is not None:
        crc = zlib.crc32(np.asarray(regions, dtype="<i4").tobytes(), crc)
    return crc & 0xFFFFFFFF


def _format_of(path: str) -> str:
    """The mesh format of a file name ("obj", ...); ValueError otherwise."""
    fmt = os.path.splitext(path)[1].lower().lstrip(".")
    if fmt not in ("obj", "off", "ply", "stl"):
        raise ValueError(f"{path}: the extension must be .obj, .off, .ply or "
                         ".stl")
    return fmt


def _last_bytes(text: str, n: int) -> str:
    """The end of `text` that fits in n bytes of UTF-8."""
    return text.encode("utf-8", "replace")[-n:].decode("utf-8", "ignore")


def _read(path: str) -> bytes:
    """The file's bytes (OSError as open() raises it)."""
    with open(path, "rb") as f:
        return f.read()


class MeshGaugeClient:
    """Client of one meshgauge server (``target`` = "host:port").

    token: sent as ``authorization: Bearer <token>`` (default: the
    MESHGAUGE_TOKEN environment variable). tls_ca_file: TLS, trusting that
    PEM CA; tls_cert_file and tls_key_file add a client certificate (mutual
    TLS). deadline: seconds per call. retry_seconds: how long a call keeps
    retrying UNAVAILABLE (a restarting server) before it fails;
    connect_seconds: the same while the server has never answered this
    client (a wrong address, no server), at most retry_seconds. The failure
    is an UnavailableError naming the target.
    """

    def __init__(self, target: str, token: Optional[str] = None, *,
                 deadline: float = 600.0, max_message_bytes: int = 256 << 20,
                 chunk: int = 65536, tls_ca_file: Optional[str] = None,
                 tls_cert_file: Optional[str] = None,
                 tls_key_file: Optional[str] = None,
                 retry_seconds: float = RETRY_SECONDS,
                 connect_seconds: float = CONNECT_SECONDS) -> None:
        if not isinstance(target, str) or not target:
            raise ValueError("target must be 'host:port'")
        retry_seconds = _wire._number("retry_seconds", retry_seconds, 0,
                                      np.inf)
        connect_seconds = _wire._number("connect_seconds", connect_seconds,
                                        0, np.inf)
        if (tls_cert_file or tls_key_file) and not tls_ca_file:
            raise ValueError("tls_cert_file/tls_key_file need tls_ca_file")
        options = [("grpc.max_send_message_length", max_message_bytes),
                   ("grpc.max_receive_message_length", max_message_bytes),
                   ("grpc.enable_retries", 1),
                   ("grpc.service_config", _SERVICE_CONFIG),
                   ("grpc.max_reconnect_backoff_ms", MAX_RECONNECT_BACKOFF_MS)]
        if tls_ca_file:
            creds = grpc.ssl_channel_credentials(
                root_certificates=_read(tls_ca_file),
                private_key=_read(tls_key_file) if tls_key_file else None,
                certificate_chain=_read(tls_cert_file) if tls_cert_file else None)
            self._channel = grpc.secure_channel(target, creds, options=options)
        else:
            self._channel = grpc.insecure_channel(target, options=options)
        if token is None:
            token = os.environ.get("MESHGAUGE_TOKEN") or None
        self._auth = [("authorization", "Bearer " + token)] if token else []
        self._stub = pb_grpc.MeshGaugeStub(self._channel)
        self._deadline = deadline
        self._chunk = chunk
        self._target = target
        self._retry_seconds = retry_seconds
        self._connect_seconds = min(connect_seconds, retry_seconds)
        self._answered = False  # has the server ever answered a call?
        # Per session: its dimension and vertex count (fixed at upload).
        self._shapes: "dict[str, Tuple[int, int]]" = {}
        # Per welded session: its map between uploaded and session vertices.
        self._welds: "dict[str, _weld.WeldMap]" = {}
        self._server_info: Optional[ServerInfo] = None
        self._asked_server_info = False

    def close(self) -> None:
        self._channel.close()

    def __enter__(self) -> "MeshGaugeClient":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # Plumbing ---------------------------------------------------------------

    def _metadata(self, session_id: str = "") -> List[Tuple[str, str]]:
        return ([(SESSION_KEY, session_id)] if session_id else []) + self._auth

    @property
    def target(self) -> str:
        return self._target

    def _retrying(self, call: Callable[[], T]) -> T:
        """Runs call(), retrying UNAVAILABLE with backoff for retry_seconds
        (connect_seconds while the server never answered; the channel's own
        retries cover short blips, this covers a restart), then raises
        UnavailableError naming the target."""
        start = time.monotonic()
        budget = (self._retry_seconds if self._answered
                  else self._connect_seconds)
        delay = 0.05
        attempts = 0
        while True:
            attempts += 1
            try:
                result = call()
                self._answered = True
                return result
            except grpc.RpcError as e:
                if e.code() != grpc.StatusCode.UNAVAILABLE:
                    self._answered = True
                    raise from_rpc_error(e) from None
                if time.monotonic() + delay > start + budget:
                    raise self._unavailable(e, attempts, budget,
                                            time.monotonic() - start) from None
            time.sleep(delay)
            delay = min(2 * delay, 1.0)

    def _unavailable(self, error: grpc.RpcError, attempts: int,
                     budget: float, seconds: float) -> UnavailableError:
        """The error of a call that stayed UNAVAILABLE for its budget."""
        details = error.details() or ""
        refused = (" (connection refused)" if "refused" in details.lower()
                   else "")
        never = ("" if self._answered else
                 ", connect_seconds: it never answered this client")
        return UnavailableError(
            grpc.StatusCode.UNAVAILABLE,
            f"the server at {self._target} is unavailable{refused}: "
            f"{attempts} attempt{'s' if attempts > 1 else ''} in "
            f"{seconds:.1f} s (retry budget {budget:g} s{never}); last "
            f"error: {details}")

    def _call(self, method: Any, request: Any, session_id: str = "",
              read: Optional[Callable[[Any], Any]] = None) -> Any:
        """method(request) with the deadline, the session's metadata and the
        retries; read(reply) (a stream's messages) inside each attempt."""
        metadata = self._metadata(session_id)

        def invoke() -> Any:
            reply = method(request, timeout=self._deadline, metadata=metadata,
                           wait_for_ready=False)
            return read(reply) if read else reply

        return self._retrying(invoke)

    def _shape(self, session_id: str) -> Tuple[int, int]:
        if session_id not in self._shapes:
            info = self.info(session_id)
            self._shapes[session_id] = (info.dimension, info.num_vertices)
        return self._shapes[session_id]

    def _dim(self, session_id: str) -> int:
        return self._shape(session_id)[0]

    # Sessions ---------------------------------------------------------------

    def server_info(self) -> Optional[ServerInfo]:
        """The server's version and limits (asked once, then cached); None
        for a server older than GetServerInfo (0.2), which has no limits to
        check against here."""
        if not self._asked_server_info:
            try:
                r = self._call(self._stub.GetServerInfo,
                               pb.GetServerInfoRequest())
            except MeshGaugeError as e:
                if e.code != grpc.StatusCode.UNIMPLEMENTED:
                    raise
                r = None
            if r is not None:
                self._server_info = ServerInfo(
                    r.version, r.api, r.max_rays, r.max_vertices, r.max_faces,
                    r.max_message_bytes, r.max_upload_message_bytes,
                    r.max_sessions, r.memory_budget_bytes,
                    r.max_upload_file_bytes)
            self._asked_server_info = True
        return self._server_info

    def _params(self, params: "dict[str, Any]") -> Any:
        """SdfParameters from `options=SdfOptions(...)` or the keyword
        options, checked here and against the server's ray limit before any
        call."""
        p = SdfOptions.of(params.pop("options", None), params).to_wire()
        info = self.server_info()
        limit = info.max_rays if info is not None else 4096
        if p.rays > limit:
            raise ValueError(f"rays must be at most {limit} on this server "
                             f"(--max_rays), got {p.rays}")
        return p

    def upload(self, vertices: Any, faces: Any, session_id: Optional[str] = None,
               regions: Optional[Sequence[int]] = None,
               outward_regions: Sequence[int] = (), *,
               reorient: bool = False,
               drop_degenerate_faces: bool = False) -> SessionInfo:
        """Creates a session from vertices (N, d) and faces; returns its
        SessionInfo. session_id: [A-Za-z0-9._-]{1,64}; None generates a
        UUID-based one (every call then carries its routing key). regions:
        one region id per face; outward_regions: regions whose cone opens
        along +n (SPEC §1). Polygons (5 to 256 corners) are triangulated
        by the server. reorient: make each component's faces agree, then
        turn closed components outward; drop_degenerate_faces: remove
        zero-area faces (as the CLI's flags; SessionInfo.warnings says what
        changed)."""
        v = _wire.points(vertices, "vertices")
        dim = v.shape[1]
        face_list = _wire.faces_list(faces, dim)
        if regions is not None and len(regions) != len(face_list):
            raise ValueError(f"regions must have one entry per face "
                             f"({len(face_list)}), got {len(regions)}")
        header = self._header(
            session_id, outward_regions, reorient, drop_degenerate_faces,
            dimension=dim, num_vertices=len(v), num_faces=len(face_list),
            num_face_indices=sum(len(f) for f in face_list))
        crc = mesh_crc32(v, face_list, regions)

        def chunks() -> Iterator[Any]:
            # Vertices `chunk` at a time; faces up to 4 * `chunk` indices at
            # a time (polygons would otherwise make large messages).
            for b in range(0, len(v), self._chunk):
                yield pb.CreateSessionRequest.Chunk(
                    positions=v[b:b + self._chunk].ravel())
            b = 0
            while b < len(face_list):
                e, indices = b, 0
                while e < len(face_list) and (
                        e == b or indices + len(face_list[e]) <= 4 * self._chunk):
                    indices += len(face_list[e])
                    e += 1
                fs = face_list[b:e]
                chunk = pb.CreateSessionRequest.Chunk(
                    face_sizes=[len(f) for f in fs],
                    face_indices=np.concatenate(fs))
                if regions is not None:
                    chunk.face_regions.extend(regions[b:e])
                yield chunk
                b = e

        footer = pb.CreateSessionRequest.Footer(
            num_vertices=len(v), num_faces=len(face_list), crc32=crc)
        return self._create(header, chunks, footer)

    def upload_file(self, path: "str | os.PathLike[str]",
                    session_id: Optional[str] = None,
                    outward_regions: Sequence[int] = (), *,
                    reorient: bool = False,
                    drop_degenerate_faces: bool = False) -> SessionInfo:
        """Creates a session from a mesh file (.obj .off .ply .stl), read by
        the server's readers exactly as the CLI reads it (BOM, polygons,
        regions from OBJ groups); returns its SessionInfo, whose warnings
        name what the reader and the repairs did. The file may be at most
        the server's max_upload_file_bytes (ServerInfo); it is checked, as a
        regular file, before it is read."""
        name, data = self._read_mesh_file(path)
        return self.upload_file_bytes(
            name, data, session_id, outward_regions, reorient=reorient,
            drop_degenerate_faces=drop_degenerate_faces)

    def _read_mesh_file(self, path: "str | os.PathLike[str]"
                        ) -> Tuple[str, bytes]:
        """(the file's name, its bytes), checked before reading."""
        path = os.fspath(path)
        _format_of(path)
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode):
            raise ValueError(f"{path}: not a regular file")
        if st.st_size == 0:
            raise ValueError(f"{path}: the file is empty")
        info = self.server_info()
        if info is not None and st.st_size > info.max_upload_file_bytes > 0:
            raise ValueError(
                f"{path}: {st.st_size} bytes exceed this server's limit of "
                f"{info.max_upload_file_bytes} bytes for a file "
                "(--max_upload_file_bytes, or 1/8 of its memory budget)")
        return os.path.basename(path), _read(path)

    def upload_file_bytes(self, name: str, data: bytes,
                          session_id: Optional[str] = None,
                          outward_regions: Sequence[int] = (), *,
                          reorient: bool = False,
                          drop_degenerate_faces: bool = False) -> SessionInfo:
        """upload_file() of a file's bytes; `name` gives the format by its
        extension and names the file in the server's messages."""
        fmt = _format_of(name)
        if not data:
            raise ValueError(f"{name}: the file is empty")
        header = self._header(session_id, outward_regions, reorient,
                              drop_degenerate_faces, file_format=fmt,
                              file_bytes=len(data), file_name=_last_bytes(name, 256))
        step = max(self._chunk * 8, 1 << 16)

        def chunks() -> Iterator[Any]:
            for b in range(0, len(data), step):
                yield pb.CreateSessionRequest.Chunk(file_data=data[b:b + step])

        footer = pb.CreateSessionRequest.Footer(
            crc32=zlib.crc32(data) & 0xFFFFFFFF)
        return self._create(header, chunks, footer)

    def _header(self, session_id: Optional[str],
                outward_regions: Sequence[int], reorient: bool,
                drop_degenerate_faces: bool, **fields: Any) -> Any:
        sid = session_id if session_id is not None else f"py-{uuid.uuid4().hex}"
        return pb.CreateSessionRequest.Header(
            session_id=sid, reorient=reorient,
            drop_degenerate_faces=drop_degenerate_faces,
            region_directions=[pb.RegionDirection(
                region=r, direction=pb.CONE_DIRECTION_OUTWARD)
                for r in outward_regions], **fields)

    def _create(self, header: Any, chunks: Callable[[], Iterator[Any]],
                footer: Any) -> SessionInfo:
        """Streams header, chunks and footer (again on each retry)."""
        def requests() -> Iterator[Any]:
            yield pb.CreateSessionRequest(header=header)
            for chunk in chunks():
                yield pb.CreateSessionRequest(chunk=chunk)
            yield pb.CreateSessionRequest(footer=footer)

        metadata = self._metadata(header.session_id)

        def create() -> Any:
            return self._stub.CreateSession(requests(), timeout=self._deadline,
                                            metadata=metadata,
                                            wait_for_ready=False)

        reply = self._retrying(create)
        welded = np.asarray(reply.welded_vertex, dtype=np.int64)
        info = _wire.session_info(reply.session,
                                  welded if welded.size else None)
        self._shapes[info.session_id] = (info.dimension, info.num_vertices)
        self._welds.pop(info.session_id, None)
        if welded.size:
            try:
                self._welds[info.session_id] = _weld.weld_map(
                    welded, info.num_vertices, uploaded)
            except ValueError as e:
                raise DataLossError(grpc.StatusCode.DATA_LOSS,
                                    f"CreateSession: {e}") from None
        return info

    def session(self, vertices: Any, faces: Any = None,
                session_id: Optional[str] = None,
                regions: Optional[Sequence[int]] = None,
                outward_regions: Sequence[int] = (), *,
                reorient: bool = False,
                drop_degenerate_faces: bool = False) -> "Session":
        """Uploads the mesh and returns a Session (a context manager that
        deletes it on exit and re-creates it if the server lost it).
        vertices and faces are arrays, or `vertices` is a mesh object and
        faces is omitted: trimesh (.vertices, .faces), Open3D (.vertices,
        .triangles) or meshio (.points, .cells); polygons included. The
        keyword options are upload()'s."""
        from meshgauge_client.session import Session
        if faces is None:
            vertices, faces = _wire.mesh_arrays(vertices)
        v = _wire.points(vertices, "vertices")
        face_list = _wire.faces_list(faces, v.shape[1])
        region_list = None if regions is None else list(regions)

        def create(sid: Optional[str]) -> SessionInfo:
            return self.upload(v, face_list, sid, region_list, outward_regions,
                               reorient=reorient,
                               drop_degenerate_faces=drop_degenerate_faces)

        # The server's mesh differs from the arrays when polygons were
        # triangulated or a repair changed faces: it is fetched then.
        changed = reorient or drop_degenerate_faces or any(
            len(f) > 4 for f in face_list)
        return Session(self, create, session_id,
                       None if changed else (v, face_list))

    def session_from_file(self, path: "str | os.PathLike[str]",
                          session_id: Optional[str] = None,
                          outward_regions: Sequence[int] = (), *,
                          reorient: bool = False,
                          drop_degenerate_faces: bool = False) -> "Session":
        """upload_file() as a Session; its positions and faces are the
        server's reading of the file (fetched once with mesh()). The file's
        bytes are kept: a session the server lost is re-created from them,
        whatever happened to the file since."""
        from meshgauge_client.session import Session
        name, data = self._read_mesh_file(path)

        def create(sid: Optional[str]) -> SessionInfo:
            return self.upload_file_bytes(
                name, data, sid, outward_regions, reorient=reorient,
                drop_degenerate_faces=drop_degenerate_faces)

        return Session(self, create, session_id)

    def mesh(self, session_id: str) -> MeshData:
        """The session's mesh as the server holds it, at its current
        generation (GetMesh)."""
        r = self._call(self._stub.GetMesh,
                       pb.GetMeshRequest(session_id=session_id), session_id)
        return _wire.mesh_data(r)

    def info(self, session_id: str) -> SessionInfo:
        """The session's SessionInfo (does not reset its idle clock)."""
        return _wire.session_info(self._call(
            self._stub.GetSession, pb.GetSessionRequest(session_id=session_id),
            session_id).session)

    def list(self, page_size: int = 100) -> List[SessionInfo]:
        """Every session of the caller's tenant."""
        out: List[SessionInfo] = []
        token = ""
        while True:
            resp = self._call(self._stub.ListSessions, pb.ListSessionsRequest(
                page_size=page_size, page_token=token))
            out.extend(_wire.session_info(s) for s in resp.sessions)
            token = resp.next_page_token
            if not token:
                return out

    def delete(self, session_id: str) -> None:
        self._call(self._stub.DeleteSession,
                   pb.DeleteSessionRequest(session_id=session_id), session_id)
        self._shapes.pop(session_id, None)

    def update_positions(self, session_id: str, positions: Any,
                         expected_generation: int,
                         indices: Optional[Sequence[int]] = None) -> int:
        """Moves all vertices ((N, d) positions) or those of ``indices``;
        returns the new generation. AbortedError when the session is not at
        expected_generation (another writer moved it)."""
        p = _wire.points(positions, "positions",
                         len(indices) if indices is not None else None)
        req = pb.UpdatePositionsRequest(
            session_id=session_id, expected_generation=int(expected_generation),
            positions=p.ravel())
        if indices is not None:
            req.indices.extend(int(i) for i in indices)
        return int(self._call(self._stub.UpdatePositions, req,
                              session_id).generation)

    # Computations -----------------------------------------------------------

    def sdf(self, session_id: str, *, expected_generation: Optional[int] = None,
            jacobian: bool = False, **params: Any) -> SdfResult:
        """SDF per vertex, or per face with samples="faces" (SdfResult).
        params: options=SdfOptions(...), or its fields as keywords (method,
        cone_angle_degrees, rays, kappa, max_distance, normals, samples; the
        CLI's flags). jacobian=True adds the sparse Jacobian (N, V*d)."""
        wire_params = self._params(params)
        faces = wire_params.samples == pb.SAMPLE_SET_FACES
        req = pb.ComputeSdfRequest(session_id=session_id, params=wire_params,
                                   include_jacobian=jacobian)
        if expected_generation is not None:
            req.expected_generation = expected_generation

        def stream(messages: Iterator[Any]) -> SdfResult:
            values: List[float] = []
            status: List[int] = []
            hits: List[int] = []
            kept: List[int] = []
            normalized: List[float] = []
            opposite: List[float] = []
            rows: List[int] = [0]
            cols: List[int] = []
            data: List[float] = []
            summary = None
            for msg in messages:
                if msg.HasField("summary"):
                    summary = msg.summary
                    continue
                c = msg.chunk
                values.extend(c.values)
                status.extend(c.status)
                hits.extend(c.hits)
                kept.extend(c.kept)
                normalized.extend(c.normalized)
                opposite.extend(c.opposite)
                if jacobian:
                    base = rows[-1]
                    rows.extend(base + o for o in list(c.row_offsets)[1:])
                    cols.extend(c.columns)
                    data.extend(c.derivatives)
            n = len(values)
            if summary is None:
                raise DataLossError(grpc.StatusCode.DATA_LOSS,
                                    "ComputeSdf stream ended without its "
                                    "summary")
            counted = (summary.ok + summary.no_hit + summary.no_faces
                       + summary.degenerate_normal)
            if counted != n or summary.ok != sum(
                    1 for x in status if x == pb.VERTEX_STATUS_OK):
                raise DataLossError(
                    grpc.StatusCode.DATA_LOSS,
                    f"the summary counts {counted} samples ({summary.ok} "
                    f"with a value), the chunks carried {n}")
            if faces != (summary.samples == pb.SAMPLE_SET_FACES):
                raise DataLossError(
                    grpc.StatusCode.DATA_LOSS,
                    ("face" if faces else "vertex") + " samples were asked "
                    "for, the reply holds others (is the server older than "
                    "SdfParameters.samples?)")
            if len(opposite) != (3 * n if wire_params.opposite_points else 0):
                raise DataLossError(
                    grpc.StatusCode.DATA_LOSS,
                    f"the server sent {len(opposite)} opposite coordinates "
                    f"for {n} samples" + (
                        " (is the server older than "
                        "SdfParameters.opposite_points?)"
                        if wire_params.opposite_points and not opposite
                        else ""))
            jac = None
            if jacobian:
                d = len(data) // max(1, len(cols)) if cols else self._dim(session_id)
                col = np.asarray(cols, dtype=np.int64)
                full_cols = (col[:, None] * d + np.arange(d)).ravel()
                counts = np.diff(np.asarray(rows, dtype=np.int64)) * d
                indptr = np.concatenate([[0], np.cumsum(counts)])
                nv = self._shape(session_id)[1] if faces else n
                jac = scipy.sparse.csr_matrix(
                    (np.asarray(data, dtype=np.float64), full_cols, indptr),
                    shape=(n, nv * d))
            result = SdfResult(np.asarray(values, dtype=np.float64),
                               np.asarray(status, dtype=np.int64),
                               np.asarray(hits, dtype=np.int64),
                               np.asarray(kept, dtype=np.int64),
                               np.asarray(normalized, dtype=np.float64),
                               _wire.summary(summary), jac,
                               np.asarray(opposite, dtype=np.float64)
                               .reshape(-1, 3) if opposite else None)
            for w in result.summary.warnings:
                warnings.warn(w, MissingValuesWarning, stacklevel=6)
            return result

        result: SdfResult = self._call(self._stub.ComputeSdf, req, session_id,
                                       stream)
        return result

    def vjp(self, session_id: str, weights: Any, *,
            expected_generation: Optional[int] = None,
            **params: Any) -> FloatArray:
        """g^T dSDF/dx for weights g (N,), one per sample (vertex, or face
        with samples="faces"): a (V, d) array, one row per vertex."""
        g = np.asarray(weights, dtype=np.float64)
        if g.ndim != 1 or not np.all(np.isfinite(g)):
            raise ValueError("weights must be a finite (N,) array")
        req = pb.ComputeVjpRequest(session_id=session_id,
                                   params=self._params(params), weights=g)
        if expected_generation is not None:
            req.expected_generation = expected_generation
        resp = self._call(self._stub.ComputeVjp, req, session_id)
        return _wire.flat(resp.gradient, self._dim(session_id))

    def penalty(self, session_id: str, t_min: float, *, form: str = "one-sided",
                power: float = 2.0, rho: float = 50.0,
                max_missing_fraction: float = 0.5, gradient: bool = True,
                expected_generation: Optional[int] = None,
                thin_regions: bool = False, min_region_area: float = 0.0,
                max_thin_regions: int = 1000,
                **params: Any) -> PenaltyResult:
        """Minimum-thickness penalty (form one-sided or thesis, power n >= 1)
        or the aggregated KS constraint (form "ks", rho > 0), with its
        gradient (N, d). FailedPreconditionError when faces without values
        cover more than max_missing_fraction of the surface.

        thin_regions: also PenaltyResult.thin, where the surface is thinner
        than t_min (ThinSurface; the max_thin_regions largest regions,
        1..100000; regions under min_region_area marked speck), the table
        of `meshgauge report`."""
        t = _wire._number("t_min", t_min, 0, np.inf, lo_open=True)
        req = pb.ComputePenaltyRequest(
            session_id=session_id, params=self._params(params), t_min=t,
            form=_wire._choice("form", form, _wire.FORMS),
            power=_wire._number("power", power, 1, np.inf),
            rho=_wire._number("rho", rho, 0, np.inf, lo_open=True),
            max_missing_fraction=_wire._number(
                "max_missing_fraction", max_missing_fraction, 0, 1),
            with_gradient=gradient)
        if thin_regions:
            if (isinstance(max_thin_regions, bool)
                    or not isinstance(max_thin_regions, int)
                    or not 1 <= max_thin_regions <= 100000):
                raise ValueError("max_thin_regions must be an int in "
                                 f"[1, 100000], got {max_thin_regions!r}")
            req.with_thin_regions = True
            req.min_region_area = _wire._number(
                "min_region_area", min_region_area, 0, np.inf)  # finite.
            req.max_thin_regions = max_thin_regions
        if expected_generation is not None:
            req.expected_generation = expected_generation
        resp = self._call(self._stub.ComputePenalty, req, session_id)
        return _wire.penalty(resp, self._dim(session_id), form, t,
                             thin_regions)

    def constraint(self, session_id: str, t_min: float, *, rho: float = 50.0,
                   **kwargs: Any) -> PenaltyResult:
        """The aggregated constraint G (penalty with form "ks"): bound it by
        0 in the optimiser."""
        return self.penalty(session_id, t_min, form="ks", rho=rho, **kwargs)

    def calibrate(self, session_id: str, t_min: float, *,
                  tolerance: float = 0.01, bins: int = 20,
                  **params: Any) -> Calibration:
        """SPEC §8 calibration report (Calibration)."""
        t = _wire._number("t_min", t_min, 0, np.inf, lo_open=True)
        if not isinstance(bins, int) or not 1 <= bins <= 1000:
            raise ValueError(f"bins must be an int in [1, 1000], got {bins!r}")
        return _wire.calibration(self._call(
            self._stub.Calibrate, pb.CalibrateRequest(
                session_id=session_id, params=self._params(params),
                t_min=t, equal_tolerance=_wire._number(
                    "tolerance", tolerance, 0, 1, lo_open=True), bins=bins),
            session_id))

    def gradcheck(self, session_id: str, *, probes: Optional[int] = None,
                  samples: "int | str | None" = None, seed: int = 1,
                  vertices: Optional[Any] = None,
                  relative_step: float = 1e-7, tolerance: float = 1e-5,
                  min_clean_fraction: float = 0.9,
                  penalty: Optional["dict[str, Any]"] = None,
                  expected_generation: Optional[int] = None,
                  **params: Any) -> GradCheckReport:
        """The SPEC §6 finite-difference check of the session's derivatives
        at its current positions, run by the server on a private copy (the
        session is unchanged): `meshgauge gradcheck`. probes (1..1000, 12)
        vertices drawn with seed, or the given vertices; samples "vertices"
        or "faces": where the checked values are (SPEC v2 §5c; an int is the
        older name of probes); penalty: also the penalty's gradient, a dict
        of t_min and optionally form, power, rho, max_missing_fraction.
        report.ok is True on PASS."""
        if isinstance(samples, str):
            params["samples"] = samples
        elif samples is not None:
            if probes is not None:
                raise TypeError("give probes, or samples as a count, not both")
            probes = samples
        if probes is None:
            probes = 12
        if (isinstance(probes, bool) or not isinstance(probes, int)
                or not 1 <= probes <= 1000):
            raise ValueError(f"probes must be an int in [1, 1000], got "
                             f"{probes!r}")
        req = pb.GradCheckRequest(
            session_id=session_id, params=self._params(params),
            samples=probes, seed=seed,
            relative_step=_wire._number("relative_step", relative_step, 0,
                                        0.01, lo_open=True),
            tolerance=_wire._number("tolerance", tolerance, 0, np.inf,
                                    lo_open=True),
            min_clean_fraction=_wire._number(
                "min_clean_fraction", min_clean_fraction, 0, 1))
        if vertices is not None:
            listed = _wire._indices(np.asarray(vertices).ravel(), "vertices")
            if listed.size > 1000:
                raise ValueError("at most 1000 vertices, got "
                                 f"{listed.size}")
            req.vertices.extend(int(v) for v in listed)
        if penalty is not None:
            p = dict(penalty)
            req.penalty.t_min = _wire._number("t_min", p.pop("t_min", 0), 0,
                                              np.inf, lo_open=True)
            req.penalty.form = _wire._choice("form",
                                             p.pop("form", "one-sided"),
                                             _wire.FORMS)
            req.penalty.power = _wire._number("power", p.pop("power", 2.0), 1,
                                              np.inf)
            req.penalty.rho = _wire._number("rho", p.pop("rho", 50.0), 0,
                                            np.inf, lo_open=True)
            req.penalty.max_missing_fraction = _wire._number(
                "max_missing_fraction", p.pop("max_missing_fraction", 0.5),
                0, 1)
            if p:
                raise ValueError(f"unknown penalty keys {sorted(p)}")
        if expected_generation is not None:
            req.expected_generation = expected_generation

        def read(messages: Iterator[Any]) -> GradCheckReport:
            report = None
            for msg in messages:
                if msg.HasField("report"):
                    report = msg.report
            if report is None:
                raise DataLossError(grpc.StatusCode.DATA_LOSS,
                                    "GradCheck stream ended without a report")
            return _wire.gradcheck(report)

        result: GradCheckReport = self._call(self._stub.GradCheck, req,
                                             session_id, read)
        return result


__all__ = ["MeshGaugeClient", "MeshGaugeError", "mesh_crc32", "SESSION_KEY"]
