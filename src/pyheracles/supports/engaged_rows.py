"""Engaged columns told by their row: rings cut on one straight line.

An engaged column whose wall was never scanned beside it (a ruin whose walls end below
the section, all stations outside: supports draw 24) shows no face to find
(:func:`~pyheracles.supports.rings.wall_face_beside` needs one).  What is left is the
shaft itself: its ring stops at the wall's plane, a little behind its centre, at both
ends of its arc; and the rings of the columns standing along one wall stop on ONE line.
A free column seen from stations on one side stops where its tangent rays touch it,
which turns with the direction of the stations from each column: the two ends of its
arc lie at different depths, and its neighbours' arcs end elsewhere.

The test is the arc's geometry in the row's frame, not a count of points: per column
of a row (``min_columns`` round shapes of about one radius, centres on a line), the
back of its ring (a low quantile of the depths of its points along the row's normal)
lies at most ``max_offset_share`` of its radius behind its centre, both ends of the arc
reach that depth, its front faces the room; and the absolute positions of those cuts
agree within the surface tolerance along the row.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.core import Array, Scales

#: Points more than this behind the line a column's ring stops on are the wall's,
#: metres: the line lies at the back of the ring already (a low quantile of its
#: depths); the row's line, or a tolerance in front, cut the ends of the arcs off (draw
#: 24: F1 of the engaged columns 0.99 as free columns, 0.85-0.95 so cut).
ROW_FACE_GAP_M = 0.01


@dataclass(frozen=True)
class RowCutParams:
    """Settings of :func:`row_cut_columns`.

    Attributes
    ----------
    min_columns
        Columns of one row whose arcs must stop on one line.
    radius_ratio
        The radii of a row's columns lie within this ratio of each other.
    centre_share
        A column belongs to a row when its centre lies within this share of its radius
        (or the surface tolerance, if larger) of the row's line, metres per metre.
    slab_m
        Half thickness of the slab whose points round a column are its ring, metres.
    back_quantile
        Quantile of the ring points' depths along the row's normal taken as the back of
        the ring (a few stray points behind are noise).
    max_offset_share
        The back lies at most this share of the radius behind the centre: a half or
        three-quarter column (its axis up to half its radius in front of the wall's
        face; the back quantile lies a little behind that face).  A free column seen from
        one side only wraps further (draw 24, noise draws 2 and 3: the free row beside
        an engaged one, its floor not seen either, stopped 0.57-0.64 r behind).
    front_share
        The ring reaches this share of its radius in front of its centre (it faces the
        room).
    end_share
        Both ends of the arc reach the back line at least this share of the chord's half
        length out from the centre, one on each side.
    min_ring_points
        Ring points a column needs for its cut to be read.
    behind_m, behind_per_m, floor_band_m
        Depth behind a row's line, metres, in which at most ``behind_per_m`` points of
        the floor (within ``floor_band_m`` of the floor the supports stand on, metres)
        per metre of the row may be seen: the wall is solid, while through a free
        colonnade the floor beyond it is seen (the top of a ruined wall is no floor;
        the floor in front may be shadowed too: supports draw 24).
    """

    min_columns: int = 3
    radius_ratio: float = 1.25
    centre_share: float = 0.25
    slab_m: float = 0.15
    back_quantile: float = 0.02
    max_offset_share: float = 0.45
    front_share: float = 0.7
    end_share: float = 0.5
    min_ring_points: int = 8
    behind_m: float = 1.0
    behind_per_m: float = 1.0
    floor_band_m: float = 0.15


def column_rows(
    centres: Array, radii: Array, tol: float, params: RowCutParams
) -> list[tuple[NDArray[np.intp], Array]]:
    """Rows of columns: sets of at least ``min_columns`` centres of about one radius on a
    straight line.

    Parameters
    ----------
    centres
        ``(N, 2)`` plan centres of the round shapes, metres.
    radii
        ``(N,)`` their radii, metres.
    tol
        Surface tolerance, metres.
    params
        Row settings.

    Returns
    -------
    list of (members, direction)
        Indices of the members (sorted, each set once) and the row's unit direction.
    """
    n = len(centres)
    rows: list[tuple[NDArray[np.intp], Array]] = []
    seen: set[tuple[int, ...]] = set()
    for i in range(n):
        like = np.maximum(radii, radii[i]) <= params.radius_ratio * np.minimum(radii, radii[i])
        for j in range(i + 1, n):
            if not like[j]:
                continue
            u = centres[j] - centres[i]
            length = float(np.hypot(*u))
            if length == 0.0:
                continue
            u = u / length
            nrm = np.array([-u[1], u[0]])
            off = np.abs((centres - centres[i]) @ nrm)
            near = like & (off <= np.maximum(tol, params.centre_share * radii))
            members = np.flatnonzero(near)
            key = tuple(members.tolist())
            if len(members) >= params.min_columns and key not in seen:
                seen.add(key)
                rows.append((members, u))
    return rows


def arc_cut(
    ring: Array, centre: Array, radius: float, u: Array, m: Array, tol: float,
    params: RowCutParams,
) -> float | None:  # fmt: skip
    """Depth of the line a column's ring stops on, behind its centre, or None.

    Parameters
    ----------
    ring
        ``(K, 2)`` plan points of the column's ring.
    centre, radius
        The column's circle, metres.
    u, m
        Unit direction of the row and unit normal towards the side the column faces.
    tol
        Surface tolerance, metres.
    params
        Row settings.

    Returns
    -------
    float or None
        ``b`` (metres, <= tol; the line lies at ``m . x = m . centre + b``) when the back
        of the ring lies within ``max_offset_share`` of the radius behind the centre,
        the front reaches ``front_share`` of the radius and both ends of the arc reach
        the back line; else None.
    """
    if len(ring) < params.min_ring_points:
        return None
    q = ring - centre
    t, s = q @ m, q @ u
    b = float(np.quantile(t, params.back_quantile))
    if b > tol or -b > params.max_offset_share * radius:
        return None
    if float(np.quantile(t, 1.0 - params.back_quantile)) < params.front_share * radius:
        return None
    reach = params.end_share * np.sqrt(max(radius * radius - b * b, 0.0))
    end = s[t <= b + tol]
    if not (np.any(end >= reach) and np.any(end <= -reach)):
        return None
    return b


def row_cut_columns(
    centres: Array, radii: Array, rings: list[Array], tol: float,
    params: RowCutParams | None = None,
    behind: Callable[[Array, float, Array], int] | None = None,
) -> dict[int, tuple[Array, float]]:  # fmt: skip
    """Columns engaged in a wall that was not seen: in a row whose rings all stop on one
    straight line.

    Parameters
    ----------
    centres
        ``(N, 2)`` plan centres of the round shapes, metres.
    radii
        ``(N,)`` their radii, metres.
    rings
        Per shape, ``(K, 2)`` plan points of its ring.
    tol
        Surface tolerance, metres.
    params
        Row settings.
    behind
        ``behind(m, d, span)``: how many points of the floor lie behind the line ``m . x
        = d`` (within ``behind_m``) along the row's ``span`` (two plan end points); a
        row is engaged when at most ``behind_per_m`` per metre of it do (a wall is
        solid; through a free colonnade the floor beyond it is seen).  None: not
        tested.

    Returns
    -------
    dict
        Per engaged shape (index), ``(unit normal into the room, offset d)`` of the line
        ``n . x = d`` its own ring stops on (the wall's face; the row's line within
        ``tol``).  A shape in rows cut on lines of other directions or facing the other
        way is left out.
    """
    params = params or RowCutParams()
    centres = np.asarray(centres, dtype=np.float64).reshape(-1, 2)
    radii = np.asarray(radii, dtype=np.float64)
    found: dict[int, tuple[Array, float]] = {}
    clash: set[int] = set()
    for members, u in column_rows(centres, radii, tol, params):
        nrm = np.array([-u[1], u[0]])
        for m in (nrm, -nrm):
            cuts = {
                int(k): b
                for k in members
                if (b := arc_cut(rings[k], centres[k], radii[k], u, m, tol, params)) is not None
            }
            if len(cuts) < params.min_columns:
                continue
            keys = np.array(list(cuts))
            lines = centres[keys] @ m + np.array(list(cuts.values()))
            d = float(np.median(lines))
            on = keys[np.abs(lines - d) <= tol]
            if len(on) < params.min_columns:
                continue
            along = centres[on] @ u
            ends = np.array([centres[on[np.argmin(along)]], centres[on[np.argmax(along)]]])
            length = float(np.hypot(*(ends[1] - ends[0])))
            nb = behind(m, d, ends) if behind is not None else 0
            if nb > params.behind_per_m * length:
                continue
            for k in on.tolist():
                if k in found and float(found[k][0] @ m) < 0.99:
                    clash.add(k)  # cut on lines of other directions or sides
                found.setdefault(k, (m, float(centres[k] @ m) + cuts[k]))
    return {k: v for k, v in found.items() if k not in clash}


def engage_rows(
    p: Array,
    order: NDArray[np.intp],
    z_sorted: Array,
    shapes: list[dict],
    h_sec: float,
    sc: Scales,
    floor_z: float,
    params: RowCutParams | None = None,
) -> int:
    """Turn the free column shapes of rows cut on one line into engaged ones, in place
    (:func:`row_cut_columns`); returns how many.

    Each shape's ring is read among the points of a slab ``slab_m`` above and below its
    section (``sh["h_sec"]`` or ``h_sec``), within ``max(2 tol, 0.1 r)`` of its circle.
    An engaged shape gets the line as its wall face (``normal``, ``d``) and
    ``row_cut = True``: no face of a wall may be found beside it.  What lies behind a
    row's line is counted among the points within ``floor_band_m`` of ``floor_z`` (the
    floor the supports stand on, metres).
    """
    params = params or RowCutParams()
    cols = [k for k, sh in enumerate(shapes) if sh["class"] == "column"]
    if len(cols) < params.min_columns:
        return 0
    centres = np.array([np.asarray(shapes[k]["centre"], dtype=np.float64) for k in cols])
    radii = np.array([float(shapes[k]["radius"]) for k in cols])
    slabs: dict[float, tuple[Array, Array]] = {}  # per section height: points sorted by x
    rings: list[Array] = []
    for c, r, k in zip(centres, radii, cols, strict=True):
        h = float(shapes[k].get("h_sec", h_sec))
        if h not in slabs:
            a, b = np.searchsorted(z_sorted, [h - params.slab_m, h + params.slab_m])
            xy = p[order[a:b], :2]
            xy = xy[np.argsort(xy[:, 0], kind="stable")]
            slabs[h] = (xy, xy[:, 0])
        xy, xs = slabs[h]
        reach = r + 2.0 * sc.tol
        a, b = np.searchsorted(xs, [c[0] - reach, c[0] + reach])
        near = xy[a:b]
        near = near[np.abs(near[:, 1] - c[1]) <= reach]
        dist = np.hypot(*(near - c).T)
        rings.append(near[np.abs(dist - r) <= max(2.0 * sc.tol, 0.1 * r)])
    band: list[Array] = []  # plan points from the floor up to the section, read once

    def behind(m: Array, d: float, ends: Array) -> int:
        """Floor points seen behind the line ``m . x = d`` along the row between ``ends``."""
        if not band:
            a, b = np.searchsorted(
                z_sorted, [floor_z - params.floor_band_m, floor_z + params.floor_band_m]
            )
            band.append(p[order[a:b], :2])
        xy = band[0]
        u = np.array([-m[1], m[0]])
        lo, hi = np.sort(ends @ u)
        t = xy @ m - d
        s = xy @ u
        along = (s >= lo) & (s <= hi)
        return int(np.count_nonzero(along & (t < -sc.tol) & (t > -params.behind_m)))

    found = row_cut_columns(centres, radii, rings, sc.tol, params, behind)
    for k, (n, d) in found.items():
        sh = shapes[cols[k]]
        r = float(sh["radius"])
        sh["class"] = "engaged_column"
        # the wall: what lies more than ROW_FACE_GAP_M behind the ring's back
        sh.update(normal=n, d=d - 2.0 * ROW_FACE_GAP_M, face_gap=ROW_FACE_GAP_M, angle=0.0)
        sh["row_cut"] = True
        sh["half"] = np.array([r, r])
    return len(found)
