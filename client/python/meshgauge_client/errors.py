"""Exceptions: a failed call is a MeshGaugeError subclass per gRPC status,
keeping the code and the server's message."""

from typing import Dict, Type

import grpc


class MissingValuesWarning(UserWarning):
    """Some vertices have no SDF value: the message names the component and
    the likely cause (inward faces, an open or flat sheet, ...)."""


class MeshGaugeError(RuntimeError):
    """A failed call: ``code`` is the grpc.StatusCode, ``details`` the
    server's message."""

    code: grpc.StatusCode

    def __init__(self, code: grpc.StatusCode, details: str) -> None:
        super().__init__(f"{code.name}: {details}")
        self.code = code
        self.details = details


class CancelledError(MeshGaugeError):
    pass


class UnknownError(MeshGaugeError):
    pass


class InvalidArgumentError(MeshGaugeError):
    pass


class DeadlineExceededError(MeshGaugeError):
    pass


class NotFoundError(MeshGaugeError):
    pass


class AlreadyExistsError(MeshGaugeError):
    pass


class PermissionDeniedError(MeshGaugeError):
    pass


class ResourceExhaustedError(MeshGaugeError):
    pass


class FailedPreconditionError(MeshGaugeError):
    pass


class AbortedError(MeshGaugeError):
    pass


class OutOfRangeError(MeshGaugeError):
    pass


class UnimplementedError(MeshGaugeError):
    pass


class InternalError(MeshGaugeError):
    pass


class UnavailableError(MeshGaugeError):
    pass


class DataLossError(MeshGaugeError):
    pass


class UnauthenticatedError(MeshGaugeError):
    pass


class SessionClosedError(MeshGaugeError):
    """A Session used after close() (or after its ``with`` block): it is
    deleted on the server and is never re-created (code
    FAILED_PRECONDITION; no call was made)."""

    def __init__(self, session_id: str) -> None:
        super().__init__(grpc.StatusCode.FAILED_PRECONDITION,
                         f"session {session_id} is closed")
        self.session_id = session_id


_BY_CODE: Dict[grpc.StatusCode, Type[MeshGaugeError]] = {
    grpc.StatusCode.CANCELLED: CancelledError,
    grpc.StatusCode.UNKNOWN: UnknownError,
    grpc.StatusCode.INVALID_ARGUMENT: InvalidArgumentError,
    grpc.StatusCode.DEADLINE_EXCEEDED: DeadlineExceededError,
    grpc.StatusCode.NOT_FOUND: NotFoundError,
    grpc.StatusCode.ALREADY_EXISTS: AlreadyExistsError,
    grpc.StatusCode.PERMISSION_DENIED: PermissionDeniedError,
    grpc.StatusCode.RESOURCE_EXHAUSTED: ResourceExhaustedError,
    grpc.StatusCode.FAILED_PRECONDITION: FailedPreconditionError,
    grpc.StatusCode.ABORTED: AbortedError,
    grpc.StatusCode.OUT_OF_RANGE: OutOfRangeError,
    grpc.StatusCode.UNIMPLEMENTED: UnimplementedError,
    grpc.StatusCode.INTERNAL: InternalError,
    grpc.StatusCode.UNAVAILABLE: UnavailableError,
    grpc.StatusCode.DATA_LOSS: DataLossError,
    grpc.StatusCode.UNAUTHENTICATED: UnauthenticatedError,
}


def from_rpc_error(error: grpc.RpcError) -> MeshGaugeError:
    """The MeshGaugeError subclass of a grpc.RpcError's status."""
    code = error.code()
    return _BY_CODE.get(code, MeshGaugeError)(code, error.details() or "")
