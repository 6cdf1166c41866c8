"""Primitives of the supports: cylinders of columns, boxes of piers; plausibility.

Columns of the objects table (:func:`describe`) beyond the primitive: the support's
inclination ``tilt_deg`` (axis from the vertical), ``lean_m`` (horizontal offset of
the axis over the support's height) and ``lean_azimuth_deg`` (direction of that
offset, degrees clockwise from +y, grid north), the shaft's ``radius_bottom_m`` and
``radius_top_m`` (a tapered cylinder; ``radius_m`` is the shaft's radius at the
height of the section, ``radius_height_m`` above ``z_min``: flutes averaged, from the
shaft's surface about its axis in a window around that height, :func:`column_shape`),
and its parts as
heights above ``z_min``: ``base_top_m`` (top of the plinth / base band) and
``capital_bottom_m`` (bottom of the capital / abacus band), NaN when the support has
none (:func:`part_bands`).  A column's axis (``axis_x/y/z``, ``x``, ``y`` on it) is
that of its whole shaft (:func:`shaft_axis`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pyheracles.geometry.fitting import (
    BoxFit,
    FailedFit,
    fit_circle,
    fit_cylinder,
    fit_oriented_box,
    perpendicular_basis,
)
from pyheracles.geometry.groups import group_medians, group_quantiles
from pyheracles.supports.clutter import off_shaft
from pyheracles.supports.core import Array, Scales
from pyheracles.supports.shaft_band import shaft_band_axis


def dedupe(shapes: list[dict]) -> list[dict]:
    """Drop a shape whose centre lies inside an earlier one (a bump seen twice)."""
    kept: list[dict] = []
    for sh in shapes:
        r = float(np.max(sh["half"]))
        if all(
            np.hypot(*(sh["centre"] - k["centre"])) > 0.5 * (r + float(np.max(k["half"])))
            for k in kept
        ):
            kept.append(sh)
    return kept


def fit_cone(
    pts: Array, point: Array, axis: Array, radius: float, *, f_scale: float = 0.005,
    max_slope: float = 0.05,
) -> tuple[Array, Array, float, float, float] | None:  # fmt: skip
    """Truncated cone through a shaft's surface points, from a fitted cylinder.

    The radius changes linearly along the axis (a tapered shaft); axis direction,
    axis position, radius and slope are refined together (robust soft-L1 loss of scale
    ``f_scale``).  A tapered shaft seen from one side pulls a cylinder's axis towards
    its visible side by the taper angle; the cone does not.  Returns (axis point at the
    points' mean height along the axis, unit axis z up, radius there, residual RMS,
    slope of the radius along the axis), or
    None when the fit fails, is worse than the cylinder or tapers by more than
    ``max_slope`` (m per m).
    """
    from scipy.optimize import least_squares

    if len(pts) < 50:
        return None
    a0 = np.asarray(axis, dtype=np.float64)
    a0 = a0 / np.linalg.norm(a0)
    if a0[2] < 0:
        a0 = -a0
    e1, e2 = perpendicular_basis(a0)

    def geom(x: Array) -> tuple[Array, Array]:
        a = a0 + x[0] * e1 + x[1] * e2
        return point + x[2] * e1 + x[3] * e2, a / np.linalg.norm(a)

    def res(x: Array) -> Array:
        return cone_residuals(pts, *geom(x), x[4], x[5])

    cyl_res = cone_residuals(pts, point, a0, radius, 0.0)
    try:
        sol = least_squares(res, np.array([0, 0, 0, 0, radius, 0.0]), loss="soft_l1",
                            f_scale=f_scale, x_scale=1e-3)  # fmt: skip
    except (ValueError, np.linalg.LinAlgError):
        return None
    if not sol.success or abs(sol.x[5]) > max_slope:
        return None
    r = res(sol.x)
    rms, rms_cyl = float(np.sqrt(np.mean(r**2))), float(np.sqrt(np.mean(cyl_res**2)))
    if not np.isfinite(rms) or rms > rms_cyl:
        return None
    c, a = geom(sol.x)
    tm = float(np.mean((pts - c) @ a))
    return c + tm * a, a, float(sol.x[4] + sol.x[5] * tm), rms, float(sol.x[5])


def centre_line(pts: Array, slab_m: float = 0.25) -> tuple[Array, Array] | None:
    """(point, unit direction, z up) of the line through the centres of a column's slabs.

    Each horizontal slab of ``slab_m`` gets an algebraic (Kåsa) circle fit of its points (a
    plinth, a base, a capital or an abacus seen all round is centred on the axis too);
    the line is a least-squares fit of x and y against z over the slabs, refitted
    without the slabs more than 3 robust sigma off it.  None with fewer than 4 slabs.
    """
    if len(pts) < 100:
        return None
    z = pts[:, 2]
    n = int(np.ptp(z) // slab_m)
    if n < 4:
        return None
    k = np.clip(((z - z.min()) / slab_m).astype(np.intp), 0, n - 1)
    cz, cxy = [], []
    for i in range(n):
        q = pts[k == i]
        if len(q) < 30:
            continue
        circle = fit_circle(q[:, :2], method="algebraic")
        if isinstance(circle, FailedFit):  # collinear points: no centre in this slab
            continue
        cz.append(float(q[:, 2].mean()))
        cxy.append(circle.center)
    if len(cz) < 4:
        return None
    cz_a, cxy_a = np.asarray(cz), np.asarray(cxy)
    keep = np.ones(len(cz_a), dtype=bool)
    for _ in range(2):
        fx = np.polyfit(cz_a[keep], cxy_a[keep, 0], 1)
        fy = np.polyfit(cz_a[keep], cxy_a[keep, 1], 1)
        off = np.hypot(cxy_a[:, 0] - np.polyval(fx, cz_a), cxy_a[:, 1] - np.polyval(fy, cz_a))
        s = 1.4826 * float(np.median(off))
        new = off <= max(3 * s, 0.005)
        if new.sum() < 4 or np.array_equal(new, keep):
            break
        keep = new
    z0 = float(np.median(cz_a))
    d = np.array([fx[0], fy[0], 1.0])
    return np.array([np.polyval(fx, z0), np.polyval(fy, z0), z0]), d / np.linalg.norm(d)


def inliers(cyl: Any, pts: Array, tol: float) -> int:
    """Points of ``pts`` within ``tol`` of a fitted cylinder's surface."""
    return int(np.count_nonzero(np.abs(cyl.residuals(pts)) <= tol))


