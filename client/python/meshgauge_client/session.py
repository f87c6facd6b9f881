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
exit; a closed Session refuses every call (SessionClosedError) rather than
re-create itself.

A welded session (weld=...) speaks the uploaded vertices' indexing:
positions, values and gradients have one row per uploaded vertex (see
meshgauge_client._weld).
"""

import contextlib
import os
from typing import (TYPE_CHECKING, Any, Callable, Dict, Optional, Sequence,
                    Tuple, TypeVar)

import scipy.sparse

from meshgauge_client import _weld, _wire, thickness
from meshgauge_client.errors import NotFoundError, SessionClosedError
from meshgauge_client.results import (Calibration, FloatArray,
                                      GradCheckReport, PenaltyResult,
                                      SdfResult, SessionInfo, ThicknessCheck)

if TYPE_CHECKING:  # client.py imports this module: no import back.
    from meshgauge_client.client import MeshGaugeClient

T = TypeVar("T")


class Session:
    """A server-side session (see the module docstring). Made by
    MeshGaugeClient.session() or session_from_file(): `create(session_id)`
    uploads the mesh (again when the server lost it); `mesh` is its
    (vertices, faces) as the caller gave them (the uploaded vertices), or
    None to ask the server (GetMesh) once it is created.

    After close() (or the end of its ``with`` block) every call raises
    SessionClosedError; positions and faces stay readable."""

    def __init__(self, client: "MeshGaugeClient",
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
        self._closed = False
        if mesh is None:
            try:
                data = client.mesh(self.session_id)
            except Exception:
                with contextlib.suppress(Exception):
                    self.close()
                raise
            mesh = (data.vertices, data.faces)
            weld = client.weld_map(self.session_id)
            if weld is not None:  # the server's mesh in the upload's indexing.
                mesh = _weld.uploaded_mesh(mesh[0], mesh[1], weld)
        self._original = mesh[0].copy()
        self._faces = list(mesh[1])
        self._positions = self._original.copy()
        self._moved = False

    def __enter__(self) -> "Session":
        self._check_open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def closed(self) -> bool:
        return self._closed

    def _check_open(self) -> None:
        if self._closed:
            raise SessionClosedError(self.session_id)

    def close(self) -> None:
        """Deletes the session (a session the server already lost is fine;
        closing again does nothing). Any later call raises
        SessionClosedError."""
        if self._closed:
            return
        self._closed = True
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
        self._check_open()
        try:
            return call()
        except NotFoundError:
            self._recreate()
            return call()

    def update(self, positions: Any) -> int:
        """Moves every vertex to positions (N, d); returns the generation.
        Welded: one row per uploaded vertex; each session vertex takes its
        lowest-numbered copy's."""
        self._check_open()
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
        """SdfResult at the latest positions (params as MeshGaugeClient.sdf,
        fan_out=K included: K ranges at once, merged bit for bit)."""
        return self._with_session(lambda: self._client.sdf(
            self.session_id, expected_generation=self.generation, **params))

    def jacobian(self, **params: Any) -> "scipy.sparse.csr_matrix":
        """dSDF/dx as a scipy.sparse.csr_matrix of shape (N, N*d)."""
        return self._with_session(lambda: self._client.sdf(
            self.session_id, expected_generation=self.generation,
            jacobian=True, **params)).jacobian

    def vjp(self, weights: Any, fan_out: int = 1, **params: Any) -> FloatArray:
        """g^T dSDF/dx, (N, d); fan_out as MeshGaugeClient.vjp."""
        return self._with_session(lambda: self._client.vjp(
            self.session_id, weights, expected_generation=self.generation,
            fan_out=fan_out, **params))

    def penalty(self, t_min: float, **kwargs: Any) -> PenaltyResult:
        """MeshGaugeClient.penalty at the latest positions (fan_out=K
        included: the fanned-out pass, then K penalty ranges at once,
        merged bit for bit)."""
        return self._with_session(lambda: self._client.penalty(
            self.session_id, t_min, expected_generation=self.generation,
            **kwargs))

    def report(self, path: "str | os.PathLike[str]", t_min: float, *,
               min_region_area: float = 0.0,
               color_range: Optional[Sequence[float]] = None,
               up: str = "z", cli: Optional[str] = None,
               **params: Any) -> Dict[str, Any]:
        """Writes `meshgauge report`'s page of this iteration into the
        directory `path` (made if needed) and returns report.json's object;
        numbers from the server (the SDF, the thin regions), params as sdf
        (rays, samples, ...). With the meshgauge CLI (`cli`, else
        $MESHGAUGE_CLI, else `meshgauge` on PATH) it runs `meshgauge remote
        report --session-id` on the session: the same page as the CLI's,
        pictures included. Without one (cli=""), the page has the
        interactive view, the bands and the thin-region table but no
        pictures. See meshgauge_client.report and docs/report.md."""
        self._check_open()
        from meshgauge_client import report as _report
        return _report.write(self, path, t_min,
                             min_region_area=min_region_area,
                             color_range=color_range, up=up, cli=cli,
                             **params)

    def constraint(self, t_min: float, rho: float = 50.0,
                   **kwargs: Any) -> PenaltyResult:
        """The aggregated KS constraint G (bound it by 0) and dG/dx;
        samples="faces" aggregates the face samples (the gradient stays per
        vertex).

        G <= 0 still allows spots thinner than t_min by up to
        t_min ln(1/a)/rho (a: the spot's share of the surface; 12 % with
        rho = 50 and one face of 400). A margin that holds: constrain at
        ks_t_min(t_min, rho) (with samples="faces", every face's value is
        then >= t_min), and check the end with check_thickness(t_min)."""
        return self.penalty(t_min, form="ks", rho=rho, **kwargs)

    def ks_t_min(self, t_min: float, rho: float = 50.0,
                 samples: str = "faces") -> float:
        """The t_min to give constraint() so that G <= 0 keeps every face
        value (samples "faces"), or the value at every quadrature point
        (samples "vertices"; vertices can still be below), >= t_min:
        t_min / (1 - ln(1/w)/rho), w the smallest point's share of the
        surface at the latest positions (thickness.ks_t_min)."""
        return thickness.ks_t_min(t_min, rho, thickness.min_weight_fraction(
            self._positions, self._faces, samples))

    def check_thickness(self, t_min: float, quantile: float = 0.0,
                        **params: Any) -> ThicknessCheck:
        """The final check of an optimisation: the SDF at the latest
        positions (params as sdf(); give the constraint's, e.g. its
        samples and method), its `quantile` (0: the minimum) against
        t_min. When not ok, multiply the constraint's t_min by .ratio and
        run the optimiser again."""
        return thickness.check(self.sdf(**params), t_min, quantile)

    def gradcheck(self, **kwargs: Any) -> GradCheckReport:
        """MeshGaugeClient.gradcheck at the latest positions."""
        return self._with_session(lambda: self._client.gradcheck(
            self.session_id, expected_generation=self.generation, **kwargs))

    def calibrate(self, t_min: float, **kwargs: Any) -> Calibration:
        return self._with_session(lambda: self._client.calibrate(
            self.session_id, t_min, **kwargs))


__all__ = ["Session"]
