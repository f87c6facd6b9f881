"""A thin, numpy-friendly wrapper over the meshgauge.v1 gRPC stubs.

Arrays: vertices are (N, d) float arrays (d = 2 or 3); faces are an (M, k)
int array (k = 2 segments, 3 triangles, 4 quads) or a list of index
sequences. Every call of a session sends the metadata key
``x-meshgauge-session`` (the routing key of a session-affine balancer).
"""

import os
import zlib

import grpc
import numpy as np

from meshgauge.v1 import meshgauge_pb2 as pb
from meshgauge.v1 import meshgauge_pb2_grpc as pb_grpc

SESSION_KEY = "x-meshgauge-session"


class MeshGaugeError(RuntimeError):
    """A failed call: ``code`` is the grpc.StatusCode, ``details`` the message."""

    def __init__(self, code, details):
        super().__init__(f"{code.name}: {details}")
        self.code = code
        self.details = details


def _faces_to_lists(faces):
    if isinstance(faces, np.ndarray):
        return [np.asarray(f, dtype=np.int64) for f in faces]
    return [np.asarray(f, dtype=np.int64) for f in faces]


def mesh_crc32(vertices, faces, regions=None):
    """CRC-32 of a mesh in the upload footer's canonical order."""
    v = np.ascontiguousarray(vertices, dtype="<f8")
    faces = _faces_to_lists(faces)
    sizes = np.array([len(f) for f in faces], dtype="<i4")
    indices = (np.concatenate(faces).astype("<i4") if faces
               else np.zeros(0, "<i4"))
    crc = zlib.crc32(v.tobytes())
    crc = zlib.crc32(sizes.tobytes(), crc)
    crc = zlib.crc32(indices.tobytes(), crc)
    if regions is not None:
        crc = zlib.crc32(np.asarray(regions, dtype="<i4").tobytes(), crc)
    return crc & 0xFFFFFFFF


def _params(method="cone", cone_angle=0.0, rays=0, kappa=None,
            max_distance=0.0, normals="area"):
    p = pb.SdfParameters(
        method={"cone": pb.SDF_METHOD_CONE,
                "normal": pb.SDF_METHOD_NORMAL_RAY}[method],
        cone_angle_degrees=cone_angle, rays=rays, max_distance=max_distance,
        normal_weighting={"area": pb.NORMAL_WEIGHTING_AREA,
                          "angle": pb.NORMAL_WEIGHTING_ANGLE}[normals])
    if kappa is not None:
        p.kappa = kappa
    return p


def _read(path):
    with open(path, "rb") as f:
        return f.read()