#: Refits of a shaft's cone to the points near the cone itself (:func:`shaft_axis`).
CONE_REFITS = 2
#: ... each kept when this share of the points it was fitted to lie within the band of it.
CONE_REFIT_KEEP = 0.8


def shaft_axis(pts: Array, cyl: Any, tol: float) -> tuple[Array, Array, float]:
    """(point, unit axis, radius) of a column's whole shaft: its inclination.

    The section's shaft points (``rho`` within ``tol``) mark a leaning column on one
    side only away from the section, and a cylinder fitted to a tapered shaft seen
    from one side leans by the taper angle.  So: the shaft's points about the line of
    the slabs' centres (:func:`centre_line`) or about the section's cylinder ``cyl``,
    whichever start holds more points within ``tol``; a cylinder refitted to the points
    within ``tol`` of it (up to three times); then a cone (:func:`fit_cone`), refitted
    (up to :data:`CONE_REFITS` times) to the points within ``max(tol, 3 sigma)`` of
    itself when the shaft tapers by more than ``tol / 2`` over its height or the points
    within ``tol`` of it scatter by more than ``tol / 4`` (sigma, robust: flutes), kept
    when :data:`CONE_REFIT_KEEP` of the band's points lie within the band's width of it.
    The band is about the cone and sigma that of the points within ``tol`` of it: a
    column seen from one side whose plinth and capital hold more points than its shaft
    (supports draw 16, column 7) has the mouldings' median offset and spread, and a band
    about them took the cone through the plinth's top face and the abacus' underside
    (0.45 m for a 0.28 m shaft, leaning 1.5 degrees).  The
    cylinder's points of a tapered shaft are those of the heights where the cylinder
    meets the cone, and of a fluted one its arrises or its flutes' bottoms only: supports
    draw 1's fluted, tapered twin columns (17 flutes 3 cm deep, radius 0.72 -> 0.55 m
    over 13.8 m) leaned 2.3-3.1 cm at 12 m on a cone of those points, 0.1-0.2 cm after
    the refits; their IFC surfaces were 1.7-2.5 cm RMS from their points.
    """
    sample = pts if len(pts) <= 2000 else pts[np.linspace(0, len(pts) - 1, 2000).astype(np.intp)]
    best, fit_pts = cyl, sample[np.abs(cyl.residuals(sample)) <= tol]
    hint = centre_line(pts)
    if hint is not None:
        rel = sample - hint[0]
        dd = np.linalg.norm(rel - np.outer(rel @ hint[1], hint[1]), axis=1)
        start = sample[np.abs(dd - float(np.median(dd))) <= tol]
        alt = fit_cylinder(start, axis_hint=hint[1], f_scale=tol / 2) if len(start) >= 20 else None
        if alt and inliers(alt, sample, tol) > len(fit_pts):
            best, fit_pts = alt, start
    for _ in range(3):
        near = sample[np.abs(best.residuals(sample)) <= tol]
        new = fit_cylinder(near, axis_hint=best.axis, f_scale=tol / 2) if len(near) >= 20 else None
        if not new:
            break
        moved = float(np.linalg.norm(np.cross(new.axis, best.axis)))
        best, fit_pts = new, near
        if moved < 1e-4:
            break
    few = fit_pts[np.linspace(0, len(fit_pts) - 1, min(len(fit_pts), 1000)).astype(np.intp)]
    cone = fit_cone(few, best.point, best.axis, best.radius, f_scale=max(tol / 4, 1e-3))
    if cone is None:
        return best.point, best.axis, best.radius
    height = float(np.ptp(sample @ cone[1]))
    for _ in range(CONE_REFITS):
        point, axis, radius, _, slope = cone
        res = cone_residuals(sample, point, axis, radius, slope)
        own = np.abs(res[np.abs(res) <= tol])  # the shaft's (not a plinth's) points
        sigma = 1.4826 * float(np.median(own)) if len(own) else 0.0
        if abs(slope) * height <= tol / 2 and sigma <= tol / 4:
            break  # neither taper nor flutes: the cylinder's points are the cone's
        width = max(tol, 3.0 * sigma)
        band = sample[np.abs(res) <= width]
        few = band[np.linspace(0, len(band) - 1, min(len(band), 1000)).astype(np.intp)]
        new = fit_cone(few, point, axis, radius, f_scale=max(tol / 4, sigma, 1e-3))
        if new is None:
            break
        res_new = cone_residuals(band, *new[:3], new[4])
        if np.mean(np.abs(res_new) <= width) < CONE_REFIT_KEEP:
            break  # pulled off the band by a plinth's or a capital's faces in it
        cone = new
    return cone[0], cone[1], cone[2]


