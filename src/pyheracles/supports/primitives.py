"""Primitives of the supports: cylinders of columns, boxes of piers; plausibility."""

from __future__ import annotations

import numpy as np

from pyheracles.geometry.fitting import fit_cylinder, fit_oriented_box
from pyheracles.supports.core import Array, Scales


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


def describe(pts: Array, rho: Array, sh: dict, tol: float) -> dict:
    """Objects-table row of one support (its points ``pts``) with its fitted primitive."""
    shaft = np.abs(rho) <= tol
    fit_pts = pts[shaft] if shaft.sum() >= 20 else pts
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
        "axis_x": nan,
        "axis_y": nan,
        "axis_z": nan,
        "box_length_m": nan,
        "box_width_m": nan,
        "box_height_m": nan,
        "fit_rms_m": nan,
        "circularity": sh.get("circularity", nan),
    }
    if sh["class"] in ("column", "engaged_column"):
        cyl = fit_cylinder(fit_pts, axis_hint=(0.0, 0.0, 1.0), f_scale=tol / 2)
        if cyl:  # second pass without base / capital mouldings: residuals within 3 sigma
            res = cyl.residuals(fit_pts)
            sigma = 1.4826 * np.median(np.abs(res - np.median(res)))
            close = np.abs(res - np.median(res)) <= max(3 * sigma, 1e-4)
            if close.sum() >= 20:
                cyl = fit_cylinder(fit_pts[close], axis_hint=cyl.axis, f_scale=max(sigma, 1e-3))
        if cyl:
            row.update(
                x=float(cyl.point[0]),
                y=float(cyl.point[1]),
                radius_m=cyl.radius,
                axis_x=float(cyl.axis[0]),
                axis_y=float(cyl.axis[1]),
                axis_z=float(cyl.axis[2]),
                fit_rms_m=cyl.rms,
            )
    else:
        box = fit_oriented_box(fit_pts, up=(0.0, 0.0, 1.0))
        if box:
            vert = int(np.argmax(np.abs(box.axes[2])))
            horiz = sorted((box.extents[k] for k in range(3) if k != vert), reverse=True)
            row.update(
                x=float(box.centre[0]),
                y=float(box.centre[1]),
                box_length_m=float(horiz[0]),
                box_width_m=float(horiz[1]),
                box_height_m=float(np.ptp(pts[:, 2])),
                fit_rms_m=box.rms,
                axis_x=float(box.axes[0, 0]),
                axis_y=float(box.axes[1, 0]),
                axis_z=float(box.axes[2, 0]),
            )
    if np.isnan(row["x"]):
        row["x"], row["y"] = (float(v) for v in sh["centre"])
    return row


def implausible(row: dict, pts: Array, sc: Scales) -> str:
    """Why a support's fitted primitive does not lie within its points ('' if it does).

    The centre must lie within the points' horizontal bounding box (a cylinder's centre
    may lie up to one radius outside it: the points of a partly scanned column are an
    arc), the primitive must not be larger than the points' extent, and the points must
    be at least one per point spacing along the primitive's size.  Slack: twice the
    surface tolerance.
    """
    lo = np.array([pts[:, 0].min(), pts[:, 1].min()])
    hi = np.array([pts[:, 0].max(), pts[:, 1].max()])
    span = float(np.hypot(*(hi - lo)))
    slack = 2.0 * sc.tol
    if row["class"] == "pier":
        size = float(np.nanmax([row["box_length_m"], row["box_width_m"]]))
        margin = slack
        what = "box"
    else:
        size = 2.0 * float(row["radius_m"])
        margin = slack + 0.5 * size
        what = "cylinder"
    if not np.isfinite(size):
        return ""  # no primitive was fitted: the section shape describes it
    if size > span + slack:
        return f"its {what} is {size:.2f} m across, its points span {span:.2f} m"
    centre = np.array([row["x"], row["y"]], dtype=np.float64)
    out = float(np.max(np.r_[lo - centre, centre - hi, 0.0]))
    if out > margin:
        return f"the {what}'s centre lies {out:.2f} m outside its points"
    if len(pts) < size / sc.spacing:
        return f"{len(pts)} points for a {what} {size:.2f} m across"
    return ""