class MeshGaugeClient:
    """Client of one meshgauge server (``target`` = "host:port").

    ``token`` is sent as ``authorization: Bearer <token>`` on every call
    (default: the MESHGAUGE_TOKEN environment variable). With ``tls_ca_file``
    the channel is TLS, trusting that PEM CA; ``tls_cert_file`` and
    ``tls_key_file`` add a client certificate (mutual TLS)."""

    def __init__(self, target, token=None, deadline=600.0,
                 max_message_bytes=256 << 20, chunk=65536, tls_ca_file=None,
                 tls_cert_file=None, tls_key_file=None):
        options = [("grpc.max_send_message_length", max_message_bytes),
                   ("grpc.max_receive_message_length", max_message_bytes)]
        if (tls_cert_file or tls_key_file) and not tls_ca_file:
            raise ValueError("tls_cert_file/tls_key_file need tls_ca_file")
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
        self._dims = {}

    def close(self):
        self._channel.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _metadata(self, session_id=""):
        return ([(SESSION_KEY, session_id)] if session_id else []) + self._auth

    def _call(self, method, request, session_id=""):
        metadata = self._metadata(session_id)
        try:
            return method(request, timeout=self._deadline, metadata=metadata)
        except grpc.RpcError as e:
            raise MeshGaugeError(e.code(), e.details()) from None

    def _dim(self, session_id):
        if session_id not in self._dims:
            self._dims[session_id] = self.info(session_id).dimension
        return self._dims[session_id]

    # Sessions -------------------------------------------------------------

    def upload(self, vertices, faces, session_id="", regions=None,
               outward_regions=()):
        """Creates a session; returns its SessionInfo (``.session_id``)."""
        vertices = np.asarray(vertices, dtype=np.float64)
        dim = vertices.shape[1]
        faces = _faces_to_lists(faces)
        header = pb.CreateSessionRequest.Header(
            session_id=session_id, dimension=dim,
            num_vertices=len(vertices), num_faces=len(faces),
            region_directions=[
                pb.RegionDirection(region=r,
                                   direction=pb.CONE_DIRECTION_OUTWARD)
                for r in outward_regions])

        def requests():
            yield pb.CreateSessionRequest(header=header)
            n = max(len(vertices), len(faces))
            for b in range(0, n, self._chunk):
                fs = faces[b:b + self._chunk]
                chunk = pb.CreateSessionRequest.Chunk(
                    positions=vertices[b:b + self._chunk].ravel(),
                    face_sizes=[len(f) for f in fs],
                    face_indices=(np.concatenate(fs) if fs else []))
                if regions is not None:
                    chunk.face_regions.extend(regions[b:b + self._chunk])
                yield pb.CreateSessionRequest(chunk=chunk)
            yield pb.CreateSessionRequest(footer=pb.CreateSessionRequest.Footer(
                num_vertices=len(vertices), num_faces=len(faces),
                crc32=mesh_crc32(vertices, faces, regions)))

        info = self._call(self._stub.CreateSession, requests(),
                          session_id).session
        self._dims[info.session_id] = dim
        return info

    def info(self, session_id):
        return self._call(self._stub.GetSession,
                          pb.GetSessionRequest(session_id=session_id),
                          session_id).session

    def list(self, page_size=100):
        out, token = [], ""
        while True:
            resp = self._call(self._stub.ListSessions, pb.ListSessionsRequest(
                page_size=page_size, page_token=token))
            out.extend(resp.sessions)
            token = resp.next_page_token
            if not token:
                return out

    def delete(self, session_id):
        self._call(self._stub.DeleteSession,
                   pb.DeleteSessionRequest(session_id=session_id), session_id)
        self._dims.pop(session_id, None)

    def update_positions(self, session_id, positions, expected_generation,
                         indices=None):
        """Moves all vertices (or ``indices``); returns the new generation."""
        positions = np.asarray(positions, dtype=np.float64)
        req = pb.UpdatePositionsRequest(
            session_id=session_id, expected_generation=expected_generation,
            positions=positions.ravel())
        if indices is not None:
            req.indices.extend(int(i) for i in indices)
        return self._call(self._stub.UpdatePositions, req,
                          session_id).generation

    # Computations ---------------------------------------------------------

    def sdf(self, session_id, expected_generation=None, **params):
        """Per-vertex SDF: dict with values (NaN without value), status,
        hits, kept, normalized (arrays) and summary (SdfSummary)."""
        req = pb.ComputeSdfRequest(session_id=session_id,
                                   params=_params(**params))
        if expected_generation is not None:
            req.expected_generation = expected_generation
        values, status, hits, kept, normalized, summary = [], [], [], [], [], None
        metadata = self._metadata(session_id)
        try:
            for msg in self._stub.ComputeSdf(req, timeout=self._deadline,
                                             metadata=metadata):
                if msg.HasField("summary"):
                    summary = msg.summary
                    continue
                c = msg.chunk
                values.extend(c.values)
                status.extend(c.status)
                hits.extend(c.hits)
                kept.extend(c.kept)
                normalized.extend(c.normalized)
        except grpc.RpcError as e:
            raise MeshGaugeError(e.code(), e.details()) from None
        return {"values": np.array(values), "status": np.array(status),
                "hits": np.array(hits), "kept": np.array(kept),
                "normalized": np.array(normalized), "summary": summary}

    def vjp(self, session_id, weights, expected_generation=None, **params):
        """g^T dSDF/dx as an (N, d) array."""
        req = pb.ComputeVjpRequest(session_id=session_id,
                                   params=_params(**params),
                                   weights=np.asarray(weights, np.float64))
        if expected_generation is not None:
            req.expected_generation = expected_generation
        resp = self._call(self._stub.ComputeVjp, req, session_id)
        return np.array(resp.gradient).reshape(-1, self._dim(session_id))

    _FORMS = {"one-sided": pb.PENALTY_FORM_ONE_SIDED,
              "thesis": pb.PENALTY_FORM_THESIS,
              "ks": pb.PENALTY_FORM_KS}

    def penalty(self, session_id, t_min, form="one-sided", power=2.0,
                rho=50.0, max_missing_fraction=0.5, with_gradient=True,
                expected_generation=None, **params):
        """Penalty P (form one-sided or thesis, power n) or the aggregated
        KS constraint G (form "ks", rho), SPEC v2 §7.

        Returns (value, d value/dx as an (N, d) array or None,
        ComputePenaltyResponse with missing and world_frame_vertices).
        Raises MeshGaugeError FAILED_PRECONDITION when faces without values
        cover more than max_missing_fraction of the surface."""
        if form not in self._FORMS:
            raise ValueError("form must be one of %s, got %r"
                             % (sorted(self._FORMS), form))
        req = pb.ComputePenaltyRequest(
            session_id=session_id, params=_params(**params), t_min=t_min,
            form=self._FORMS[form], power=power, rho=rho,
            max_missing_fraction=max_missing_fraction,
            with_gradient=with_gradient)
        if expected_generation is not None:
            req.expected_generation = expected_generation
        resp = self._call(self._stub.ComputePenalty, req, session_id)
        grad = (np.array(resp.gradient).reshape(-1, self._dim(session_id))
                if with_gradient else None)
        return resp.value, grad, resp

    def calibrate(self, session_id, t_min, equal_tolerance=0.0, bins=0,
                  **params):
        return self._call(self._stub.Calibrate, pb.CalibrateRequest(
            session_id=session_id, params=_params(**params), t_min=t_min,
            equal_tolerance=equal_tolerance, bins=bins), session_id)