def cone_residuals(pts: Array, point: Array, axis: Array, radius: float, slope: float) -> Array:
    """Distances of ``pts`` from a truncated cone's surface (positive outside).

    The cone as :func:`fit_cone` returns it: the axis through ``point`` along the unit
    ``axis``, radius ``radius`` at ``point`` changing by ``slope`` per metre along it.
    """
    rel = pts - point
    t = rel @ axis
    return np.linalg.norm(rel - np.outer(t, axis), axis=1) - (radius + slope * t)


def section_box(pts: Array, angle: float) -> BoxFit | FailedFit:
    """Upright box of the points ``pts`` with its sides along the section rectangle's
    direction ``angle`` (radians from +x): extents from the points' 0.2-99.8 %
    quantiles in that frame, RMS (trimmed, 90 %) of their distances to the nearest
    side face."""
    if len(pts) < 8:
        return FailedFit("too few points for a box")
    c, s = math.cos(angle), math.sin(angle)
    frame = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    local = pts @ frame
    lo, hi = np.quantile(local, 0.002, axis=0), np.quantile(local, 0.998, axis=0)
    lo[2], hi[2] = local[:, 2].min(), local[:, 2].max()
    d = np.minimum(np.abs(local[:, :2] - lo[:2]), np.abs(hi[:2] - local[:, :2])).min(axis=1)
    keep = d <= np.quantile(d, 0.9)
    ext = hi - lo
    order = np.argsort(-ext)
    return BoxFit(
        frame @ ((lo + hi) / 2), frame[:, order], ext[order],
        float(np.sqrt(np.mean(d[keep] ** 2))), keep,
    )  # fmt: skip


def pier_box(pts: Array, sh: dict, tol: float) -> BoxFit | FailedFit:
    """The box of a pier: the least-squares oriented box, or the box along its section
    rectangle (:func:`section_box`) when that fits its points better or the
    least-squares one is wider than they are.

    The least-squares box starts from the minimum-area rectangle of the points, which
    for a pier seen from a corner (an L of two faces) lies along the diagonal; from
    there it can turn away and open its unseen sides far beyond the points (draw 32 of
    the supports family: a pier of 0.49 x 0.31 m fitted as a box 29.8 m across).
    """
    box = fit_oriented_box(pts, up=(0.0, 0.0, 1.0))
    alt = section_box(pts, float(sh["angle"]))
    if not alt:
        return box
    if not box:
        return alt
    span = float(np.hypot(*np.ptp(pts[:, :2], axis=0)))
    vert = int(np.argmax(np.abs(box.axes[2])))
    wide = max(float(box.extents[k]) for k in range(3) if k != vert) > span + 2.0 * tol
    return alt if wide or alt.rms < box.rms else box


#: A pier's box is fitted again to the prism of its shaft band when more than this
#: share of the prism's points lie outside the box of the faces its section saw.
PRISM_OUTSIDE_SHARE = 0.05
#: ... to the prism of the shaft band less this share of its height at either end.
PRISM_END_SHARE = 0.1


def prism_points(pts: Array, cell: float, *, layers: int = 8, min_layers: int = 5) -> Array:
    """Mask of the points in plan cells occupied over most of their height.

    ``pts`` are a pier's points between its base and capital bands; the height is cut
    into ``layers`` equal layers and the plan into square cells of ``cell`` metres.  A
    cell of the pier's faces holds points in at least ``min_layers`` layers (a face
    runs from the base to the capital); a chair, a fence or a sign touching the pier,
    or a ceiling's edge, fills a few layers of its cells.
    """
    if len(pts) == 0:
        return np.zeros(0, dtype=bool)
    z = pts[:, 2]
    span = float(np.ptp(z))
    if span <= 0:
        return np.zeros(len(pts), dtype=bool)
    layer = np.minimum(((z - z.min()) / span * layers).astype(np.int64), layers - 1)
    ij = np.floor((pts[:, :2] - pts[:, :2].min(axis=0)) / cell).astype(np.int64)
    key = ij[:, 0] * (int(ij[:, 1].max()) + 1) + ij[:, 1]
    cells, inv = np.unique(key, return_inverse=True)
    occupied = np.zeros((len(cells), layers), dtype=bool)
    occupied[inv, layer] = True
    return occupied.sum(axis=1)[inv] >= min_layers


