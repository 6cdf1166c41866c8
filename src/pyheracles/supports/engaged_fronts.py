"""Supports standing against a wall face: an engaged column or a respond pier, told by
the shape of their front, and free columns engaged by the wall face line their ring
meets (issue 12: engaged columns classed as piers or as free columns).

A support against a wall shows the wall's face running on beyond both its sides and,
between them, its front standing out into the room.  The front of a respond pier is a
straight face parallel to the wall; the front of an engaged (half or three-quarter)
column is an arc of its ring.  The respond stages (:mod:`~pyheracles.supports.responds`,
:mod:`~pyheracles.supports.line_responds`) outline a rectangle out of the face and took
the arc's rectangle for a pier (supports draw 0 and its noise draws: half columns of
0.2 m found as responds).  Here the front decides: a circle that explains the front
better than the rectangle, of a column's radius, with its axis near the face, is an
engaged column.

A column shaft whose wall beside it is shadowed (by the shaft itself, from most
stations) or cut by a window holds too few wall points near it for the local test
(:func:`~pyheracles.supports.rings.wall_face_beside`: draw 38, columns of 0.94 m with
15-66 points of their wall within 1.9 m, seen over less than their radius).  The
wall's face is still a line of the slab over metres
(:func:`~pyheracles.supports.line_responds.face_lines`): a column whose ring meets that
line (its axis within ``axis_share x radius`` of it, the ring on one side only) and
lies within the face's extent stands in that wall.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pyheracles.geometry.fitting import fit_circle
from pyheracles.supports.core import Array, trimmed_rms


@dataclass(frozen=True)
class FrontParams:
    """The front of a support against a wall face.

    Attributes
    ----------
    radius_m
        Radii of the engaged columns an arc front may be, metres (a respond's rounded
        corner is a few centimetres; the family's and the thesis' half columns are
        0.15-1.5 m).
    axis_share
        The axis of an engaged column lies within this share of its radius of its
        wall's face (a half column on it, a three-quarter column 0.6 r in front of it):
        a ring whose axis is further out stands free of the wall.
    behind_share
        Share of the ring's points allowed beyond the face by more than the tolerance
        (a ring that goes on behind the face line is a free column in line with a wall).
    face_margin_m
        A column is in a face line's wall when its axis lies within the extent of the
        line's points along it, grown by its radius and this much, metres (a wall's
        end shadowed by the column beside it).
    """

    radius_m: tuple[float, float] = (0.15, 1.5)
    axis_share: float = 0.6
    behind_share: float = 0.02
    face_margin_m: float = 0.5


FRONTS = FrontParams()


def arc_front(
    p: Array, n: Array, d: float, side: float, tol: float, fp: FrontParams = FRONTS
) -> tuple[Array, float] | None:
    """The circle of an engaged column whose front the points ``p`` (a bump standing out
    of the face ``n . x = d`` on the ``side`` of it) outline, or None (a flat front: a
    respond pier).

    The bump's points off the face (beyond ``tol``) are fitted with a circle and with the
    rectangle of the bump (its two sides, at the 2 % and 98 % quantiles along the face,
    and its front, at the 95 % quantile of the depth out of it); the front is an arc when
    the circle's trimmed RMS is below the rectangle's, its radius within ``radius_m``
    and its centre within ``axis_share`` of the radius (plus ``tol``) of the face.

    Returns
    -------
    tuple or None
        ``(centre, radius)`` of the arc, metres.
    """
    front = side * (p @ n - d)
    q = p[front > tol]
    if len(q) < 8:
        return None
    circle = fit_circle(q)
    if not circle or not fp.radius_m[0] <= circle.radius <= fp.radius_m[1]:
        return None
    centre, radius = np.asarray(circle.center, dtype=np.float64), float(circle.radius)
    if abs(float(centre @ n - d)) > fp.axis_share * radius + tol:
        return None
    t = q @ np.array([-n[1], n[0]])
    f = side * (q @ n - d)
    t_lo, t_hi = np.quantile(t, [0.02, 0.98])
    depth = float(np.quantile(f, 0.95))
    rect = np.minimum(np.minimum(np.abs(t - t_lo), np.abs(t - t_hi)), np.abs(f - depth))
    if trimmed_rms(circle.residuals(q)) >= trimmed_rms(rect):
        return None
    return centre, radius


def engaged_shape(centre: Array, radius: float, n: Array, d: float, face_rms: float) -> dict:
    """The section shape of an engaged column of circle ``centre``, ``radius`` standing
    in the wall face ``n . x = d`` (``n`` into the room), its noise ``face_rms``."""
    return {
        "class": "engaged_column",
        "centre": np.asarray(centre, dtype=np.float64),
        "radius": float(radius),
        "half": np.array([radius, radius]),
        "angle": 0.0,
        "normal": np.asarray(n, dtype=np.float64),
        "d": float(d),
        "face_gap": max(0.01, 3.0 * face_rms),
        "circularity": float("nan"),
    }


def ring_on_face_line(
    ring: Array,
    centre: Array,
    radius: float,
    lines: list[tuple[Array, float, float, Array]],
    tol: float,
    fp: FrontParams = FRONTS,
) -> tuple[Array, float, float] | None:
    """The wall face line a column's ring meets, or None.

    Parameters
    ----------
    ring
        ``(K, 2)`` the section's points on the column's ring.
    centre, radius
        The ring's circle, metres.
    lines
        The slab's wall face lines, ``(n, d, rms, points)`` each (``n . x = d`` on it,
        ``points``: its inliers' plan positions).
    tol
        Surface tolerance, metres.

    Returns
    -------
    tuple or None
        ``(unit normal into the room, offset d, face RMS)`` of the first line that
        passes within ``axis_share x radius + tol`` of the axis, with at most
        ``behind_share`` of the ring beyond it by ``tol`` and the axis within the
        extent of its points along it (grown by ``radius + face_margin_m``).
    """
    if len(ring) < 8:
        return None
    for n, d, rms, pts in lines:
        if abs(float(centre @ n - d)) > fp.axis_share * radius + tol:
            continue
        tangent = np.array([-n[1], n[0]])
        along = pts @ tangent
        at = float(centre @ tangent)
        grow = radius + fp.face_margin_m
        if not along.min() - grow <= at <= along.max() + grow:
            continue
        side = float(np.sign(np.median(ring @ n - d)))
        if side == 0 or np.mean(side * (ring @ n - d) < -tol) > fp.behind_share:
            continue
        return side * n, side * d, rms
    return None
