"""MeshGaugeClient: one meshgauge server, numpy in, numpy out.

Arrays: vertices (N, d) floats (d = 2 or 3); faces an (M, k) int array or a
list of index sequences (2 per segment in 2D; 3 to 256 corners in 3D,
polygons triangulated by the server). Mesh files are read by the server. Every call
of a session sends ``x-meshgauge-session`` (the balancer's routing key) and,
with a token, ``authorization: Bearer <token>``; a range call of a
fanned-out sdf, vjp or penalty (``fan_out=K``) adds ``x-meshgauge-range:
BEGIN-END`` and ``x-meshgauge-part: I`` (_fan_out). The channel retries
UNAVAILABLE with exponential backoff; a call keeps retrying UNAVAILABLE for
``retry_seconds`` (``connect_seconds`` while the server has never answered),
then raises UnavailableError naming the target. Welded uploads
(``weld=``) keep the caller's vertex indexing in every result (_weld).
"""

import concurrent.futures
import dataclasses
import json
import os
import socket
import stat
import warnings
import time
import uuid
import zlib
from typing import (Any, Callable, Iterator, List, Optional,
                    Sequence, Tuple, TypeVar)

import grpc
import numpy as np
import scipy.sparse

from meshgauge_client import _fan_out, _weld, _wire
from meshgauge_client._stubs import pb
from meshgauge_client._stubs import pb_grpc
from meshgauge_client.errors import (CancelledError, DataLossError,
                                     InvalidArgumentError,
                                     MeshGaugeError, MissingValuesWarning,
                                     ResourceExhaustedError, UnavailableError,
                                     from_rpc_error)
from meshgauge_client.options import SdfOptions
from meshgauge_client.session import Session
from meshgauge_client.results import (Calibration, FloatArray,
                                      GradCheckReport, MeshData,
                                      PenaltyResult, SdfResult, SdfSummary,
                                      ServerInfo, SessionInfo)

SESSION_KEY = "x-meshgauge-session"
# The prefix of a CANCELLED upload: the client never cancels one, so the
# server stopped it (the C++ client says the same).
UPLOAD_CANCELLED_BY_SERVER = (
    "the server cancelled the upload: it stops an upload silent for longer "
    "than its --upload_idle_seconds (30 s by default), and cancels calls "
    "when it shuts down; its log names which: ")
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