def outside_share(pts: Array, box: BoxFit, margin: float) -> float:
    """Share of ``pts`` farther than ``margin`` outside an upright box, in plan."""
    vert = int(np.argmax(np.abs(box.axes[2])))
    h = [k for k in range(3) if k != vert]
    local = (pts - box.centre) @ box.axes[:, h]
    out = np.abs(local) - 0.5 * box.extents[h] > margin
    return float(np.mean(out.any(axis=1))) if len(pts) else 0.0


def prism_box(prism: Array, sh: dict, tol: float) -> BoxFit | FailedFit:
    """The box of a pier's prism points: :func:`pier_box`, or the box along the
    section's direction (:func:`section_box`) when that holds more of them.

    The least-squares box of a face seen fully and a side face seen at a grazing angle
    (a tenth of the points) is the thin box of the first face, with the side's points
    as outliers and a smaller RMS than any box holding both faces (supports draw 7: a
    0.53 x 0.005 m box of a pier whose side face showed 0.33 m of its depth).
    """
    box = pier_box(prism, sh, tol)
    alt = section_box(prism, float(sh["angle"]))
    if not alt:
        return box
    if not box:
        return alt
    margin = 2.0 * tol
    return alt if outside_share(prism, alt, margin) < outside_share(prism, box, margin) else box


def _pier_fields(pts: Array, box: BoxFit, tol: float, z_min: float) -> dict[str, float]:
    """Objects-table fields of a pier from its box: centre, sides, axis, RMS, bands."""
    vert = int(np.argmax(np.abs(box.axes[2])))
    horiz = sorted((box.extents[k] for k in range(3) if k != vert), reverse=True)
    h = [k for k in range(3) if k != vert]
    local = (pts - box.centre) @ box.axes[:, h]  # plan coordinates in the box frame
    reach = np.max(np.abs(local) / (0.5 * box.extents[h]), axis=1)  # 1 on the sides
    noise = max(float(box.rms), 0.25 * tol) / (0.5 * float(min(box.extents[h])))
    base, cap = part_bands(pts[:, 2] - z_min, reach, np.ones(len(pts)), noise)
    return {
        "x": float(box.centre[0]),
        "y": float(box.centre[1]),
        "box_length_m": float(horiz[0]),
        "box_width_m": float(horiz[1]),
        "box_height_m": float(np.ptp(pts[:, 2])),
        "fit_rms_m": box.rms,
        "axis_x": float(box.axes[0, 0]),
        "axis_y": float(box.axes[1, 0]),
        "axis_z": float(box.axes[2, 0]),
        "base_top_m": base,
        "capital_bottom_m": cap,
    }


