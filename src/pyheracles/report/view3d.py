"""The interactive 3D view of a report: what the page's WebGL viewer draws.

The viewer (``templates/view3d.js.j2``) is hand-written: plotly's scatter3d builds
JavaScript objects per point and took ~50 s to draw 300 000 points in headless
Chromium without a GPU.  This module prepares the data it reads, as compact as
a browser can take it: the points as one base64 Float32 array of positions
relative to a local origin, sorted so that each legend entry (the ground, the
remainder, every object) is one contiguous range; a colour, a class and the
attributes per entry; and overlays drawn over the points: wireframes of the
fitted primitives (cylinders, boxes, cuboids), translucent surfaces (walls,
roofs), residual vectors of check and tie points, camera stations.
"""

from __future__ import annotations

import base64
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from pyheracles.report.colours import GROUND, REMAINDER, hex_colour, object_colours
from pyheracles.report.folder import CloudSample, RunFolder
from pyheracles.report.surfaces import SurfaceSet

__all__ = [
    "b64",
    "camera_overlays",
    "folder_scene",
    "object_points",
    "polyline_segments",
    "primitive_lines",
    "residual_overlays",
    "surface_overlays",
    "view3d_scene",
]

Array = NDArray[np.float64]

#: Colours of classes (object classes of a step), in order of first appearance.
CLASS_PALETTE = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#bcbd22",
    "#17becf",
    "#393b79",
)


def b64(a: NDArray[Any], dtype: Any = np.float32) -> str:
    """Base64 of an array's bytes as ``dtype`` (little-endian, as typed arrays read them)."""
    return base64.b64encode(
        np.ascontiguousarray(a, dtype=np.dtype(dtype).newbyteorder("<")).tobytes()
    ).decode("ascii")


def _num(row: Mapping[str, Any], key: str) -> float:
    try:
        return float(row.get(key, np.nan))
    except (TypeError, ValueError):
        return float("nan")


def _unit(v: Array, default: Sequence[float]) -> Array:
    n = np.linalg.norm(v)
    return v / n if np.isfinite(n) and n > 1e-9 else np.asarray(default, float)


