"""SdfOptions: the SDF parameters of every computing call, as one typed,
frozen, validated value (the CLI's flags, SPEC §5)."""

import dataclasses
from dataclasses import dataclass
from typing import Any, Dict, Optional

from meshgauge_client import _wire


@dataclass(frozen=True)
class SdfOptions:
    """method: "cone" (Shapira et al.), "normal" (one ray along the axis:
    physical thickness) or "sphere" (the inscribed ball tangent at the vertex,
    SPEC v2 §5b); contact_angle_degrees: the sphere's contact cone
    half-angle in (0, 90); opposite_points: also return each sample's
    opposite point (SdfResult.opposite); cone_angle_degrees: full opening angle in (0, 180);
    rays: per vertex, 1..4096 (0: 100 in 3D, 32 in 2D; the server may allow
    fewer, see MeshGaugeClient.server_info); kappa >= 0: keep rays with
    |t - median| <= kappa sigma; max_distance >= 0 (0: the bounding-box
    diagonal); normals: "area" or "angle" vertex-normal weighting;
    samples: "vertices" or "faces" (each face's centroid along its own
    normal, SPEC v2 §5c; values, VJP weights and Jacobian rows are then per
    face; penalty and constraint integrate the face values, their gradient
    still per vertex).

    Invalid values raise ValueError or TypeError when the options are made.
    """

    method: str = "cone"
    cone_angle_degrees: float = 30.0
    rays: int = 0
    kappa: float = 1.0
    max_distance: float = 0.0
    normals: str = "area"
    contact_angle_degrees: float = 60.0
    opposite_points: bool = False
    samples: str = "vertices"

    def __post_init__(self) -> None:
        self.to_wire()  # validates.

    def to_wire(self) -> Any:
        """The SdfParameters message."""
        return _wire.sdf_params(self.method, self.cone_angle_degrees,
                                self.rays, self.kappa, self.max_distance,
                                self.normals, self.contact_angle_degrees,
                                self.opposite_points, self.samples)

    @staticmethod
    def of(options: Optional["SdfOptions"], params: Dict[str, Any]
           ) -> "SdfOptions":
        """`options`, or SdfOptions from keyword arguments named as its
        fields (cone_angle and contact_angle are accepted for the _degrees
        fields). TypeError
        names an unknown keyword and lists the known ones."""
        if options is not None:
            if params:
                raise TypeError("pass SdfOptions or keyword options, not both "
                                f"(got {sorted(params)})")
            if not isinstance(options, SdfOptions):
                raise TypeError("options must be an SdfOptions, got "
                                f"{type(options).__name__}")
            return options
        names = {f.name for f in dataclasses.fields(SdfOptions)}
        given = dict(params)
        for short in ("cone_angle", "contact_angle"):
            if short in given:
                given[short + "_degrees"] = given.pop(short)
        for key in given:
            if key not in names:
                raise TypeError(f"unknown SDF option {key!r}; options are "
                                f"{', '.join(sorted(names))}")
        return SdfOptions(**given)


__all__ = ["SdfOptions"]