def describe(pts: Array, rho: Array, sh: dict, tol: float, *, z_ref: float | None = None) -> dict:
    """Objects-table row of one support (its points ``pts``) with its fitted primitive.

    Parameters
    ----------
    pts : (N, 3) ndarray
        The support's points (metres).
    rho : (N,) ndarray
        Each point's offset from the section's shape (within ``tol``: the section's
        shaft).
    sh : dict
        The section shape.
    tol : float
        Surface tolerance (metres).
    z_ref : float, optional
        Height (z) of the section the shape was found in: a column's ``radius_m`` is
        measured there.  Default: the median height of the section's shaft points.

    Returns
    -------
    dict
        The row; columns as in the module docstring.  Piers get ``base_top_m`` /
        ``capital_bottom_m`` from the reach of their layers beyond the fitted box.
        A pier's box is that of the faces its section saw, or, when more than
        :data:`PRISM_OUTSIDE_SHARE` of the points of its shaft band that outline a
        prism (:func:`prism_points`) lie outside it, the box of that prism
        (:func:`prism_box`; a face shadowed at the section but seen above or below it).
        A free column's row holds ``off_shaft``, a mask of its points that are clutter
        touching it (:func:`~pyheracles.supports.clutter.off_shaft`; for the detection,
        not a column of the objects table).
        A column's row also holds ``cylinder_radius_m``, the radius of the cylinder
        of the section's shaft points (the detection's checks of a candidate: does its
        cylinder agree with its section circle, is it thinner than the columns that
        carry; not a column of the objects table).

    Notes
    -----
    The points within ``tol`` of the section circle are not the section: on a tapered
    shaft they are the band of heights where the shaft's radius is within ``tol`` of
    the circle's, several metres tall when ``tol`` is a few centimetres and cut by the
    capital or the floor on one side, and centred where the radius equals the circle's
    (a circle fitted a centimetre too large moves the band down the shaft to where the
    shaft is that large).  Their cylinder gives the axis; the radius is measured at
    ``z_ref`` along that axis (:func:`column_shape`).
    """
    shaft = np.abs(rho) <= tol
    fit_pts = pts[shaft] if shaft.sum() >= 20 else pts
    if z_ref is None or not np.isfinite(z_ref):
        z_ref = float(np.median(fit_pts[:, 2]))
    if len(fit_pts) > 3000:  # the fit is as good on a spread sample and much faster
        fit_pts = fit_pts[np.linspace(0, len(fit_pts) - 1, 3000).astype(np.intp)]
    nan = float("nan")
    row = {
        "class": sh["class"],
        "n_points": len(pts),
        "x": nan,
        "y": nan,
        "z_min": float(pts[:, 2].min()),
        "z_max": float(pts[:, 2].max()),
        "height_m": float(np.ptp(pts[:, 2])),
        "radius_m": nan,
        "radius_height_m": nan,
        "axis_x": nan,
        "axis_y": nan,
        "axis_z": nan,
        "box_length_m": nan,
        "box_width_m": nan,
        "box_height_m": nan,
        "fit_rms_m": nan,
        "circularity": sh.get("circularity", nan),
        "tilt_deg": nan,
        "lean_m": nan,
        "lean_azimuth_deg": nan,
        "radius_bottom_m": nan,
        "radius_top_m": nan,
        "base_top_m": nan,
        "capital_bottom_m": nan,
    }
    if sh["class"] in ("column", "engaged_column"):
        cyl = fit_cylinder(fit_pts, axis_hint=(0.0, 0.0, 1.0), f_scale=tol / 2)
        if cyl:  # second pass without base / capital mouldings: residuals within 3 sigma
            res = cyl.residuals(fit_pts)
            sigma = 1.4826 * np.median(np.abs(res - np.median(res)))
            close = np.abs(res - np.median(res)) <= max(3 * sigma, 1e-4)
            if close.sum() >= 20:
                cyl = fit_cylinder(fit_pts[close], axis_hint=cyl.axis, f_scale=max(sigma, 1e-3))
        if cyl:  # radius and fit RMS: the cylinder of the section's shaft points
            row.update(
                x=float(cyl.point[0]),
                y=float(cyl.point[1]),
                radius_m=cyl.radius,
                cylinder_radius_m=cyl.radius,
                radius_height_m=z_ref - row["z_min"],
                axis_x=float(cyl.axis[0]),
                axis_y=float(cyl.axis[1]),
                axis_z=float(cyl.axis[2]),
                fit_rms_m=cyl.rms,
            )
            # the axis of the whole shaft (a leaning, a tapered column), through its points
            point, axis, radius = shaft_axis(pts, cyl, tol)
            axis = axis if axis[2] >= 0 else -axis
            row.update(x=float(point[0]), y=float(point[1]), axis_x=float(axis[0]),
                       axis_y=float(axis[1]), axis_z=float(axis[2]))  # fmt: skip
            row.update(column_shape(pts, point, axis, radius, tol, z_ref=z_ref))
            # the axis again from the shaft band only (not its plinth, base or capital)
            band = shaft_band_axis(pts, point, axis, radius, row["base_top_m"],
                                   row["capital_bottom_m"], tol)  # fmt: skip
            if band is not None:
                point, axis, radius = band
                row.update(x=float(point[0]), y=float(point[1]), axis_x=float(axis[0]),
                           axis_y=float(axis[1]), axis_z=float(axis[2]))  # fmt: skip
                row.update(column_shape(pts, point, axis, radius, tol, z_ref=z_ref))
            if sh["class"] == "column":  # an engaged column's wall lies outside it too
                row["off_shaft"] = off_shaft(pts, point, axis, row, tol)
    else:
        box = pier_box(fit_pts, sh, tol)
        if box:
            row.update(_pier_fields(pts, box, tol, row["z_min"]))
            # the section may have seen one face of a pier whose other faces show above
            # or below it: the box of the prism its shaft band outlines, when more than
            # PRISM_OUTSIDE_SHARE of that prism lies outside the box of the section's faces
            lo = row["base_top_m"] if np.isfinite(row["base_top_m"]) else 0.0
            hi = row["capital_bottom_m"] if np.isfinite(row["capital_bottom_m"]) else np.inf
            h = pts[:, 2] - row["z_min"]
            # the middle of the shaft band: a plinth or a capital the bands missed (a
            # plinth 3 cm wider than the faces) fills the cells of the faces beside it
            # (supports draw 8's pier 18: its box 2 cm outside both seen faces)
            top = min(hi, float(h.max()))
            inset = PRISM_END_SHARE * max(top - lo, 0.0)
            band = pts[(h > lo + inset) & (h < top - inset)]
            prism = band[prism_points(band, max(0.02, 2.0 * tol))]
            if len(prism) >= 20 and outside_share(prism, box, 2.0 * tol) > PRISM_OUTSIDE_SHARE:
                wider = prism_box(prism, sh, tol)
                if wider:
                    row.update(_pier_fields(pts, wider, tol, row["z_min"]))
    if np.isnan(row["x"]):
        row["x"], row["y"] = (float(v) for v in sh["centre"])
    return row