def _with_path(error: OSError, path: str) -> OSError:
    """`error` (from stat or open) naming `path` in its message."""
    if error.filename is not None:
        return error
    return type(error)(error.errno, error.strerror or str(error), path)


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
    retrying UNAVAILABLE or waiting for a connection (a restarting server)
    before it fails; connect_seconds: the same while the server has never
    answered this client (a wrong address, no server), and the least a
    call waits for a connection. The failure is an UnavailableError naming
    the target and why (connection refused, ...).
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
        self._token = token
        self._tls_files = (tls_ca_file, tls_cert_file, tls_key_file)
        self._stub = pb_grpc.MeshGaugeStub(self._channel)
        self._deadline = deadline
        self._chunk = chunk
        self._target = target
        self._retry_seconds = retry_seconds
        self._connect_seconds = connect_seconds
        self._answered = False  # has the server ever answered a call?
        # The channel's connectivity, kept by gRPC's callback.
        self._state: Any = None
        self._channel.subscribe(self._on_state, try_to_connect=False)
        # Per session: its dimension, vertex and face counts (fixed at
        # upload).
        self._shapes: "dict[str, Tuple[int, int, int]]" = {}
        # Per welded session: its map between uploaded and session vertices.
        self._welds: "dict[str, _weld.WeldMap]" = {}
        self._server_info: Optional[ServerInfo] = None
        self._asked_server_info = False

    def close(self) -> None:
        self._channel.unsubscribe(self._on_state)
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

    @property
    def token(self) -> Optional[str]:
        """The token sent, or None (open mode)."""
        return self._token

    def cli_tls_flags(self) -> List[str]:
        """The `meshgauge remote` flags of this client's TLS files."""
        flags: List[str] = []
        for flag, path in (("--tls-ca-file", self._tls_files[0]),
                           ("--tls-cert-file", self._tls_files[1]),
                           ("--tls-key-file", self._tls_files[2])):
            if path:
                flags += [flag, os.fspath(path)]
        return flags

    def _on_state(self, state: Any) -> None:
        self._state = state

    def _wait_ready(self, timeout: float) -> bool:
        """Waits up to `timeout` seconds for the channel to be READY (asking
        it to connect); False when it is not."""
        if self._state == grpc.ChannelConnectivity.READY:
            return True
        if timeout <= 0:
            return False
        ready = grpc.channel_ready_future(self._channel)
        try:
            ready.result(timeout=timeout)
            return True
        except grpc.FutureTimeoutError:
            ready.cancel()
            return False

    def _retrying(self, call: Callable[[], T]) -> T:
        """Runs call() once the channel is ready, retrying UNAVAILABLE with
        backoff; gives up retry_seconds after the start (connect_seconds
        while the server never answered this client) with an
        UnavailableError naming the target. Each call may wait
        connect_seconds for a connection however small retry_seconds is.
        Calls never wait for readiness inside gRPC (wait_for_ready=False),
        which would hold them for the whole deadline."""
        start = time.monotonic()
        budget = (self._retry_seconds if self._answered
                  else self._connect_seconds)
        stop = start + budget
        delay = 0.05
        attempts = 0
        while True:
            if self._state != grpc.ChannelConnectivity.READY:
                wait = stop - time.monotonic()
                if attempts == 0:
                    wait = max(wait, self._connect_seconds)
                if not self._wait_ready(wait):
                    raise self._unavailable(
                        f"no connection within {time.monotonic() - start:.1f}"
                        f" s{self._budget_note(budget)}{self._diagnosis()}")
            attempts += 1
            try:
                result = call()
                self._answered = True
                return result
            except grpc.RpcError as e:
                if e.code() != grpc.StatusCode.UNAVAILABLE:
                    self._answered = True
                    raise from_rpc_error(e) from None
                if time.monotonic() + delay > stop:
                    raise self._unavailable(
                        f"UNAVAILABLE {attempts} time"
                        f"{'' if attempts == 1 else 's'} in "
                        f"{time.monotonic() - start:.1f} s"
                        f"{self._budget_note(budget)}; last error: "
                        f"{e.details() or ''}") from None
            time.sleep(delay)
            delay = min(2 * delay, 1.0)

    def _diagnosis(self) -> str:
        """Why a plain host:port target does not connect (one TCP connect,
        at most 1 s): "; connection refused", ...; "" for other targets."""
        host, sep, port = self._target.rpartition(":")
        if not sep or not port.isdigit() or "/" in host:
            return ""
        host = host.strip("[]")
        try:
            with socket.create_connection((host, int(port)), timeout=1.0):
                return "; TCP connects (a TLS or HTTP/2 handshake fails?)"
        except ConnectionRefusedError:
            return f"; connection refused by {self._target}"
        except socket.timeout:
            return f"; no answer from {self._target} within 1 s"
        except OSError as e:
            return f"; {e.strerror or e}"

    def _budget_note(self, budget: float) -> str:
        if self._answered:
            return f" (retry_seconds={budget:g})"
        return (f" (connect_seconds={self._connect_seconds:g}: it never "
                "answered this client)")

    def _unavailable(self, why: str) -> UnavailableError:
        """The error of a call without a reply within its budget."""
        return UnavailableError(
            grpc.StatusCode.UNAVAILABLE,
            f"the server at {self._target} is unavailable: {why}")

    def _call(self, method: Any, request: Any, session_id: str = "",
              read: Optional[Callable[[Any], Any]] = None,
              extra_metadata: Sequence[Tuple[str, str]] = ()) -> Any:
        """method(request) with the deadline, the session's metadata (and
        extra_metadata) and the retries; read(reply) (a stream's messages)
        inside each attempt."""
        metadata = self._metadata(session_id) + list(extra_metadata)

        def invoke() -> Any:
            reply = method(request, timeout=self._deadline, metadata=metadata,
                           wait_for_ready=False)
            return read(reply) if read else reply

        return self._retrying(invoke)

    def _shape(self, session_id: str) -> Tuple[int, int]:
        """The session's dimension and vertex count."""
        d, nv, _ = self._counts(session_id)
        return d, nv

    def _counts(self, session_id: str) -> Tuple[int, int, int]:
        """The session's dimension, vertex count and face count (asked
        once with GetSession unless this client uploaded it)."""
        if session_id not in self._shapes:
            info = self.info(session_id)
            self._shapes[session_id] = (info.dimension, info.num_vertices,
                                        info.num_faces)
        return self._shapes[session_id]

    def _samples(self, session_id: str, faces: bool) -> int:
        """The session's vertex count, or its face count."""
        return self._counts(session_id)[2 if faces else 1]

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
               drop_degenerate_faces: bool = False,
               weld: "bool | float" = False) -> SessionInfo:
        """Creates a session from vertices (N, d) and faces; returns its
        SessionInfo. session_id: [A-Za-z0-9._-]{1,64}; None generates a
        UUID-based one (every call then carries its routing key). regions:
        one region id per face; outward_regions: regions whose cone opens
        along +n (SPEC §1). Polygons (5 to 256 corners) are triangulated
        by the server. reorient: make each component's faces agree, then
        turn closed components outward; drop_degenerate_faces: remove
        zero-area faces (as the CLI's flags; SessionInfo.warnings says what
        changed). weld: merge duplicate vertices first (True: exact
        duplicates; a number: within that fraction of the bounding box's
        diagonal, at most 0.01); every later call of this client on the
        session keeps the uploaded vertices' indexing
        (SessionInfo.welded_vertex maps them to the session's)."""
        v = _wire.points(vertices, "vertices")
        dim = v.shape[1]
        face_list = _wire.faces_list(faces, dim)
        if regions is not None and len(regions) != len(face_list):
            raise ValueError(f"regions must have one entry per face "
                             f"({len(face_list)}), got {len(regions)}")
        header = self._header(
            session_id, outward_regions, reorient, drop_degenerate_faces,
            weld, dimension=dim, num_vertices=len(v), num_faces=len(face_list),
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
        return self._create(header, chunks, footer, len(v))

    def upload_file(self, path: "str | os.PathLike[str]",
                    session_id: Optional[str] = None,
                    outward_regions: Sequence[int] = (), *,
                    reorient: bool = False,
                    drop_degenerate_faces: bool = False,
                    weld: "bool | float" = False) -> SessionInfo:
        """Creates a session from a mesh file (.obj .off .ply .stl), read by
        the server's readers exactly as the CLI reads it (BOM, polygons,
        regions from OBJ groups); returns its SessionInfo, whose warnings
        name what the reader and the repairs did. The file may be at most
        the server's max_upload_file_bytes (ServerInfo); it is checked, as a
        regular file, before it is read. Every error about the file (local
        checks, the server's INVALID_ARGUMENT and RESOURCE_EXHAUSTED) names
        its path. weld: as upload() (the file's vertices are the uploaded
        ones)."""
        name, data = self._read_mesh_file(path)
        return self.upload_file_bytes(
            name, data, session_id, outward_regions, reorient=reorient,
            drop_degenerate_faces=drop_degenerate_faces, weld=weld)

    def _read_mesh_file(self, path: "str | os.PathLike[str]"
                        ) -> Tuple[str, bytes]:
        """(the file's path, its bytes), checked before reading; every error
        names the path."""
        path = os.fspath(path)
        _format_of(path)
        try:
            st = os.stat(path)
        except OSError as e:
            raise _with_path(e, path) from None
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
        try:
            return path, _read(path)
        except OSError as e:
            raise _with_path(e, path) from None

    def upload_file_bytes(self, name: str, data: bytes,
                          session_id: Optional[str] = None,
                          outward_regions: Sequence[int] = (), *,
                          reorient: bool = False,
                          drop_degenerate_faces: bool = False,
                          weld: "bool | float" = False) -> SessionInfo:
        """upload_file() of a file's bytes; `name` (a path or a file name)
        gives the format by its extension and names the file in the
        server's messages (its last 256 bytes) and in every error about
        the file."""
        fmt = _format_of(name)
        if not data:
            raise ValueError(f"{name}: the file is empty")
        header = self._header(session_id, outward_regions, reorient,
                              drop_degenerate_faces, weld, file_format=fmt,
                              file_bytes=len(data), file_name=_last_bytes(name, 256))
        step = max(self._chunk * 8, 1 << 16)

        def chunks() -> Iterator[Any]:
            for b in range(0, len(data), step):
                yield pb.CreateSessionRequest.Chunk(file_data=data[b:b + step])

        footer = pb.CreateSessionRequest.Footer(
            crc32=zlib.crc32(data) & 0xFFFFFFFF)
        try:
            return self._create(header, chunks, footer)
        except (InvalidArgumentError, ResourceExhaustedError) as e:
            # The server names the file by the (possibly cut) name sent; a
            # message about the mesh it read may not name it at all.
            if name in e.details:
                raise
            raise type(e)(e.code, f"{name}: {e.details}") from None

    def _header(self, session_id: Optional[str],
                outward_regions: Sequence[int], reorient: bool,
                drop_degenerate_faces: bool, weld: "bool | float",
                **fields: Any) -> Any:
        sid = session_id if session_id is not None else f"py-{uuid.uuid4().hex}"
        welding, tolerance = _weld.options(weld)
        return pb.CreateSessionRequest.Header(
            session_id=sid, reorient=reorient,
            drop_degenerate_faces=drop_degenerate_faces,
            weld=welding, weld_tolerance=tolerance,
            region_directions=[pb.RegionDirection(
                region=r, direction=pb.CONE_DIRECTION_OUTWARD)
                for r in outward_regions], **fields)

    def _create(self, header: Any, chunks: Callable[[], Iterator[Any]],
                footer: Any, uploaded: Optional[int] = None) -> SessionInfo:
        """Streams header, chunks and footer (again on each retry); keeps
        the weld map of a welded upload (of `uploaded` vertices, when
        known)."""
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

        try:
            reply = self._retrying(create)
        except CancelledError as e:
            # This client cancels no upload: the server stopped it.
            raise CancelledError(e.code, UPLOAD_CANCELLED_BY_SERVER
                                 + e.details) from None
        welded = np.asarray(reply.welded_vertex, dtype=np.int64)
        info = _wire.session_info(reply.session,
                                  welded if welded.size else None)
        self._shapes[info.session_id] = (info.dimension, info.num_vertices,
                                         info.num_faces)
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
                drop_degenerate_faces: bool = False,
                weld: "bool | float" = False) -> "Session":
        """Uploads the mesh and returns a Session (a context manager that
        deletes it on exit and re-creates it if the server lost it).
        vertices and faces are arrays, or `vertices` is a mesh object and
        faces is omitted: trimesh (.vertices, .faces), Open3D (.vertices,
        .triangles) or meshio (.points, .cells); polygons included. The
        keyword options are upload()'s; with weld, the Session's positions,
        values and gradients stay one per vertex given."""
        if faces is None:
            vertices, faces = _wire.mesh_arrays(vertices)
        v = _wire.points(vertices, "vertices")
        face_list = _wire.faces_list(faces, v.shape[1])
        region_list = None if regions is None else list(regions)

        def create(sid: Optional[str]) -> SessionInfo:
            return self.upload(v, face_list, sid, region_list, outward_regions,
                               reorient=reorient,
                               drop_degenerate_faces=drop_degenerate_faces,
                               weld=weld)

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
                          drop_degenerate_faces: bool = False,
                          weld: "bool | float" = False) -> "Session":
        """upload_file() as a Session; its positions and faces are the
        server's reading of the file (fetched once with mesh(); with weld,
        one position per vertex of the file, each face's corners the
        lowest-numbered copies). The file's bytes are kept: a session the
        server lost is re-created from them, whatever happened to the file
        since. Every error about the file names its path."""
        name, data = self._read_mesh_file(path)

        def create(sid: Optional[str]) -> SessionInfo:
            return self.upload_file_bytes(
                name, data, sid, outward_regions, reorient=reorient,
                drop_degenerate_faces=drop_degenerate_faces, weld=weld)

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
        self._welds.pop(session_id, None)

    def weld_map(self, session_id: str) -> Optional[_weld.WeldMap]:
        """The map between the uploaded and the session's vertices of a
        session this client uploaded welded (None when nothing merged)."""
        return self._welds.get(session_id)

    def update_positions(self, session_id: str, positions: Any,
                         expected_generation: int,
                         indices: Optional[Sequence[int]] = None) -> int:
        """Moves all vertices ((N, d) positions) or those of ``indices``;
        returns the new generation. AbortedError when the session is not at
        expected_generation (another writer moved it). A welded session
        takes one position per uploaded vertex (indices of uploaded
        vertices) and moves each of its vertices to the position of its
        lowest-numbered copy; the other copies' positions are not sent."""
        p = _wire.points(positions, "positions",
                         len(indices) if indices is not None else None)
        listed = (None if indices is None else
                  _wire._indices(np.asarray(indices).ravel(), "indices"))
        m = self._welds.get(session_id)
        if m is not None:
            if listed is None:
                p = _weld.gather_positions(p, m)
            else:
                listed, p = _weld.session_update(listed, p, m)
        req = pb.UpdatePositionsRequest(
            session_id=session_id, expected_generation=int(expected_generation),
            positions=p.ravel())
        if listed is not None:
            req.indices.extend(int(i) for i in listed)
        return int(self._call(self._stub.UpdatePositions, req,
                              session_id).generation)

    # Computations -----------------------------------------------------------

    def sdf(self, session_id: str, *, expected_generation: Optional[int] = None,
            jacobian: bool = False, fan_out: int = 1,
            **params: Any) -> SdfResult:
        """SDF per vertex, or per face with samples="faces" (SdfResult).
        params: options=SdfOptions(...), or its fields as keywords (method,
        cone_angle_degrees, rays, kappa, max_distance, normals, samples; the
        CLI's flags). jacobian=True adds the sparse Jacobian (N, V*d).
        Welded session: one vertex sample per uploaded vertex (each its
        session vertex's; the summary counts the session's vertices), the
        Jacobian's columns those of the uploaded vertices (a session
        vertex's at its lowest-numbered copy).

        fan_out=K (default 1) splits the samples into K ranges computed at
        once (through a balancer, by different replicas) and merges them:
        the same result as one call, bit for bit (every array, the
        Jacobian, and the summary, whose normalized values, statistics,
        missing counts, integral and warnings are computed here from every
        value as the server computes them, on the session's mesh fetched
        with GetMesh). rays sums the ranges' traced rays, seconds is the
        slowest range's, reused_hits whether every range reused its pass.
        AbortedError when the session moved between the ranges."""
        fan_out = _fan_out.check_fan_out(fan_out)
        wire_params = self._params(params)
        faces = wire_params.samples == pb.SAMPLE_SET_FACES
        summary: Optional[SdfSummary] = None
        if fan_out > 1:
            reply, summary = self._sdf_ranges(
                session_id, wire_params, jacobian, expected_generation,
                fan_out)
        else:
            req = pb.ComputeSdfRequest(session_id=session_id,
                                       params=wire_params,
                                       include_jacobian=jacobian)
            if expected_generation is not None:
                req.expected_generation = expected_generation
            reply = self._call(self._stub.ComputeSdf, req, session_id,
                               lambda m: _fan_out.read_sdf(m, jacobian))
            _fan_out.check_sdf(reply, faces, wire_params.opposite_points)
        result = self._sdf_result(session_id, reply, summary, faces,
                                  jacobian)
        for w in result.summary.warnings:
            warnings.warn(w, MissingValuesWarning, stacklevel=2)
        m = self._welds.get(session_id)
        if m is None:
            return result
        d = self._dim(session_id)
        jac = (None if result.jacobian is None else
               _weld.jacobian(result.jacobian, m, d, vertex_rows=not faces))
        if faces:
            return dataclasses.replace(result, jacobian=jac)
        return dataclasses.replace(
            result, values=_weld.expand(result.values, m),
            status=_weld.expand(result.status, m),
            hits=_weld.expand(result.hits, m),
            kept=_weld.expand(result.kept, m),
            normalized=_weld.expand(result.normalized, m), jacobian=jac,
            opposite=None if result.opposite is None
            else _weld.expand(result.opposite, m))

    def _sdf_result(self, session_id: str, r: "_fan_out.SdfReply",
                    summary: Optional[SdfSummary], faces: bool,
                    jacobian: bool) -> SdfResult:
        """The SdfResult (session vertices) of a checked ComputeSdf reply,
        with `summary` (a fanned-out call's) or the reply's own."""
        n = len(r.values)
        jac = None
        if jacobian:
            d = (len(r.data) // max(1, len(r.cols)) if r.cols
                 else self._dim(session_id))
            col = np.asarray(r.cols, dtype=np.int64)
            full_cols = (col[:, None] * d + np.arange(d)).ravel()
            counts = np.diff(np.asarray(r.rows, dtype=np.int64)) * d
            indptr = np.concatenate([[0], np.cumsum(counts)])
            nv = self._shape(session_id)[1] if faces else n
            jac = scipy.sparse.csr_matrix(
                (np.asarray(r.data, dtype=np.float64), full_cols, indptr),
                shape=(n, nv * d))
        return SdfResult(
            np.asarray(r.values, dtype=np.float64),
            np.asarray(r.status, dtype=np.int64),
            np.asarray(r.hits, dtype=np.int64),
            np.asarray(r.kept, dtype=np.int64),
            np.asarray(r.normalized, dtype=np.float64),
            summary if summary is not None else _wire.summary(r.summary),
            jac,
            np.asarray(r.opposite, dtype=np.float64).reshape(-1, 3)
            if r.opposite else None)

    def _sdf_ranges(self, session_id: str, wire_params: Any, jacobian: bool,
                    expected_generation: Optional[int], fan_out: int
                    ) -> Tuple["_fan_out.SdfReply", SdfSummary]:
        """The fanned-out ComputeSdf: one streamed call per range at once
        and GetMesh beside them (the merged summary needs the mesh),
        merged."""
        faces = wire_params.samples == pb.SAMPLE_SET_FACES
        with concurrent.futures.ThreadPoolExecutor(1) as pool:
            mesh = pool.submit(self._call, self._stub.GetMesh,
                               pb.GetMeshRequest(session_id=session_id),
                               session_id)
            replies = self._sdf_range_replies(
                session_id, wire_params, jacobian, expected_generation,
                fan_out)
            mesh_reply = mesh.result()
        return _fan_out.merge_sdf(replies, mesh_reply, faces, jacobian)

    def _sdf_range_replies(self, session_id: str, wire_params: Any,
                           jacobian: bool,
                           expected_generation: Optional[int], fan_out: int
                           ) -> List["_fan_out.SdfReply"]:
        """The checked replies of the fanned-out ComputeSdf's ranges (one
        streamed call per range at once), in order: on the session's own
        samples (a welded session's vertices, not the uploaded ones)."""
        faces = wire_params.samples == pb.SAMPLE_SET_FACES
        ranges = _fan_out.split_samples(self._samples(session_id, faces),
                                        fan_out)

        def call(part: int) -> "_fan_out.SdfReply":
            r = ranges[part]
            req = pb.ComputeSdfRequest(
                session_id=session_id, params=wire_params,
                include_jacobian=jacobian,
                range=pb.SampleRange(begin=r[0], end=r[1]))
            if expected_generation is not None:
                req.expected_generation = expected_generation
            reply: _fan_out.SdfReply = self._call(
                self._stub.ComputeSdf, req, session_id,
                lambda m: _fan_out.read_sdf(m, jacobian, r[0]),
                extra_metadata=_fan_out.range_metadata(part, *r))
            _fan_out.check_sdf(reply, faces, wire_params.opposite_points, r)
            return reply

        with concurrent.futures.ThreadPoolExecutor(
                max(1, len(ranges))) as pool:
            return list(pool.map(call, range(len(ranges))))

    def vjp(self, session_id: str, weights: Any, *,
            expected_generation: Optional[int] = None, fan_out: int = 1,
            **params: Any) -> FloatArray:
        """g^T dSDF/dx for weights g (N,), one per sample (vertex, or face
        with samples="faces"): a (V, d) array, one row per vertex. Welded
        session: one weight per uploaded vertex (summed onto its session
        vertex), and each session vertex's row at its lowest-numbered
        uploaded vertex (zeros at the other copies).

        fan_out=K (default 1) splits the samples into K ranges sent at once
        (through a balancer, to different replicas) and adds their exact
        partial sums: the same bits as one call, for any K (AbortedError
        when the session moved between the ranges). Each range call carries
        x-meshgauge-range: BEGIN-END and x-meshgauge-part: I (its index
        0..K-1), the balancer's keys."""
        fan_out = _fan_out.check_fan_out(fan_out)
        g = np.asarray(weights, dtype=np.float64)
        if g.ndim != 1 or not np.all(np.isfinite(g)):
            raise ValueError("weights must be a finite (N,) array")
        wire_params = self._params(params)
        m = self._welds.get(session_id)
        if m is not None and wire_params.samples != pb.SAMPLE_SET_FACES:
            g = _weld.sum_weights(g, m)
        if fan_out > 1:
            flat, _ = self._vjp_ranges(session_id, wire_params, g,
                                       expected_generation, fan_out)
        else:
            req = pb.ComputeVjpRequest(session_id=session_id,
                                       params=wire_params, weights=g)
            if expected_generation is not None:
                req.expected_generation = expected_generation
            flat = self._call(self._stub.ComputeVjp, req, session_id).gradient
        out = _wire.flat(flat, self._dim(session_id))
        return out if m is None else _weld.scatter_gradient(out, m)

    def _vjp_ranges(self, session_id: str, wire_params: Any, g: Any,
                    expected_generation: Optional[int],
                    fan_out: int) -> Tuple[Any, int]:
        """The fanned-out ComputeVjp: one call per range at once, merged."""
        ranges = _fan_out.split_samples(len(g), fan_out)

        def call(part: int) -> Any:
            r = ranges[part]
            req = pb.ComputeVjpRequest(
                session_id=session_id, params=wire_params,
                weights=g[r[0]:r[1]],
                range=pb.SampleRange(begin=r[0], end=r[1]))
            if expected_generation is not None:
                req.expected_generation = expected_generation
            return self._call(self._stub.ComputeVjp, req, session_id,
                              extra_metadata=_fan_out.range_metadata(part, *r))

        with concurrent.futures.ThreadPoolExecutor(len(ranges)) as pool:
            replies = list(pool.map(call, range(len(ranges))))
        return _fan_out.merge_vjp(replies)

    def penalty(self, session_id: str, t_min: float, *, form: str = "one-sided",
                power: float = 2.0, rho: float = 50.0,
                max_missing_fraction: float = 0.5, gradient: bool = True,
                expected_generation: Optional[int] = None,
                thin_regions: bool = False, min_region_area: float = 0.0,
                max_thin_regions: int = 1000, fan_out: int = 1,
                **params: Any) -> PenaltyResult:
        """Minimum-thickness penalty (form one-sided or thesis, power n >= 1)
        or the aggregated KS constraint (form "ks", rho > 0), with its
        gradient (N, d). FailedPreconditionError when faces without values
        cover more than max_missing_fraction of the surface.

        samples="faces" (in params) integrates the face samples (each
        face's value constant on it, SPEC v2 §5c) instead of the vertex
        values interpolated linearly; the gradient stays one row per vertex.
        Welded session: the gradient's row of a session vertex is at its
        lowest-numbered uploaded vertex (zeros at the other copies), and
        thin regions' min_vertex are uploaded vertices.

        thin_regions: also PenaltyResult.thin, where the surface is thinner
        than t_min (ThinSurface; the max_thin_regions largest regions,
        1..100000; regions under min_region_area marked speck), the table
        of `meshgauge report`.

        fan_out=K (default 1): the fanned-out sdf of the same params (K
        ranges at once) gives every sample's value, then K ComputePenalty
        range calls at once, each with its range and every value (and the
        sdf's generation as expected_generation), merged: the value,
        missing counts, sdf_min and thin regions of the range at 0,
        world_frame_vertices summed, each gradient value the exact sum of
        the ranges' partial sums rounded once, plus the measure part: the
        same result as one call, bit for bit (reused_hits: whether every
        range reused its pass). AbortedError when the session moved
        between the ranges. Each range call carries x-meshgauge-range and
        x-meshgauge-part, as vjp's."""
        fan_out = _fan_out.check_fan_out(fan_out)
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
        if fan_out > 1:
            resp = self._penalty_ranges(session_id, req, fan_out)
        else:
            resp = self._call(self._stub.ComputePenalty, req, session_id)
        result = _wire.penalty(resp, self._dim(session_id), form, t,
                               thin_regions)
        m = self._welds.get(session_id)
        if m is None:
            return result
        thin = result.thin
        if thin is not None:
            thin = dataclasses.replace(
                thin, min_vertex=_weld.uploaded_vertex(thin.min_vertex, m),
                regions=[dataclasses.replace(
                    r, min_vertex=_weld.uploaded_vertex(r.min_vertex, m))
                    for r in thin.regions])
        return dataclasses.replace(
            result, thin=thin, gradient=None if result.gradient is None
            else _weld.scatter_gradient(result.gradient, m))

    def _penalty_ranges(self, session_id: str, req: Any,
                        fan_out: int) -> Any:
        """The fanned-out ComputePenalty of `req` (a whole call's request):
        the fanned-out ComputeSdf's values, then one call per range at
        once, each with every value, merged into the whole call's reply."""
        expected = (req.expected_generation
                    if req.HasField("expected_generation") else None)
        passes = self._sdf_range_replies(session_id, req.params, False,
                                         expected, fan_out)
        if not passes:  # no sample: the whole call's reply.
            return self._call(self._stub.ComputePenalty, req, session_id)
        values, generation = _fan_out.sample_values(passes)
        whole = pb.ComputePenaltyRequest()
        whole.CopyFrom(req)
        whole.values.extend(values)
        # The values' generation: a session moved since is ABORTED.
        whole.expected_generation = generation
        ranges = [(p.first, p.first + len(p.values)) for p in passes]

        def call(part: int) -> Any:
            begin, end = ranges[part]
            part_req = pb.ComputePenaltyRequest()
            part_req.CopyFrom(whole)
            part_req.range.begin = begin
            part_req.range.end = end
            return self._call(
                self._stub.ComputePenalty, part_req, session_id,
                extra_metadata=_fan_out.range_metadata(part, begin, end))

        with concurrent.futures.ThreadPoolExecutor(len(ranges)) as pool:
            replies = list(pool.map(call, range(len(ranges))))
        d, nv = self._shape(session_id)
        return _fan_out.merge_penalty(replies, req.with_gradient, d * nv)

    def constraint(self, session_id: str, t_min: float, *, rho: float = 50.0,
                   **kwargs: Any) -> PenaltyResult:
        """The aggregated constraint G (penalty with form "ks"): bound it by
        0 in the optimiser. samples="faces" aggregates the face samples.

        G <= 0 is an area mean: it still allows the thinnest spot to be
        thinner than t_min by up to t_min ln(1/a)/rho, a the thin spot's
        share of the surface (rho = 50, one face of 400: 12 %). For a
        margin that holds, constrain at ks_t_min(t_min, rho, a_min) (module
        meshgauge_client.thickness; with face samples every face's value is
        then >= t_min), or check the result with
        Session.check_thickness(t_min) and raise t_min by its ratio."""
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
        m = self._welds.get(session_id)
        if vertices is not None:
            listed = _wire._indices(np.asarray(vertices).ravel(), "vertices")
            if listed.size > 1000:
                raise ValueError("at most 1000 vertices, got "
                                 f"{listed.size}")
            req.vertices.extend([int(v) for v in listed] if m is None
                                else _weld.session_vertices(listed, m))
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
        if m is None:
            return result
        weld = m
        vertex_rows = req.params.samples != pb.SAMPLE_SET_FACES

        def row(r: Any) -> Any:
            return dataclasses.replace(
                r, vertex=_weld.uploaded_vertex(r.vertex, weld),
                row=_weld.uploaded_vertex(r.row, weld) if vertex_rows
                else r.row)

        return dataclasses.replace(
            result, rows=[row(r) for r in result.rows],
            penalty_rows=[row(r) for r in result.penalty_rows],
            vjp_rows=[row(r) for r in result.vjp_rows])


__all__ = ["MeshGaugeClient", "MeshGaugeError", "mesh_crc32", "SESSION_KEY"]
