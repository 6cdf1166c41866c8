"""The interactive 3D view of a report: the labelled cloud, its fitted primitives, residual vectors.

Built with plotly (its JavaScript is embedded in the report, so the page works
offline).  Coordinates are shifted to a local origin and sent as float32
typed arrays (plotly's binary encoding), which keeps 300 000 points near 5 MB.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from pyheracles.report.colours import GROUND, REMAINDER, hex_colour, object_colours
from pyheracles.report.folder import CloudSample

__all__ = ["camera_figure", "primitive_lines", "residual_lines", "view3d_figure"]

Array = NDArray[np.float64]


def _num(row: Mapping[str, Any], key: str) -> float:
    try:
        v = float(row.get(key, np.nan))
    except (TypeError, ValueError):
        return float("nan")
    return v


def _unit(v: Array, default: Sequence[float]) -> Array:
    n = np.linalg.norm(v)
    return v / n if np.isfinite(n) and n > 1e-9 else np.asarray(default, float)


def _cylinder(base: Array, axis: Array, height: float, radius: float, seg: int = 24) -> Array:
    ref = np.array([1.0, 0, 0]) if abs(axis[0]) < 0.9 else np.array([0, 1.0, 0])
    u = _unit(np.cross(axis, ref), (1, 0, 0))
    v = np.cross(axis, u)
    phi = np.linspace(0, 2 * np.pi, seg + 1)
    ring = radius * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v)
    lines = [base + ring, base + height * axis + ring]
    for k in range(0, seg, seg // 4):
        lines.append(np.stack([base + ring[k], base + height * axis + ring[k]]))
    return _join(lines)


def _cuboid(centre: Array, axes: Array, size: Array) -> Array:
    h = size / 2
    c = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    p = centre + (c * h) @ axes
    edges = [
        (0, 1),
        (2, 3),
        (4, 5),
        (6, 7),
        (0, 2),
        (1, 3),
        (4, 6),
        (5, 7),
        (0, 4),
        (1, 5),
        (2, 6),
        (3, 7),
    ]
    return _join([p[list(e)] for e in edges])


def _join(lines: list[Array]) -> Array:
    out = []
    for ln in lines:
        out.append(ln)
        out.append(np.full((1, 3), np.nan))
    return np.concatenate(out) if out else np.empty((0, 3))


def primitive_lines(objects: pd.DataFrame | None, origin: Array) -> Array:
    """Wireframes of the fitted primitives of an objects table (NaN-separated polylines).

    Columns understood: columns and engaged columns (``radius_m``, ``x``, ``y``,
    ``z_min``, ``z_max``, ``axis_x/y/z``), piers (``box_length_m``,
    ``box_width_m``, ``box_height_m``), beams (``centre_x/y/z``, ``axis_x/y/z``,
    ``length_m``, ``width_m``, ``height_m``).
    """
    if objects is None or len(objects) == 0:
        return np.empty((0, 3))
    lines: list[Array] = []
    for row in objects.to_dict("records"):
        axis = _unit(
            np.array([_num(row, "axis_x"), _num(row, "axis_y"), _num(row, "axis_z")]), (0, 0, 1)
        )
        r = _num(row, "radius_m")
        if np.isfinite(r) and r > 0:
            z0, z1 = _num(row, "z_min"), _num(row, "z_max")
            base = np.array([_num(row, "x"), _num(row, "y"), z0])
            if np.all(np.isfinite(base)) and np.isfinite(z1):
                ax = axis if axis[2] > 0 else -axis
                lines.append(_cylinder(base - origin, ax, (z1 - z0) / max(ax[2], 0.2), r))
            continue
        bl = _num(row, "box_length_m")
        if np.isfinite(bl):
            c = np.array(
                [_num(row, "x"), _num(row, "y"), (_num(row, "z_min") + _num(row, "z_max")) / 2]
            )
            d = _unit(np.array([axis[0], axis[1], 0.0]), (1, 0, 0))
            axes = np.vstack([d, [-d[1], d[0], 0.0], [0, 0, 1.0]])
            size = np.array([bl, _num(row, "box_width_m"), _num(row, "box_height_m")])
            if np.all(np.isfinite(c)) and np.all(np.isfinite(size)):
                lines.append(_cuboid(c - origin, axes, size))
            continue
        length = _num(row, "length_m")
        if np.isfinite(length) and np.isfinite(_num(row, "centre_x")):
            c = np.array([_num(row, "centre_x"), _num(row, "centre_y"), _num(row, "centre_z")])
            w = _unit(np.cross([0, 0, 1.0], axis), (0, 1, 0))
            h = np.cross(axis, w)
            size = np.array([length, _num(row, "width_m"), _num(row, "height_m")])
            if np.all(np.isfinite(size)):
                lines.append(_cuboid(c - origin, np.vstack([axis, w, h]), size))
    return _join([ln for ln in lines if len(ln)]) if lines else np.empty((0, 3))


def residual_lines(
    points: Sequence[Mapping[str, Any]], origin: Array, extent_m: float
) -> tuple[Array, Array, float]:
    """Check point positions and residual vectors scaled so the largest is 5 % of the extent."""
    if not points:
        return np.empty((0, 3)), np.empty((0, 3)), 1.0
    ref = np.array([p["reference"] for p in points], float) - origin
    v = np.array([[p["vx"], p["vy"], p["vz"]] for p in points], float)
    big = float(np.nanmax(np.linalg.norm(v, axis=1))) or 1.0
    scale = 0.05 * max(extent_m, 1.0) / big
    segs = [np.stack([a, a + scale * b]) for a, b in zip(ref, v, strict=True)]
    return ref, _join(segs), scale


def view3d_figure(
    sample: CloudSample,
    labels: Mapping[int, str],
    hovers: Mapping[int, str],
    *,
    primitives: Array | None = None,
    checkpoints: Sequence[Mapping[str, Any]] = (),
) -> dict[str, Any]:
    """A plotly figure (as a JSON-able dict) of the labelled cloud.

    One trace per object (its name in the legend, its attributes on hover),
    the ground in light grey and the remainder in dark grey; fitted primitives
    as black wireframes; check points with their residual vectors in red.
    """
    import plotly.graph_objects as go

    fig = go.Figure()
    xyz = sample.xyz
    rest = (sample.instance == 0) & ~sample.ground

    def points(mask: NDArray[np.bool_], name: str, colour: str, hover: str) -> None:
        if mask.any():
            p = xyz[mask]
            fig.add_trace(
                go.Scatter3d(
                    x=p[:, 0],
                    y=p[:, 1],
                    z=p[:, 2],
                    mode="markers",
                    name=name,
                    marker={"size": 1.6, "color": colour},
                    hovertemplate=hover + "<extra></extra>",
                )
            )

    points(sample.ground, "ground", hex_colour(GROUND), "ground")
    points(rest, "remainder", hex_colour(REMAINDER), "remainder")
    ids = [int(i) for i in np.unique(sample.instance) if i > 0]
    cols = object_colours(max(ids, default=0))
    for i in ids:
        points(
            sample.instance == i,
            labels.get(i, f"object {i}"),
            hex_colour(cols[i - 1]),
            hovers.get(i, labels.get(i, f"object {i}")),
        )
    if primitives is not None and len(primitives):
        fig.add_trace(
            go.Scatter3d(
                x=primitives[:, 0],
                y=primitives[:, 1],
                z=primitives[:, 2],
                mode="lines",
                name="fitted primitives",
                line={"color": "black", "width": 3},
                hoverinfo="skip",
            )
        )
    if checkpoints:
        extent = float(np.ptp(xyz, axis=0).max()) if len(xyz) else 1.0
        pos, vec, scale = residual_lines(checkpoints, sample.origin, extent)
        fig.add_trace(
            go.Scatter3d(
                x=pos[:, 0],
                y=pos[:, 1],
                z=pos[:, 2],
                mode="markers+text",
                name="check points",
                text=[str(p["id"]) for p in checkpoints],
                marker={"size": 4, "color": "red"},
                hovertemplate="%{text}<extra></extra>",
            )
        )
        fig.add_trace(
            go.Scatter3d(
                x=vec[:, 0],
                y=vec[:, 1],
                z=vec[:, 2],
                mode="lines",
                name=f"residuals x {scale:,.0f}",
                line={"color": "red", "width": 5},
                hoverinfo="skip",
            )
        )
    fig.update_layout(
        margin={"l": 0, "r": 0, "t": 0, "b": 0},
        scene={
            "aspectmode": "data",
            "xaxis": {"title": "E - origin (m)"},
            "yaxis": {"title": "N - origin (m)"},
            "zaxis": {"title": "z (m)"},
        },
        legend={"itemsizing": "constant", "font": {"size": 11}},
        template="plotly_white",
    )
    import json

    return json.loads(fig.to_json())


def camera_figure(images: Sequence[Mapping[str, Any]]) -> dict[str, Any] | None:
    """A plotly figure of a bundle adjustment's camera stations (hover: image statistics)."""
    import json

    import plotly.graph_objects as go

    rows = [im for im in images if all(np.isfinite(_num(im, k)) for k in ("X0", "Y0", "Z0"))]
    if not rows:
        return None
    xyz = np.array([[_num(im, "X0"), _num(im, "Y0"), _num(im, "Z0")] for im in rows])
    rms = np.array([_num(im, "rms_px") for im in rows])
    text = [
        f"<b>{html_escape(str(im.get('name', im.get('id'))))}</b><br>"
        f"points: {im.get('n_points', '?')}<br>RMS: {_num(im, 'rms_px'):.3f} px<br>"
        f"coverage: {_num(im, 'coverage_rect'):.2f}"
        for im in rows
    ]
    fig = go.Figure(
        go.Scatter3d(
            x=xyz[:, 0],
            y=xyz[:, 1],
            z=xyz[:, 2],
            mode="markers+text",
            name="camera stations",
            text=[str(im.get("name", im.get("id"))) for im in rows],
            hovertext=text,
            hoverinfo="text",
            textfont={"size": 9},
            marker={
                "size": 5,
                "color": rms,
                "colorscale": "Viridis",
                "showscale": True,
                "colorbar": {"title": "image RMS (px)"},
            },
        )
    )
    fig.update_layout(
        margin={"l": 0, "r": 0, "t": 0, "b": 0},
        template="plotly_white",
        scene={"aspectmode": "data"},
    )
    return json.loads(fig.to_json())


def html_escape(text: str) -> str:
    """Escape text for plotly's HTML-like hover labels."""
    import html

    return html.escape(text)
