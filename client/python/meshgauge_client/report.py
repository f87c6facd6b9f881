"""Session.report: the interactive page of `meshgauge report` (index.html)
and its report.json, written from a session (numbers from the server; no
CLI, no pictures: those need the CLI's renderer, `meshgauge remote report
--session-id ID`).

The page is the CLI's interactive view: the same scripts (three.js bundled
by scripts/install_web_deps.sh and web/report_viewer.js, copied into this
package as meshgauge_client/web/ when it is built) reading data in the same
format as client/cli/report_viewer.cc writes; the thin regions are the
server's (ComputePenalty with thin regions), the bands computed here with
the CLI's exact formula. See docs/report.md.
"""

import base64
import html
import json
import math
import os
import shutil
import subprocess
import tempfile
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

# client/cli/report_viewer.h kMaxShownVertices.
MAX_SHOWN_VERTICES = 200000
OVERFLOW_COLOR = [236, 174, 215]
WEB_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "web")
_ASSETS = ("three.bundle.min.js", "three.LICENSE", "report_viewer.js",
           "report_viewer.html")


def _asset(name: str) -> str:
    path = os.path.join(WEB_DIR, name)
    if not os.path.exists(path):
        raise FileNotFoundError(
            f"{path} is missing: the package was built without the report "
            "page's scripts (run scripts/install_web_deps.sh, then build "
            "or install the package again)")
    with open(path, encoding="utf-8") as f:
        return f.read()


def percent(share: float) -> str:
    """client/cli/thin_summary.cc Percent."""
    text = ""
    for digits in range(3, 18):
        text = "%.*g" % (digits, 100 * share)
        if share >= 1 or text != "100":
            break
    return text


def elements(faces: Sequence[Any], values: Any, face_samples: bool
             ) -> Tuple[Any, Any, int]:
    """Triangles (0,1,2), (0,2,3) per face (segments in 2D), and the values
    shown: per vertex, or per element for face samples."""
    tris: List[List[int]] = []
    per_element: List[float] = []
    arity = 3
    for f, face in enumerate(faces):
        face = [int(v) for v in face]
        if len(face) == 2:
            arity = 2
            tris.append(face)
            per_element.append(float(values[f]) if face_samples else 0.0)
            continue
        for t in range(len(face) - 2):
            tris.append([face[0], face[t + 1], face[t + 2]])
            per_element.append(float(values[f]) if face_samples else 0.0)
    el = np.array(tris, dtype=np.int64).reshape(-1, arity)
    shown = (np.array(per_element, dtype=float) if face_samples
             else np.asarray(values, dtype=float))
    return el, shown, arity


def measures(p: Any, el: Any) -> Any:
    if el.shape[1] == 2:
        return np.linalg.norm(p[el[:, 1]] - p[el[:, 0]], axis=1)
    return 0.5 * np.linalg.norm(np.cross(p[el[:, 1]] - p[el[:, 0]],
                                         p[el[:, 2]] - p[el[:, 0]]), axis=1)