def lean(axis: Array, height: float) -> dict[str, float]:
    """Inclination of a support's ``axis`` (unit, 3D) over its ``height`` (m).

    Returns ``tilt_deg`` (angle from the vertical), ``lean_m`` (horizontal offset of
    the axis over ``height``) and ``lean_azimuth_deg`` (direction the axis leans to, in
    degrees clockwise from +y, grid north, in [0, 360); 0 for a vertical axis).
    """
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    if a[2] < 0:
        a = -a
    tilt = math.degrees(math.acos(min(1.0, float(a[2]))))
    horiz = float(np.hypot(a[0], a[1]))
    off = height * horiz / max(float(a[2]), 1e-9)
    az = math.degrees(math.atan2(float(a[0]), float(a[1]))) % 360.0 if horiz > 1e-12 else 0.0
    return {"tilt_deg": tilt, "lean_m": off, "lean_azimuth_deg": az}


def part_bands(
    h: Array, reach: Array, ref: Array, noise: float, *, layer_m: float = 0.02,
    max_share: float = 0.4, min_points: int = 5,
) -> tuple[float, float]:  # fmt: skip
    """(base_top, capital_bottom) heights of a support's parts above its bottom.

    ``h`` are the points' heights above the support's bottom (along its axis),
    ``reach`` their distance from the axis (or the box frame's reach), ``ref`` the
    shaft's radius at each point's height.  The support is cut into layers of
    ``layer_m``; a layer is wider than the shaft when the 90th percentile of
    ``reach - ref`` among its points exceeds ``max(3 noise, 1 cm)``.  The base band
    is the run of such layers from the bottom (the first layer may be narrow: the
    floor's edge), the capital band the run from the top, each at most ``max_share``
    of the height; NaN where there is no such run.
    """
    nan = float("nan")
    if len(h) < 4 * min_points:
        return nan, nan
    top = float(h.max())
    n = max(1, math.ceil(top / layer_m))
    k = np.clip((h / layer_m).astype(np.intp), 0, n - 1)
    over = reach - ref
    thr = max(3.0 * noise, 0.01)
    seen = np.bincount(k, minlength=n) >= min_points
    wide = seen & (group_quantiles(over, k, n, 0.9) > thr)
    lim = max(1, int(max_share * n))

    def run(idx: range) -> int:  # wide layers from one end (empty layers carry on)
        last = -1
        for j, i in enumerate(idx):
            if j >= lim:
                return 0  # wider over too much of the height: no band, a poor shaft radius
            if not seen[i]:
                continue
            if not wide[i]:
                if j == 0:
                    continue  # the floor's or the ceiling's edge
                break
            last = j
        return last + 1

    nb, nc = run(range(n)), run(range(n - 1, -1, -1))
    base = min(nb * layer_m, top) if nb else nan
    cap = max(top - nc * layer_m, 0.0) if nc else nan
    return base, cap


#: The radius at the section is measured over the shaft within this share of its length
#: of the section's height, and within at least ``REF_WINDOW_M`` metres.
REF_WINDOW_SHARE = 0.1
REF_WINDOW_M = 0.5


