"""Session: one mesh on the server, as an optimiser uses it.

    with client.session(vertices, faces) as s:
        s.update(x)                 # a BVH refit on the server
        g = s.penalty(t_min).gradient
        G = s.constraint(t_min)     # the KS constraint, bound by 0

It tracks the generation, keeps the original mesh and the latest positions,
and when the server lost the session (restarted, evicted) it re-creates it
transparently: re-upload the original mesh, re-apply the latest positions
(so results stay bit-identical to an undisturbed run), and retry the call.
UNAVAILABLE is retried with backoff by the client. The session is deleted on
exit.
"""

import contextlib
from typing import Any, Callable, Optional, Tuple, TypeVar

import scipy.sparse

from meshgauge_client import _wire
from meshgauge_client.client import MeshGaugeClient
from meshgauge_client.errors import NotFoundError
from meshgauge_client.results import (Calibration, FloatArray,
                                      GradCheckReport, PenaltyResult,
                                      SdfResult, SessionInfo)

T = TypeVar("T")


class Session:
    """A server-side session (see the module docstring). Made by
    MeshGaugeClient.session() or session_from_file(): `create(session_id)`
    uploads the mesh (again when the server lost it); `mesh` is its
    (vertices, faces) as the server holds them, or None to ask the server
    (GetMesh) once it is created."""

    def __init__(self, client: MeshGaugeClient,
                 create: Callable[[Optional[str]], SessionInfo],
                 session_id: Optional[str] = None,
                 mesh: Optional[Tuple[FloatArray, "list[Any]"]] = None
                 ) -> None:
        self._client = client
        self._create = create
        info = create(session_id)
        self.session_id = info.session_id
        self.generation = info.generation
        # What the reader, the repairs and the diagnostics said at upload.
        self.warnings: Tuple[str, ...] = info.warnings
        self.recreated = 0  # how often the server lost it and it came back.
        if mesh is None:
            try:
                data = client.mesh(self.session_id)
            except Exception:
                with contextlib.suppress(Exception):
                    self.close()
                raise
            mesh = (data.vertices, data.faces)
        self._original = mesh[0].copy()
        self._faces = list(mesh[1])
        self._positions = self._original.copy()
        self._moved = False

    def __enter__(self) -> "Session":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Deletes the session (a session the server already lost is fine)."""
        try:
            self._client.delete(self.session_id)
        except NotFoundError:
            pass

    @property
    def positions(self) -> FloatArray:
        """The latest positions (N, d): at upload, then as sent with
        update()."""
        return self._positions.copy()

    @property
    def faces(self) -> "list[Any]":
        """The faces as the server holds them (polygons triangulated, repairs
        made), as index arrays."""
        return list(self._faces)

    def _recreate(self) -> None:
        info = self._create(self.session_id)
        self.generation = info.generation
        if self._moved:
            self.generation = self._client.update_positions(
                self.session_id, self._positions, self.generation)
        self.recreated += 1

    def _with_session(self, call: Callable[[], T]) -> T:
        try:
            return call()
        except NotFoundError:
            self._recreate()
            return call()

    def update(self, positions: Any) -> int:
        """Moves every vertex to positions (N, d); returns the generation."""
        p = _wire.points(positions, "positions", len(self._original))
        if p.shape[1] != self._original.shape[1]:
            raise ValueError(f"positions must have {self._original.shape[1]} "
                             f"columns, got {p.shape[1]}")

        # The generation is read at each attempt (a re-created session has
        # its own).
        self.generation = self._with_session(
            lambda: self._client.update_positions(self.session_id, p,
                                                  self.generation))
        self._positions = p.copy()
        self._moved = True
        return self.generation

    def info(self) -> SessionInfo:
        return self._with_session(lambda: self._client.info(self.session_id))

    def sdf(self, **params: Any) -> SdfResult:
        """SdfResult at the latest positions (params as MeshGaugeClient.sdf)."""
        return self._with_session(lambda: self._client.sdf(
            self.session_id, expected_generation=self.generation, **params))

    def jacobian(self, **params: Any) -> "scipy.sparse.csr_matrix":
        """dSDF/dx as a scipy.sparse.csr_matrix of shape (N, N*d)."""
        return self._with_session(lambda: self._client.sdf(
            self.session_id, expected_generation=self.generation,
            jacobian=True, **params)).jacobian

    def vjp(self, weights: Any, **params: Any) -> FloatArray:
        """g^T dSDF/dx, (N, d)."""
        return self._with_session(lambda: self._client.vjp(
            self.session_id, weights, expected_generation=self.generation,
            **params))

    def penalty(self, t_min: float, **kwargs: Any) -> PenaltyResult:
        """MeshGaugeClient.penalty at the latest positions."""
        return self._with_session(lambda: self._client.penalty(
            self.session_id, t_min, expected_generation=self.generation,
            **kwargs))

    def constraint(self, t_min: float, rho: float = 50.0,
                   **kwargs: Any) -> PenaltyResult:
        """The aggregated KS constraint G (bound it by 0) and dG/dx."""
        return self.penalty(t_min, form="ks", rho=rho, **kwargs)

    def gradcheck(self, **kwargs: Any) -> GradCheckReport:
        """MeshGaugeClient.gradcheck at the latest positions."""
        return self._with_session(lambda: self._client.gradcheck(
            self.session_id, expected_generation=self.generation, **kwargs))

    def calibrate(self, t_min: float, **kwargs: Any) -> Calibration:
        return self._with_session(lambda: self._client.calibrate(
            self.session_id, t_min, **kwargs))


__all__ = ["Session"]