def _cylinder(base: Array, axis: Array, height: float, radius: float, seg: int = 24) -> list[Array]:
    ref = np.array([1.0, 0, 0]) if abs(axis[0]) < 0.9 else np.array([0, 1.0, 0])
    u = _unit(np.cross(axis, ref), (1, 0, 0))
    v = np.cross(axis, u)
    phi = np.linspace(0, 2 * np.pi, seg + 1)
    ring = radius * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v)
    lines = [base + ring, base + height * axis + ring]
    for k in range(0, seg, seg // 4):
        lines.append(np.stack([base + ring[k], base + height * axis + ring[k]]))
    return lines


_BOX_EDGES = (
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
)


def _cuboid(centre: Array, axes: Array, size: Array) -> list[Array]:
    c = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    p = centre + (c * size / 2) @ axes
    return [p[list(e)] for e in _BOX_EDGES]


def polyline_segments(lines: Sequence[Array]) -> Array:
    """``(2m, 3)`` segment ends (GL_LINES) of polylines."""
    segs = [np.stack([ln[:-1], ln[1:]], axis=1).reshape(-1, 3) for ln in lines if len(ln) >= 2]
    return np.concatenate(segs) if segs else np.empty((0, 3))


def primitive_lines(objects: pd.DataFrame | None, origin: Array) -> Array:
    """Wireframes of the fitted primitives of an objects table, as ``(2m, 3)`` segment ends.

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
                lines += _cylinder(base - origin, ax, (z1 - z0) / max(ax[2], 0.2), r)
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
                lines += _cuboid(c - origin, axes, size)
            continue
        length = _num(row, "length_m")
        if np.isfinite(length) and np.isfinite(_num(row, "centre_x")):
            c = np.array([_num(row, "centre_x"), _num(row, "centre_y"), _num(row, "centre_z")])
            w = _unit(np.cross([0, 0, 1.0], axis), (0, 1, 0))
            h = np.cross(axis, w)
            size = np.array([length, _num(row, "width_m"), _num(row, "height_m")])
            if np.all(np.isfinite(size)) and np.all(np.isfinite(c)):
                lines += _cuboid(c - origin, np.vstack([axis, w, h]), size)
    return polyline_segments(lines)


def _ramp(values: NDArray[np.float64]) -> NDArray[np.uint8]:
    """Viridis-like colours (RGB 0-255) of values, low = dark blue, high = yellow."""
    stops = np.array(
        [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]], float
    )
    v = np.asarray(values, float)
    lo, hi = np.nanmin(v), np.nanmax(v)
    t = np.zeros_like(v) if not np.isfinite(hi - lo) or hi <= lo else (v - lo) / (hi - lo)
    t = np.nan_to_num(t) * (len(stops) - 1)
    k = np.clip(np.floor(t).astype(int), 0, len(stops) - 2)
    f = (t - k)[:, None]
    return np.round(stops[k] * (1 - f) + stops[k + 1] * f).astype(np.uint8)


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return "NaN" if not np.isfinite(v) else f"{v:.4g}"
    return str(v)


def residual_overlays(
    name: str,
    xyz: Array,
    v: Array,
    ids: Sequence[str],
    origin: Array,
    extent_m: float,
    *,
    outlier: NDArray[np.bool_] | None = None,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Points with residual vectors: markers (labelled, pickable) and the vectors as lines.

    The vectors are scaled so that the largest is 5 % of the scene's extent; the
    scale is in the legend entry.  Outliers (when given) are drawn in magenta.
    """
    xyz = np.asarray(xyz, float).reshape(-1, 3)
    v = np.asarray(v, float).reshape(-1, 3)
    ok = np.all(np.isfinite(xyz), axis=1)
    xyz, v, ids = xyz[ok], np.nan_to_num(v[ok]), [i for i, k in zip(ids, ok, strict=True) if k]
    out = np.zeros(len(xyz), bool) if outlier is None else np.asarray(outlier, bool)[ok]
    if not len(xyz):
        return [], []
    big = float(np.max(np.linalg.norm(v, axis=1))) or 1.0
    scale = 0.05 * max(extent_m, 1.0) / big
    local = xyz - origin
    rgb = np.where(out[:, None], [[200, 0, 200]], [[220, 20, 20]]).astype(np.uint8)
    attrs = [
        [
            ["id", str(i)],
            ["residual x, y, z (m)", ", ".join(f"{c:.4f}" for c in r)],
            ["residual 3D (m)", f"{np.linalg.norm(r):.4f}"],
            *([["outlier", "yes"]] if o else []),
        ]
        for i, r, o in zip(ids, v, out, strict=True)
    ]
    marker = {
        "name": name + (" (magenta: outliers)" if out.any() else ""),
        "colour": "#dc1414",
        "xyz": b64(local),
        "rgb": b64(rgb, np.uint8),
        "labels": [str(i) for i in ids],
        "attrs": attrs,
        "size": 8,
    }
    seg = np.stack([local, local + scale * v], axis=1).reshape(-1, 3)
    line = {
        "name": f"{name}: residuals x {scale:,.0f}",
        "colour": "#dc1414",
        "xyz": b64(seg),
        "rgb": b64(np.repeat(rgb, 2, axis=0), np.uint8),
    }
    return [marker], [line]


def object_points(
    report: Mapping[str, Any],
) -> tuple[Array, NDArray[np.str_], list[str], Array, list[int]]:
    """Object points of a bundle ``report.json``: xyz, role, label, std (m), rays.

    Reads the columnar ``object_points`` (``xyz`` and ``std`` as triplets, or
    ``X``, ``Y``, ``Z`` and ``sX``, ``sY``, ``sZ`` columns); empty when absent.
    """
    op = report.get("object_points") or {}
    if not isinstance(op, Mapping):
        op = {}
    if "xyz" in op:
        xyz = np.asarray(op["xyz"], float).reshape(-1, 3)
    elif {"X", "Y", "Z"} <= set(op):
        xyz = np.column_stack([np.asarray(op[k], float) for k in ("X", "Y", "Z")])
    else:
        xyz = np.empty((0, 3))
    n = len(xyz)
    if "std" in op:
        std = np.asarray(op["std"], float).reshape(-1, 3)
    elif {"sX", "sY", "sZ"} <= set(op):
        std = np.column_stack([np.asarray(op[k], float) for k in ("sX", "sY", "sZ")])
    else:
        std = np.full((n, 3), np.nan)
    role = np.asarray(op.get("role") or ["tie"] * n, str)
    label = [str(x) for x in (op.get("label") or op.get("id") or range(n))]
    rays = [int(r) for r in op.get("rays") or [0] * n]
    if not (len(std) == len(role) == len(label) == len(rays) == n):
        return np.empty((0, 3)), np.empty(0, str), [], np.empty((0, 3)), []
    return xyz, role, label, std, rays


def camera_overlays(
    report: Mapping[str, Any], origin: Array, extent_m: float
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Camera stations of a bundle adjustment (``report.json``) and its object points.

    Each image is a pyramid (centre to the image corners at the camera's
    principal distance, scaled to 6 % of the scene), coloured by its image RMS
    (dark blue low, yellow high); the centres are pickable markers with the
    image statistics; control, check and tie points are markers by role.
    """
    from pyheracles.bundle.camera import rotation_matrix

    images = [
        im
        for im in report.get("images") or []
        if all(np.isfinite(_num(im, k)) for k in ("X0", "Y0", "Z0"))
    ]
    cams = {c.get("id"): c for c in report.get("cameras") or []}
    markers: list[dict[str, Any]] = []
    lines: list[dict[str, Any]] = []
    if images:
        c = np.array([[_num(im, "X0"), _num(im, "Y0"), _num(im, "Z0")] for im in images])
        ang = np.radians(
            [[_num(im, k) for k in ("omega_deg", "phi_deg", "kappa_deg")] for im in images]
        )
        rot = rotation_matrix(np.nan_to_num(ang))
        rms = np.array([_num(im, "rms_px") for im in images])
        rgb = _ramp(rms)
        size = 0.06 * max(extent_m, 1e-3)
        segs, cols = [], []
        for k, im in enumerate(images):
            cam = cams.get(im.get("camera"), {})
            w_px, h_px = (cam.get("image_size_px") or [4, 3])[:2]
            pix = (cam.get("pixel_size_mm") or [1.0, 1.0])[:2]
            cc = float((cam.get("values") or {}).get("cc", max(w_px * pix[0], 1.0)))
            hw, hh = w_px * pix[0] / 2, h_px * pix[1] / 2
            s = size / max(cc, 1e-9)
            corners = np.array([[-hw, -hh, -cc], [hw, -hh, -cc], [hw, hh, -cc], [-hw, hh, -cc]]) * s
            top = np.array([[0, hh * 1.35, -cc]]) * s  # which way is up in the image
            world = (rot[k] @ np.vstack([corners, top]).T).T + c[k] - origin
            o = c[k] - origin
            for q in world[:4]:
                segs += [o, q]
            for a, b in ((0, 1), (1, 2), (2, 3), (3, 0), (2, 4), (3, 4)):
                segs += [world[a], world[b]]
            cols += [rgb[k]] * 20
        lines.append(
            {
                "name": f"images (colour: RMS {np.nanmin(rms):.2f}-{np.nanmax(rms):.2f} px)",
                "colour": hex_colour(rgb[int(np.nanargmax(rms))] / 255.0),
                "xyz": b64(np.array(segs)),
                "rgb": b64(np.array(cols), np.uint8),
            }
        )
        keys = ("n_points", "rms_px", "coverage_rect", "coverage_hull", "mean_ray_angle_deg")
        markers.append(
            {
                "name": "camera stations",
                "colour": "#3b528b",
                "xyz": b64(c - origin),
                "rgb": b64(rgb, np.uint8),
                "labels": [str(im.get("name", im.get("id"))) for im in images],
                "attrs": [
                    [["image id", str(im.get("id"))], ["camera", str(im.get("camera"))]]
                    + [[k, _fmt(im[k])] for k in keys if k in im]
                    + [[k, _fmt(im[k])] for k in ("omega_deg", "phi_deg", "kappa_deg") if k in im]
                    for im in images
                ],
                "size": 9,
            }
        )
    xyz, role, label, std, rays = object_points(report)
    style = {"control": ("#d62728", 8), "check": ("#1f77b4", 8), "tie": ("#555555", 4)}
    for r in sorted(set(role.tolist()), key=lambda x: list(style).index(x) if x in style else 9):
        m = (role == r) & np.all(np.isfinite(xyz), axis=1)
        if not m.any():
            continue
        colour, sz = style.get(r, ("#8c564b", 5))
        markers.append(
            {
                "name": f"{r} points",
                "colour": colour,
                "xyz": b64(xyz[m] - origin),
                "labels": [label[i] for i in np.flatnonzero(m)] if r != "tie" else [],
                "attrs": [
                    [
                        ["point", label[i]],
                        ["role", r],
                        ["std X, Y, Z (m)", ", ".join(f"{v:.2g}" for v in std[i])],
                        ["rays", str(rays[i])],
                    ]
                    for i in np.flatnonzero(m)
                ],
                "size": sz,
            }
        )
    return markers, lines


def surface_overlays(
    sets: Sequence[SurfaceSet],
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Translucent triangles and outlines of surface sets (walls, roofs)."""
    meshes, lines = [], []
    for s in sets:
        if len(s.triangles):
            meshes.append(
                {"name": s.name, "colour": s.colour, "xyz": b64(s.triangles), "alpha": 0.45}
            )
        if len(s.edges):
            lines.append({"name": f"{s.name}: outlines", "colour": "#333333", "xyz": b64(s.edges)})
    return meshes, lines


def view3d_scene(
    sample: CloudSample | None,
    labels: Mapping[int, str],
    attrs: Mapping[int, list[list[str]]],
    *,
    classes: Mapping[int, str] | None = None,
    origin: Array | None = None,
    lines: Sequence[Mapping[str, Any]] = (),
    meshes: Sequence[Mapping[str, Any]] = (),
    markers: Sequence[Mapping[str, Any]] = (),
) -> dict[str, Any]:
    """The JSON document the page's viewer draws.

    Parameters
    ----------
    sample
        The (subsampled) labelled cloud, or None (a bundle adjustment has none).
    labels, attrs
        Instance -> legend name, and instance -> ``[[key, value], ...]`` shown
        when one of its points is clicked.
    classes
        Instance -> class name (legend groups, "colour by class"); default ``object``.
    origin
        Local origin of the overlays when there is no cloud (world coordinates).
    lines, meshes, markers
        Overlays from :func:`primitive_lines`, :func:`surface_overlays`,
        :func:`residual_overlays`, :func:`camera_overlays` (local coordinates).
    """
    classes = classes or {}
    groups: list[dict[str, Any]] = []
    pts = np.empty((0, 3), np.float32)
    if sample is not None and len(sample.xyz):
        inst = sample.instance
        key = np.where(inst > 0, inst + 1, np.where(sample.ground, 0, 1))
        order = np.argsort(key, kind="stable")
        pts = sample.xyz[order]
        ks, starts, counts = np.unique(key[order], return_index=True, return_counts=True)
        cols = object_colours(int(max(inst.max(), 0)))
        for k, s, n in zip(ks.tolist(), starts.tolist(), counts.tolist(), strict=True):
            if k == 0:
                g = {"name": "ground", "cls": "ground", "colour": hex_colour(GROUND)}
            elif k == 1:
                g = {"name": "remainder", "cls": "remainder", "colour": hex_colour(REMAINDER)}
            else:
                i = k - 1
                g = {
                    "name": labels.get(i, f"object {i}"),
                    "cls": classes.get(i, "object"),
                    "colour": hex_colour(cols[i - 1]),
                    "instance": i,
                    "attrs": attrs.get(i, []),
                }
            groups.append({**g, "start": s, "count": n})
    class_names = list(dict.fromkeys(g["cls"] for g in groups))
    fixed = {"ground": hex_colour(GROUND), "remainder": hex_colour(REMAINDER)}
    others = [c for c in class_names if c not in fixed]
    class_list = [
        {"name": c, "colour": fixed.get(c) or CLASS_PALETTE[others.index(c) % len(CLASS_PALETTE)]}
        for c in class_names
    ]
    org = sample.origin if sample is not None else (np.zeros(3) if origin is None else origin)
    return {
        "origin": [float(x) for x in org],
        "crs": None if sample is None else sample.crs,
        "n_points": len(pts),
        "points": b64(pts),
        "groups": groups,
        "classes": class_list,
        "lines": list(lines),
        "meshes": list(meshes),
        "markers": list(markers),
    }


def folder_scene(
    folder: RunFolder,
    sample: CloudSample | None,
    labels: Mapping[int, str],
    attrs: Mapping[int, list[list[str]]],
    classes: Mapping[int, str],
) -> dict[str, Any] | None:
    """The 3D view of an output folder, with every overlay its files give; None if nothing to draw.

    Overlays: fitted primitives of the objects table, walls and openings
    (``walls.gpkg``, ``openings.gpkg``), buildings (``buildings.city.json``),
    check points (``checkpoints.json``) and tie points (``tiepoints.csv``) with
    their residual vectors, cameras and object points of a bundle adjustment
    (``report.json``).
    """
    from pyheracles.report.surfaces import cityjson_surfaces, polygon_surfaces

    report = folder.documents.get("report.json") or {}
    has_cameras = isinstance(report.get("images"), list) and bool(report.get("images"))
    chk = (folder.documents.get("checkpoints.json") or {}).get("points") or []
    ties = folder.tables.get("tiepoints.csv")
    tie_cols = ["X_target", "Y_target", "Z_target", "vx", "vy", "vz"]
    if ties is not None and not (set(tie_cols) <= set(ties.columns) and len(ties)):
        ties = None
    tie_xyzv = (
        None
        if ties is None
        else ties[tie_cols].apply(pd.to_numeric, errors="coerce").to_numpy(float)
    )
    chk_xyz = np.array([p.get("reference", [np.nan] * 3) for p in chk], float).reshape(-1, 3)
    if sample is not None and len(sample.xyz):
        origin = sample.origin
        extent = float(np.ptp(sample.xyz, axis=0).max())
    else:  # no cloud: the view spans the cameras, object points, check and tie points
        parts = [chk_xyz, np.empty((0, 3)) if tie_xyzv is None else tie_xyzv[:, :3]]
        if has_cameras:
            parts.append(
                np.array([[_num(im, k) for k in ("X0", "Y0", "Z0")] for im in report["images"]])
            )
            parts.append(object_points(report)[0])
        a = np.concatenate(parts)
        a = a[np.all(np.isfinite(a), axis=1)]
        if not len(a):
            return None
        origin = np.floor(a.min(0))
        extent = float(np.ptp(a, axis=0).max())
    lines: list[dict[str, Any]] = []
    meshes: list[dict[str, Any]] = []
    markers: list[dict[str, Any]] = []
    prim = primitive_lines(folder.objects, origin)
    if len(prim):
        lines.append({"name": "fitted primitives", "colour": "#111111", "xyz": b64(prim)})
    sets = []
    for name, title, colour in (
        ("walls.gpkg", "walls (fitted)", "#e0a96d"),
        ("openings.gpkg", "openings", "#2e86c1"),
    ):
        s = polygon_surfaces(folder.layers.get(name), origin, title, colour)
        if s is not None:
            sets.append(s)
    city = folder.layers.get("buildings.city.json")
    if isinstance(city, Mapping):
        sets += cityjson_surfaces(city, origin)
    m, ln = surface_overlays(sets)
    meshes += m
    lines += ln
    if chk:
        mk, ln = residual_overlays(
            "check points",
            chk_xyz,
            np.array([[_num(p, "vx"), _num(p, "vy"), _num(p, "vz")] for p in chk], float),
            [str(p.get("id")) for p in chk],
            origin,
            extent,
        )
        markers += mk
        lines += ln
    if ties is not None and tie_xyzv is not None:
        out = (
            pd.to_numeric(ties["outlier"], errors="coerce").fillna(0).to_numpy() != 0
            if "outlier" in ties
            else None
        )
        ids = (
            ties["id"].astype(str).tolist() if "id" in ties else [str(i) for i in range(len(ties))]
        )
        mk, ln = residual_overlays(
            "tie points", tie_xyzv[:, :3], tie_xyzv[:, 3:], ids, origin, extent, outlier=out
        )
        markers += mk
        lines += ln
    if has_cameras:
        mk, ln = camera_overlays(report, origin, extent)
        markers += mk
        lines += ln
    return view3d_scene(
        sample,
        labels,
        attrs,
        classes=classes,
        origin=origin,
        lines=lines,
        meshes=meshes,
        markers=markers,
    )
