"""meshgauge-client: the Python client of the meshgauge shape-diameter
service (numpy in, numpy out). See docs/python.md.

    from meshgauge_client import MeshGaugeClient
    with MeshGaugeClient("127.0.0.1:50051") as client:
        with client.session(vertices, faces) as s:
            result = s.penalty(t_min=0.2)       # PenaltyResult
            result.value, result.gradient       # float, (N, d)
"""

from meshgauge_client.client import SESSION_KEY, MeshGaugeClient, mesh_crc32
from meshgauge_client.errors import (AbortedError, AlreadyExistsError,
                                     CancelledError, DataLossError,
                                     DeadlineExceededError,
                                     FailedPreconditionError, InternalError,
                                     InvalidArgumentError, MeshGaugeError,
                                     MissingValuesWarning,
                                     NotFoundError, OutOfRangeError,
                                     PermissionDeniedError,
                                     ResourceExhaustedError,
                                     SessionClosedError,
                                     UnauthenticatedError, UnavailableError,
                                     UnimplementedError, UnknownError)
from meshgauge_client.results import (Calibration, GradCheckReport,
                                      GradCheckRow, MeshData, PenaltyResult,
                                      SdfResult,
                                      SdfSummary, ServerInfo, SessionInfo,
                                      ThicknessCheck, ThinRegion,
                                      ThinSurface, VertexStatus)
from meshgauge_client.options import SdfOptions
from meshgauge_client.session import Session
from meshgauge_client import thickness

from meshgauge_client._version import __version__  # noqa: E402

__all__ = [
    "AbortedError", "AlreadyExistsError", "Calibration", "CancelledError",
    "DataLossError", "DeadlineExceededError", "FailedPreconditionError",
    "GradCheckReport", "GradCheckRow",
    "InternalError", "InvalidArgumentError", "MeshGaugeClient",
    "MeshData", "MeshGaugeError", "MissingValuesWarning", "NotFoundError",
    "OutOfRangeError", "PenaltyResult",
    "PermissionDeniedError", "ResourceExhaustedError", "SESSION_KEY",
    "SdfOptions", "SdfResult", "SdfSummary", "ServerInfo", "Session",
    "SessionClosedError", "SessionInfo", "ThicknessCheck",
    "ThinRegion",
    "ThinSurface",
    "UnauthenticatedError", "UnavailableError", "UnimplementedError",
    "UnknownError", "VertexStatus", "mesh_crc32", "thickness",
]