def column_shape(
    pts: Array, point: Array, axis: Array, radius: float, tol: float, *,
    z_ref: float | None = None,
) -> dict:  # fmt: skip
    """Inclination, radii of the shaft and parts of a column from its points.

    The radius along the axis is fitted as a line to the per-layer medians of the
    distances to the axis of the points within ``max(3 tol, 0.15 radius)`` of the
    cylinder (the shaft's surface), outside the base and capital bands
    (:func:`part_bands` on the 90th percentile reach of each layer); the end radii are
    that line at the shaft's two ends.  ``base_top_m`` and ``capital_bottom_m`` are the
    heights above ``z_min`` of the axis where the bands end (found along the axis).

    With ``z_ref`` (a height, m), also ``radius_m``: the shaft's radius there
    (:func:`section_radius` of the shaft's points within ``REF_WINDOW_SHARE`` of its
    length, at least ``REF_WINDOW_M``, of that height, as far above as below it where
    the shaft's ends allow; the taper from the same line fitted over that window: an
    entasis is a curve, over a tenth of the shaft a line within a tenth of a
    millimetre), and ``radius_height_m`` (``z_ref`` above ``z_min``).  The circle's
    least squares average the flutes (half the flutes' depth) and the noise.
    """
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    if a[2] < 0:
        a = -a
    z_min, z_span = float(pts[:, 2].min()), float(np.ptp(pts[:, 2]))
    if len(pts) > 12000:  # a spread sample measures the profile as well, much faster
        pts = pts[np.linspace(0, len(pts) - 1, 12000).astype(np.intp)]
    rel = pts - point
    t = rel @ a
    d = np.linalg.norm(rel - np.outer(t, a), axis=1)
    t0 = float(t.min())
    h = t - t0
    length = float(h.max()) if len(h) else 0.0
    out = lean(a, z_span)
    ring = np.abs(d - radius) <= max(3.0 * tol, 0.15 * radius)
    if ring.sum() < 20 or length <= 0:
        return out

    def line(lo: float, hi: float) -> np.ndarray | None:  # r(h) = c0 + c1 h on the shaft
        sel = ring & (h >= lo) & (h <= hi)
        if sel.sum() < 20:
            return None
        nl = max(2, int((hi - lo) / 0.05))
        hs, ds = h[sel], d[sel]
        kk = np.clip(((hs - lo) / max(hi - lo, 1e-9) * nl).astype(np.intp), 0, nl - 1)
        full = np.bincount(kk, minlength=nl) >= 5  # layers of 5 points or more
        if full.sum() < 2:
            return np.array([float(np.median(ds)), 0.0])
        hm, rm = group_medians(hs, kk, nl)[full], group_medians(ds, kk, nl)[full]
        return np.polyfit(hm, rm, 1)[::-1]

    coef = line(0.0, length)
    if coef is None:
        return out
    res = d[ring] - (coef[0] + coef[1] * h[ring])  # the surface's scatter about its taper
    noise = 1.4826 * float(np.median(np.abs(res - np.median(res))))
    base, cap = part_bands(h, d, coef[0] + coef[1] * h, noise)
    lo = 0.0 if math.isnan(base) else base
    hi = length if math.isnan(cap) else cap
    coef = line(lo, hi) if hi - lo > 0.1 * length else coef
    if coef is None:
        return out

    def above(hh: float) -> float:  # height along the axis -> z of the axis above z_min
        return float(point[2] + (t0 + hh) * a[2] - z_min) if math.isfinite(hh) else math.nan

    out.update(
        radius_bottom_m=float(coef[0] + coef[1] * lo),
        radius_top_m=float(coef[0] + coef[1] * hi),
        base_top_m=above(base),
        capital_bottom_m=above(cap),
    )
    if z_ref is not None and np.isfinite(z_ref) and abs(a[2]) > 1e-6:
        h_ref = (z_ref - point[2]) / a[2] - t0  # the axis at the height z_ref
        w = max(REF_WINDOW_M, REF_WINDOW_SHARE * (hi - lo))
        a_lo, a_hi = max(lo, h_ref - w), min(hi, h_ref + w)
        local = line(a_lo, a_hi) if a_hi - a_lo >= REF_WINDOW_M else None
        # the circle's points centred on h_ref where the shaft allows: a taper measured
        # about an axis leaning by the taper angle then moves none of them on average
        w_sym = min(w, h_ref - lo, hi - h_ref)
        if w_sym >= REF_WINDOW_M / 2:
            a_lo, a_hi = h_ref - w_sym, h_ref + w_sym
        c = coef if local is None else local
        r_ref = float(c[0] + c[1] * h_ref)
        # the shaft's surface in the window about its own radius there, not the shaft's
        # mean one: about an axis leaning by the taper angle, one side of the shaft's
        # foot lies beyond the ring of the mean radius (the circle took the other)
        win = (h >= a_lo) & (h <= a_hi)
        d_win = float(np.median(d[win & ring])) if np.any(win & ring) else radius
        sel = win & (np.abs(d - d_win) <= max(3.0 * tol, 0.15 * radius))
        at_ref = section_radius(rel[sel] - np.outer(t[sel], a), h[sel] - h_ref, a, float(c[1]))
        out.update(
            radius_m=r_ref if at_ref is None else at_ref, radius_height_m=float(z_ref - z_min)
        )
    return out


