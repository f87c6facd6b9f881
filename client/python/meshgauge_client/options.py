"""SdfOptions: the SDF parameters of every computing call, as one typed,
frozen, validated value (the CLI's flags, SPEC §5)."""

import dataclasses
from dataclasses import dataclass
from typing import Any, Dict, Optional

from meshgauge_client import _wire


@dataclass(frozen=True)
class SdfOptions:
    """method: "cone" (Shapira et al.) or "normal" (one ray along the axis:
    physical thickness); cone_angle_degrees: full opening angle in (0, 180);
    rays: per vertex, 1..4096 (0: 100 in 3D, 32 in 2D; the server may allow
    fewer, see MeshGaugeClient.server_info); kappa >= 0: keep rays with
    |t - median| <= kappa sigma; max_distance >= 0 (0: the bounding-box
    diagonal); normals: "area" or "angle" vertex-normal weighting.

    Invalid values raise ValueError or TypeError when the options are made.
    """

    method: str = "cone"
    cone_angle_degrees: float = 30.0
    rays: int = 0
    kappa: float = 1.0
    max_distance: float = 0.0
    normals: str = "area"

    def __post_init__(self) -> None:
        self.to_wire()  # validates.

    def to_wire(self) -> Any:
        """The SdfParameters message."""
        return _wire.sdf_params(self.method, self.cone_angle_degrees,
                                self.rays, self.kappa, self.max_distance,
                                self.normals)

    @staticmethod
    def of(options: Optional["SdfOptions"], params: Dict[str, Any]
           ) -> "SdfOptions":
        """`options`, or SdfOptions from keyword arguments named as its
        fields (cone_angle is accepted for cone_angle_degrees). TypeError
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
        if "cone_angle" in given:
            given["cone_angle_degrees"] = given.pop("cone_angle")
        for key in given:
            if key not in names:
                raise TypeError(f"unknown SDF option {key!r}; options are "
                                f"{', '.join(sorted(names))}")
        return SdfOptions(**given)


__all__ = ["SdfOptions"]