def measure_below(m: Any, v: Any, s: float) -> Any:
    """lib/core/thin_regions.cc TriangleAreaBelow (segments: linear), per
    element; v: (E, 2 or 3) corner values."""
    v = np.sort(v, axis=1)
    a, c = v[:, 0], v[:, -1]
    out = np.where(s >= c, m, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        if v.shape[1] == 2:
            mid = m * (s - a) / (c - a)
        else:
            b = v[:, 1]
            low = m * ((s - a) / (b - a)) * ((s - a) / (c - a))
            high = m - m * ((c - s) / (c - a)) * ((c - s) / (c - b))
            mid = np.where(s <= b, low, high)
    inside = (s > a) & (s < c)
    return np.where(inside, mid, np.where(s <= a, 0.0, out))


def bands(m: Any, corner_values: Any, t_min: float, total: float
          ) -> List[Dict[str, Any]]:
    """report.json `bands` (client/cli/report_command.cc Bands)."""
    valued = ~np.isnan(corner_values).any(axis=1)
    edge = t_min * 1.1
    below = float(measure_below(m[valued], corner_values[valued], t_min).sum())
    below_edge = float(
        measure_below(m[valued], corner_values[valued], edge).sum())
    rows = [("below", None, t_min, below),
            ("within", t_min, edge, below_edge - below),
            ("above", edge, None, float(m[valued].sum()) - below_edge),
            ("no value", None, None, float(m[~valued].sum()))]
    return [{"band": n, "lo": lo, "hi": hi, "area": a,
             "share": a / total if total > 0 else 0.0}
            for n, lo, hi, a in rows]


def _packed(array: Any, dtype: str) -> Dict[str, Any]:
    kind = {"f64": "<f8", "f32": "<f4", "u16": "<u2", "u32": "<u4"}[dtype]
    raw = np.ascontiguousarray(array, dtype=kind).tobytes()
    return {"dtype": dtype, "b64": base64.b64encode(raw).decode("ascii")}


def _simplified(p: Any, el: Any, shown: Any, face_samples: bool,
                limit: int) -> Tuple[Any, Any, Any]:
    """Vertex clustering, as client/cli/report_viewer.cc Simplified."""
    lo, hi = p.min(axis=0), p.max(axis=0)
    cell = max(float(np.linalg.norm(hi - lo)), 1e-300) / math.sqrt(limit)
    for _ in range(40):
        keys = np.floor((p - lo) / cell).astype(np.int64)
        _, cell_of, counts = np.unique(keys, axis=0, return_inverse=True,
                                       return_counts=True)
        cell_of = cell_of.reshape(-1)
        if len(counts) <= limit:
            break
        cell *= max(1.02, math.sqrt(len(counts) / limit))
    n = len(counts)
    q = np.zeros((n, 3))
    np.add.at(q, cell_of, p)
    q /= np.maximum(counts, 1)[:, None]
    e = cell_of[el]
    keep = np.ones(len(e), dtype=bool)
    for i in range(e.shape[1]):
        for j in range(i):
            keep &= e[:, i] != e[:, j]
    if face_samples:
        values = shown[keep]
    else:
        ok = ~np.isnan(shown)
        s = np.zeros(n)
        k = np.zeros(n)
        np.add.at(s, cell_of[ok], shown[ok])
        np.add.at(k, cell_of[ok], 1)
        with np.errstate(invalid="ignore", divide="ignore"):
            values = np.where(k > 0, s / k, np.nan)
    return q, e[keep], values


def viewer_data(positions: Any, faces: Sequence[Any], values: Any,
                face_samples: bool, report: Dict[str, Any],
                limit: int = MAX_SHOWN_VERTICES) -> Dict[str, Any]:
    """The page's data, as client/cli/report_viewer.cc ViewerData."""
    p = np.zeros((len(positions), 3))
    p[:, :np.asarray(positions).shape[1]] = positions
    el, shown, arity = elements(faces, values, face_samples)
    simplify = len(p) > limit
    if simplify:
        p, el, shown = _simplified(p, el, shown, face_samples, limit)
        lo, hi = p.min(axis=0), p.max(axis=0)
        span = np.where(hi > lo, hi - lo, 1.0)
        quant = np.rint(np.clip((p - lo) / span, 0, 1) * 65535)
        pos = _packed(quant, "u16")
        pos["box_min"], pos["box_max"] = lo.tolist(), hi.tolist()
        vals = _packed(shown, "f32")
    else:
        pos = _packed(p, "f64")
        vals = _packed(shown, "f64")
    el_packed = _packed(el, "u32")
    el_packed["arity"] = arity
    rng = report["color_range"]
    return {
        "format": 1, "t_min": report["thin"]["t_min"],
        "curve": arity == 2,
        "samples": "faces" if face_samples else "vertices",
        "up": report["parameters"]["up"],
        "color_range": {k: rng[k] for k in ("low", "high", "source",
                                            "above_color")},
        "regions": [{k: r[k] for k in ("centroid", "box_min", "box_max")}
                    for r in report["thin"]["regions"]],
        "mesh": {"vertices": len(positions), "faces": len(faces)},
        "shown": {"vertices": len(p), "elements": len(el),
                  "decimated": simplify, "quantised": simplify,
                  "limit": limit},
        "positions": pos, "elements": el_packed, "values": vals,
    }


def _band_table(rows: List[Dict[str, Any]], curve: bool) -> str:
    what = {"below": "thinner than t_min",
            "within": "within 10 % above t_min", "above": "thicker",
            "no value": "without a value"}
    out = []
    for b in rows:
        if b["band"] == "below":
            rng = "t &lt; %.6g" % b["hi"]
        elif b["band"] == "within":
            rng = "%.6g &le; t &lt; %.6g" % (b["lo"], b["hi"])
        elif b["band"] == "above":
            rng = "t &ge; %.6g" % b["lo"]
        else:
            rng = "no value"
        out.append('<tr data-band="%s"><th>%s</th><td class="range">%s</td>'
                   '<td class="area">%.6g</td><td class="share">%s %%</td>'
                   '</tr>\n' % (b["band"], what[b["band"]], rng, b["area"],
                                percent(b["share"])))
    return ('<table id="mg-bands"><tr><th>band</th><th>thickness</th><th>%s'
            '</th><th>share</th></tr>\n%s</table>\n'
            % ("length" if curve else "area", "".join(out)))


def _region_table(thin: Dict[str, Any], curve: bool) -> str:
    def pt(p: Sequence[float]) -> str:
        return "(%.6g, %.6g, %.6g)" % tuple(p)
    total = thin["total_area"]
    rows = []
    for i, r in enumerate(thin["regions"]):
        rows.append(
            '<tr data-region="%d"%s><td>%d</td><td>%.6g</td><td>%s %%</td>'
            '<td>%.6g</td><td>%s</td><td>%s</td><td>%s &ndash; %s</td>'
            '<td>%d</td><td>%s</td></tr>\n'
            % (i, ' class="speck"' if r["speck"] else "", i + 1, r["area"],
               percent(r["area"] / total if total > 0 else 0.0),
               r["min_thickness"], pt(r["min_point"]), pt(r["centroid"]),
               pt(r["box_min"]), pt(r["box_max"]), r["faces"],
               "speck" if r["speck"] else ""))
    if not rows:
        rows = ['<tr><td colspan="9">no thin region</td></tr>\n']
    return ('<table><tr><th>#</th><th>%s</th><th>share</th><th>min</th>'
            '<th>thinnest at</th><th>centroid</th><th>bounding box</th>'
            '<th>%s</th><th></th></tr>\n%s</table>\n'
            % ("length" if curve else "area", "segments" if curve else "faces",
               "".join(rows)))


def page(report: Dict[str, Any], data: Dict[str, Any]) -> str:
    """index.html: the CLI's page without its pictures."""
    curve = data["curve"]
    text = json.dumps(data, separators=(",", ":")).replace("<", "\\u003c")
    params = "".join("<tr><th>%s</th><td>%s</td></tr>\n"
                     % (html.escape(k), html.escape(json.dumps(v)))
                     for k, v in report["parameters"].items())
    name = html.escape(report["mesh"])
    return "".join([
        '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        "<title>meshgauge report: ", name, "</title>\n<style>\n"
        "body{font-family:sans-serif;margin:1.5em;color:#141414}\n"
        "table{border-collapse:collapse;margin:.5em 0}\n"
        "td,th{border:1px solid #ccc;padding:.2em .5em;text-align:right}\n"
        ".kv th{text-align:left}\n.speck{color:#888}\n"
        ".answer{font-size:1.2em;font-weight:bold}\n"
        "</style>\n</head>\n<body>\n<h1>Thickness of ", name, "</h1>\n"
        '<p class="answer" id="mg-answer">', html.escape(report["sentence"]),
        "</p>\n", _asset("report_viewer.html"),
        "<h2>Thickness bands</h2>\n", _band_table(report["bands"], curve),
        "<h2>Views</h2>\n<p>Written by the Python client from session ",
        html.escape(report["session_id"]), " (generation %d): no pictures; "
        "<code>meshgauge remote report --session-id</code> draws them.</p>\n"
        % report["generation"],
        "<h2>Thin regions</h2>\n", _region_table(report["thin"], curve),
        '<h2>Parameters</h2>\n<table class="kv">\n', params, "</table>\n",
        "<script>\n/* three.js, embedded under its licence:\n",
        _asset("three.LICENSE"), "*/\n", _asset("three.bundle.min.js"),
        '\n</script>\n<script id="mg-data" type="application/json">', text,
        "</script>\n<script>\n", _asset("report_viewer.js"), "</script>\n",
        "</body>\n</html>\n"])


def sentence(thin: Any, curve: bool) -> str:
    """client/cli/thin_summary.cc ThinSentence."""
    surface, measure = ("curve", "length") if curve else ("surface", "area")
    if thin.min_vertex < 0:
        return "no vertex of the %s has a value" % surface
    share = thin.thin_area / thin.total_area if thin.total_area > 0 else 0.0
    s = ("%s %% of the %s (%s %.4g of %.4g) is thinner than %g; thinnest "
         "%.4g at (%.6g, %.6g, %.6g)"
         % (percent(share), surface, measure, thin.thin_area,
            thin.total_area, thin.t_min, thin.min_thickness, *thin.min_point))
    if thin.missing_area > 0:
        s += "; %s %% has no value" % percent(thin.missing_area /
                                             thin.total_area)
    return s


# SdfOptions' names and the CLI's flags for them (0 or None: the default).
_CLI_FLAGS = {"method": "--method", "cone_angle_degrees": "--cone-angle",
              "rays": "--rays", "kappa": "--kappa",
              "max_distance": "--max-distance", "normals": "--normals",
              "contact_angle_degrees": "--contact-angle",
              "samples": "--samples"}


def find_cli(cli: Optional[str]) -> Optional[str]:
    """The meshgauge CLI to draw the report's pictures: `cli` ("" for
    none), else $MESHGAUGE_CLI, else `meshgauge` on PATH; None when there is
    none. Its `remote` verbs run `meshgauge-remote`, which must be installed
    beside it (else the report fails with an error naming it)."""
    if cli is not None:
        return cli or None
    return os.environ.get("MESHGAUGE_CLI") or shutil.which("meshgauge")


def _write_obj(mesh: Any, path: str) -> None:
    """The session's mesh as an OBJ whose coordinates read back exactly
    (2D: `l` segments)."""
    v = np.asarray(mesh.vertices, dtype=float)
    with open(path, "w", encoding="ascii") as f:
        for p in v:
            f.write("v " + " ".join(repr(float(x)) for x in p) +
                    (" 0" if v.shape[1] == 2 else "") + "\n")
        for face in mesh.faces:
            f.write(("l " if len(face) == 2 else "f ") +
                    " ".join(str(int(i) + 1) for i in face) + "\n")


def _write_with_cli(cli: str, session: Any, path: "str | os.PathLike[str]",
                    t_min: float, min_region_area: float,
                    color_range: Optional[Sequence[float]], up: str,
                    params: Dict[str, Any]) -> Dict[str, Any]:
    """`meshgauge remote report` on the session (its current generation):
    the CLI's whole page, pictures included, from the server's numbers."""
    client = session._client
    with tempfile.TemporaryDirectory() as tmp:
        obj = os.path.join(tmp, "session.obj")
        _write_obj(client.mesh(session.session_id), obj)
        args = [cli, "remote", "--server", client.target]
        args += client.cli_tls_flags()
        args += ["report", obj, "--session-id", session.session_id,
                 "--t-min", repr(float(t_min)), "--out", os.fspath(path),
                 "--min-region-area", repr(float(min_region_area)),
                 "--up", up, "--progress", "never"]
        if color_range is not None:
            args += ["--color-range", repr(float(color_range[0])),
                     repr(float(color_range[1]))]
        for name, value in params.items():
            if name not in _CLI_FLAGS:
                raise ValueError(f"report: unknown parameter {name!r}")
            if value in (None, 0, 0.0):
                continue
            args += [_CLI_FLAGS[name], str(value)]
        env = dict(os.environ)
        if client.token:
            env["MESHGAUGE_TOKEN"] = client.token
        # A report.json left by an earlier report in `path` must not pass
        # for this run's.
        report_json = os.path.join(path, "report.json")
        if os.path.exists(report_json):
            os.remove(report_json)
        run = subprocess.run(args, capture_output=True, text=True, env=env)
        if run.returncode != 0 and not os.path.exists(report_json):
            raise RuntimeError(f"{cli} remote report failed: "
                               + (run.stdout + run.stderr).strip()[-2000:])
    with open(report_json, encoding="utf-8") as f:
        report: Dict[str, Any] = json.load(f)
    return report


def write(session: Any, path: "str | os.PathLike[str]", t_min: float,
          min_region_area: float = 0.0,
          color_range: Optional[Sequence[float]] = None, up: str = "z",
          cli: Optional[str] = None, **params: Any) -> Dict[str, Any]:
    """Session.report: see there."""
    if up not in ("y", "z"):
        raise ValueError(f"up must be 'y' or 'z', got {up!r}")
    exe = find_cli(cli)
    if exe:
        return _write_with_cli(exe, session, path, t_min, min_region_area,
                               color_range, up, params)
    face_samples = params.get("samples", "vertices") == "faces"
    values = session.sdf(**params).values
    pen = session.penalty(t_min, thin_regions=True,
                          min_region_area=min_region_area,
                          max_thin_regions=100000, gradient=False,
                          max_missing_fraction=1.0, **params)
    thin = pen.thin
    positions = np.asarray(session.positions, dtype=float)
    faces = session.faces
    el, shown, arity = elements(faces, values, face_samples)
    p3 = np.zeros((len(positions), 3))
    p3[:, :positions.shape[1]] = positions
    m = measures(p3, el)
    corners = (np.repeat(shown[:, None], arity, axis=1) if face_samples
               else shown[el])
    if color_range is None:
        rng = {"low": 0.0, "high": 2 * t_min, "source": "default",
               "above_label": "> 2 T_MIN"}
    else:
        lo, hi = float(color_range[0]), float(color_range[1])
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ValueError(f"color_range: lo < hi, both finite, got {lo} {hi}")
        rng = {"low": lo, "high": hi, "source": "--color-range",
               "above_label": "> %.4g" % hi}
    rng["above_color"] = OVERFLOW_COLOR
    regions = [{"faces": r.faces, "area": r.area,
                "min_thickness": r.min_thickness, "min_vertex": r.min_vertex,
                "min_point": list(r.min_point), "centroid": list(r.centroid),
                "box_min": list(r.box_min), "box_max": list(r.box_max),
                "speck": r.speck} for r in thin.regions]
    curve = arity == 2
    report: Dict[str, Any] = {
        "mesh": "session %s" % session.session_id,
        "session_id": session.session_id,
        "generation": session.generation,
        "sentence": sentence(thin, curve),
        "parameters": dict({"t_min": t_min,
                            "min_region_area": min_region_area,
                            "color_range": [rng["low"], rng["high"]],
                            "up": up}, **params),
        "color_range": rng,
        "thin": {"t_min": thin.t_min, "total_area": thin.total_area,
                 "thin_area": thin.thin_area,
                 "missing_area": thin.missing_area,
                 "thin_fraction": thin.thin_fraction,
                 "thinnest": None if thin.min_vertex < 0 else {
                     "value": thin.min_thickness, "vertex": thin.min_vertex,
                     "point": list(thin.min_point)},
                 "regions": regions},
        "bands": bands(m, corners, t_min, thin.total_area),
    }
    os.makedirs(path, exist_ok=True)
    data = viewer_data(positions, faces, values, face_samples, report)
    with open(os.path.join(path, "index.html"), "w", encoding="utf-8") as f:
        f.write(page(report, data))
    with open(os.path.join(path, "report.json"), "w", encoding="utf-8") as f:
        json.dump(report, f, indent=2)
        f.write("\n")
    return report