def section_radius(rel: Array, dh: Array, axis: Array, slope: float) -> float | None:
    """Radius of a shaft at one height from its surface points near that height.

    Parameters
    ----------
    rel : (N, 3) ndarray
        The points' offsets from the shaft's axis, perpendicular to it (metres).
    dh : (N,) ndarray
        Their heights along the axis above the reference height (metres).
    axis : (3,) ndarray
        Unit axis.
    slope : float
        The shaft's taper, radius change per metre along the axis.

    Returns
    -------
    float or None
        The radius at the reference height: a circle with a free centre in the plane
        normal to the axis whose radius changes linearly with ``dh`` (the local taper),
        robust (soft-L1 at the robust standard deviation of the distances), started on
        the axis at the median distance (a chair, a sign or a fence touching the shaft
        pulls a least-squares circle's centre towards it; leaving out the points far
        from the axis leaves out the far side of a shaft seen mostly from one side when
        the axis is a few centimetres off), refitted once without the points more than
        three robust standard deviations off the cone.  The free centre takes up an
        axis off the shaft's (a cone fitted to a shaft seen mostly from one side):
        distances to such an axis are biased by up to that offset where the points are
        denser on one side.  The free taper takes up an axis leaning by the taper angle
        (the distances to it taper by another slope, draw 22: +0.018 m/m for -0.022),
        which moves the radius where the window is cut by the base.  The median
        distance to the axis when the cone runs off (radius beyond twice that, centre
        beyond half its radius from the axis); None with fewer than 20 points.
    """
    if len(rel) < 20:
        return None
    if len(rel) > 4000:
        keep = np.linspace(0, len(rel) - 1, 4000).astype(np.intp)
        rel, dh = rel[keep], dh[keep]
    from scipy.optimize import least_squares

    def spread(r: Array) -> tuple[Array, float]:  # |offsets from the median|, robust sigma
        off = np.abs(r - np.median(r))
        return off, 1.4826 * float(np.median(off))

    e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    xy = np.c_[rel @ e1, rel @ e2]
    # start: the cone about the axis (a chair or a sign touching the shaft pulls a
    # least-squares circle's centre towards it; a robust loss from the axis does not)
    on_axis = np.hypot(xy[:, 0], xy[:, 1]) - slope * dh
    _, sigma = spread(on_axis)
    r0 = float(np.median(on_axis))
    if not r0 > 0.0:
        return None
    keep = np.ones(len(xy), dtype=bool)
    x = np.r_[0.0, 0.0, r0, slope]
    for _ in range(2):  # the cone, then again without the points 3 sigma off it
        if keep.sum() < 20:
            break
        q, h = xy[keep], dh[keep]

        def res(v: Array, q: Array = q, h: Array = h) -> Array:
            return np.hypot(q[:, 0] - v[0], q[:, 1] - v[1]) - (v[2] + v[3] * h)

        try:
            sol = least_squares(res, x, loss="soft_l1", f_scale=max(sigma, 1e-3))
        except (ValueError, np.linalg.LinAlgError):
            return float(x[2])
        if not sol.success or not np.all(np.isfinite(sol.x)):
            return float(x[2])
        x = sol.x
        off, sigma = spread(np.hypot(xy[:, 0] - x[0], xy[:, 1] - x[1]) - (x[2] + x[3] * dh))
        new = off <= max(3.0 * sigma, 1e-4)
        if np.array_equal(new, keep):
            break
        keep = new
    if not 0.0 < x[2] < 2.0 * r0 or np.hypot(x[0], x[1]) > 0.5 * x[2]:
        return r0  # diverged (a few points of no shaft): the distance to the axis
    return float(x[2])


#: A column's points run along at least this arc of its ring (degrees) for its cylinder
#: to lie within them: the chord of the arc is what they must span.  A large column
#: far from every station, or seen between its neighbours, shows a quarter to a half
#: of its ring over its whole height (supports draw 39: a shaft of 1.26 m radius seen
#: over 100 degrees, its points spanning 2.01 m of its 2.51 m; draw 33: 1.64 of 2.11 m),
#: and its diameter is more than they span.
MIN_COLUMN_ARC_DEG = 90.0


def implausible(row: dict, pts: Array, sc: Scales) -> str:
    """Why a support's fitted primitive does not lie within its points ('' if it does).

    The centre must lie within the points' horizontal bounding box (a cylinder's centre
    may lie up to one radius outside it: the points of a partly scanned column are an
    arc), the primitive must not be larger than the points' extent (a column's points
    must span the chord of ``MIN_COLUMN_ARC_DEG`` of its ring), and the points must be
    at least one per point spacing along the primitive's size.  Slack: twice the
    surface tolerance.
    """
    lo = np.array([pts[:, 0].min(), pts[:, 1].min()])
    hi = np.array([pts[:, 0].max(), pts[:, 1].max()])
    span = float(np.hypot(*(hi - lo)))
    slack = 2.0 * sc.tol
    if row["class"] == "pier":
        size = float(np.nanmax([row["box_length_m"], row["box_width_m"]]))
        need = size
        margin = slack
        what = "box"
    else:
        size = 2.0 * float(row.get("cylinder_radius_m", row["radius_m"]))
        need = size * float(np.sin(np.radians(MIN_COLUMN_ARC_DEG) / 2))
        margin = slack + 0.5 * size
        what = "cylinder"
    if not np.isfinite(size):
        return ""  # no primitive was fitted: the section shape describes it
    if need > span + slack:
        return f"its {what} is {size:.2f} m across, its points span {span:.2f} m"
    centre = np.array([row["x"], row["y"]], dtype=np.float64)
    out = float(np.max(np.r_[lo - centre, centre - hi, 0.0]))
    if out > margin:
        return f"the {what}'s centre lies {out:.2f} m outside its points"
    if len(pts) < size / sc.spacing:
        return f"{len(pts)} points for a {what} {size:.2f} m across"
    return ""
