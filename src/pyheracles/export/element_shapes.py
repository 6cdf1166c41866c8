"""Shapes of IFC elements measured from their points.

What the objects table does not give and the IFC body needs: the radius profile of a
tapered column (the densest ring of distances per station), the outline of its plinth
and capital slabs, the point of a tilted axis at the element's foot and the roll of a
member's section rectangle about its axis.  Used by :mod:`pyheracles.export.ifc`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

__all__ = ["axis_base", "part_slabs", "radius_profile", "section_roll", "surface_radius"]


def surface_radius(d: Array, window_m: float) -> tuple[float, float]:
    """(radius, scatter) of the densest ring of distances ``d`` to an axis.

    The radius is the median of the distances within ``window_m`` of the centre of the
    densest window of that width (the column's surface), the scatter their robust
    standard deviation: a plinth, a base moulding or a capital in the same slice
    spreads its distances over a wide range and moves neither.
    """
    d = np.sort(d)
    if len(d) == 0:
        return math.nan, math.nan
    hi = np.searchsorted(d, d + window_m, side="right")
    k = int(np.argmax(hi - np.arange(len(d))))
    centre = 0.5 * (d[k] + d[hi[k] - 1])
    near = d[np.abs(d - centre) <= window_m]
    r = float(np.median(near))
    return r, 1.4826 * float(np.median(np.abs(near - r)))


def radius_profile(
    pts: Array,
    base: Array,
    axis: Array,
    length: float,
    *,
    stations: int = 8,
    min_change_m: float = 0.005,
    radius: float | None = None,
    band: float = 0.3,
    at: float | None = None,
) -> Array | None:
    """(radius, height) of a column at ``stations`` heights, or None for a straight one.

    The radius at a station is the radius of the densest ring of distances to the
    fitted axis among the points of its slice within ``band`` x ``radius`` of
    ``radius`` (:func:`surface_radius`, window ``max(1 cm, 0.05 radius)``; a plinth,
    the sides of an abacus or a capital in the slice do not move it; a taper of more
    than ``band`` either side of the mean radius is cut there);
    a column is written as a solid of revolution of these radii when they change
    along it (taper, entasis) by more than ``min_change_m`` and three times the
    scatter of the points about their slice's radius; else as a cylinder.  The
    stations run from the base (0) to ``length``; slices with fewer than 20 points are
    interpolated from their neighbours.  ``radius`` (the fitted cylinder's, from the
    objects table) sets the window and the level: the radii are shifted so that the
    profile's radius at ``at`` (height along the axis where the table's radius holds:
    its ``radius_height_m``) is ``radius``, without ``at`` so that their mean over the
    measured stations is (the solid agrees with the table; the change of radius along
    the axis is what is measured).  Without it the window
    is from the median distance to the axis and the radii are as measured.
    """
    if len(pts) < 20 * stations or not math.isfinite(length) or length <= 0:
        return None
    rel = pts - base
    t = rel @ axis
    d = np.linalg.norm(rel - np.outer(t, axis), axis=1)
    ref = float(np.median(d)) if radius is None or not math.isfinite(radius) else radius
    window = max(0.01, 0.05 * ref)
    edges = np.linspace(0.0, length, stations + 1)
    k = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, stations - 1)
    r = np.full(stations, np.nan)
    spread = []
    near = np.abs(d - ref) <= band * ref  # plausible shaft radii: not a plinth, an abacus
    for i in range(stations):
        di = d[(k == i) & near]
        if len(di) >= 20:
            r[i], sd = surface_radius(di, window)
            spread.append(sd)
    ok = np.isfinite(r)
    if ok.sum() < 3:
        return None
    mid = 0.5 * (edges[:-1] + edges[1:])
    r = np.interp(mid, mid[ok], r[ok])
    noise = float(np.median(spread))
    if np.ptp(r) <= max(min_change_m, 3 * noise):
        return None
    # end stations from the nearest slices' trend, so the solid spans the whole height
    lo = r[0] + (r[0] - r[1]) * 0.5
    hi = r[-1] + (r[-1] - r[-2]) * 0.5
    radii, heights = np.r_[lo, r, hi], np.r_[0.0, mid, length]
    if radius is not None and math.isfinite(radius):
        if at is not None and math.isfinite(at):  # the table's radius holds at ``at``
            radii = radii + (radius - float(np.interp(at, heights, radii)))
        else:
            radii = radii + (radius - float(radii[1:-1].mean()))
    return np.column_stack([np.clip(radii, 1e-3, None), heights])


def part_slabs(
    local: Array,
    lo: float,
    hi: float,
    *,
    noise: float = 0.005,
    layer_m: float = 0.03,
    sectors: int = 72,
    min_points: int = 3,
) -> list[tuple[Array, float, float]]:
    """Outlines of a support's plinth, base, capital or abacus: (ring, t0, t1) slabs.

    ``local`` are the support's points in its element frame (x, y across the axis, t
    along it from the base); the band ``lo`` .. ``hi`` along the axis (from the
    objects table's ``base_top_m`` / ``capital_bottom_m``, one layer more each side) is
    cut into layers of ``layer_m``; a layer's reach is the distance from the axis of
    its outer surface (the median of the points within ``2.5 noise`` below its 95th
    percentile distance: the sides of a square plinth or abacus, a torus, an echinus;
    not a top face, not the noise's outer tail).  Runs of layers whose reach stays
    within ``max(2.5 noise, 1 cm)`` of the run's median (a plinth, a step of a torus,
    an abacus) make one slab, so a sparse band is judged on all its points and the
    steps fall where the reach changes.  A slab's outline is star-shaped about the
    axis: per sector of angle (``sectors`` of them) with at least ``min_points``
    points, a vertex at the centroid of its outer surface's points; fewer than 3
    sectors give no slab.  A sparse slab (fewer than 4 x ``min_points`` points a
    sector) is outlined by the convex hull of its points moved ``noise`` inwards, less
    the points standing out of the outline their neighbours in angle draw (mixed
    pixels, floor returns: :func:`_no_radial_spikes`).  Adjacent runs of fewer than
    ``3 x min_points`` points are joined first (:func:`_merge_sparse_runs`), so a sparse
    part is kept, not dropped.  Each slab is then extruded from ``t0`` to ``t1`` as an
    extra body item.
    """
    out: list[tuple[Array, float, float]] = []
    if len(local) == 0 or not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return out
    t = local[:, 2]
    sel = (t >= lo) & (t <= hi)
    q, tq = local[sel, :2], t[sel]
    d = np.hypot(q[:, 0], q[:, 1])
    ang = np.arctan2(q[:, 1], q[:, 0]) % (2 * math.pi)
    n = max(1, math.ceil((hi - lo) / layer_m))
    edges = np.linspace(lo, hi, n + 1)
    lay = np.clip(np.searchsorted(edges, tq, side="right") - 1, 0, n - 1)
    win = 2.5 * max(noise, 0.002)

    def outer(dd: Array) -> float:  # the outer surface's distance among distances dd
        top = float(np.quantile(dd, 0.95))
        return float(np.median(dd[dd >= top - win]))

    reach = np.array([outer(d[lay == i]) if (lay == i).sum() >= min_points else np.nan
                      for i in range(n)])  # fmt: skip
    seen = np.flatnonzero(np.isfinite(reach))
    if len(seen) == 0:
        return out
    reach = np.interp(np.arange(n), seen, reach[seen])
    # runs of layers of one reach (a plinth, a torus step, an abacus): one slab each
    step = max(2.5 * noise, 0.01)
    groups, first = [], 0
    for i in range(1, n + 1):
        if i == n or abs(reach[i] - float(np.median(reach[first:i]))) > step:
            groups.append((first, i))
            first = i
    per_layer = np.bincount(lay, minlength=n)
    for g0, g1 in _merge_sparse_runs(groups, reach, per_layer, 3 * min_points):
        m = (lay >= g0) & (lay < g1)
        if m.sum() < 3:
            continue
        if m.sum() < 4 * min_points * sectors:  # sparse: the hull of the points, less
            # the noise (each point is on the surface), without radial spikes
            ring = _hull(q[m][_no_radial_spikes(ang[m], d[m], max(3.0 * noise, 0.01))], noise)
            if ring is not None:
                out.append((ring, float(edges[g0]), float(edges[g1])))
            continue
        ns = sectors
        sec = np.minimum((ang[m] * (ns / (2 * math.pi))).astype(np.intp), ns - 1)
        dm, qm = d[m], q[m]
        ring_l = []
        for j in range(ns):
            dd = dm[sec == j]
            if len(dd) >= min_points:  # the vertex: the centroid of the outer surface's
                top = float(np.quantile(dd, 0.95))  # points (on a flat side: on it)
                ring_l.append(qm[sec == j][dd >= top - win].mean(axis=0))
        if len(ring_l) < 3:
            continue
        ring = np.asarray(ring_l)
        out.append((ring, float(edges[g0]), float(edges[g1])))
    return _face_levels(out, q, tq, win, min_points)


def _level(t: Array, win: float, top: bool) -> float:
    """The level of a horizontal face among heights ``t``: the median of those within
    ``win`` of their 95th (``top``) or 5th percentile, as :func:`part_slabs` takes the
    outer surface among distances."""
    edge = float(np.quantile(t, 0.95 if top else 0.05))
    return float(np.median(t[t >= edge - win] if top else t[t <= edge + win]))


def _face_levels(
    slabs: list[tuple[Array, float, float]], q: Array, tq: Array, win: float, min_points: int
) -> list[tuple[Array, float, float]]:
    """Slabs whose ends lie on the measured faces, not on the layers' edges.

    A step between two slabs (a plinth's top, an abacus' underside) is a horizontal face
    at some height inside a 3 cm layer; ending the slabs at the layer's edge left the
    face's points up to a layer from the solid (supports draw 0, column 9: a plinth's
    top face, 5,742 points, 2.4 cm under its slab's top; IFC surface RMS 1.1 cm for the
    column).  Between two slabs stacked one on the other, the points of the wider one
    outside the narrower one's outline end at the face: its level (:func:`_level`) is the
    new boundary, and the narrower slab reaches it.  The lowest slab starts where its
    points start, the highest ends where they end (on the floor or the entablature
    the support meets; the band's edge lay up to a layer beyond them; their 1st / 99th
    percentile instead made 10 of the 10 draws' columns worse, up to 2.6 mm).
    Boundaries only move inwards (within the slabs' layers), and a slab keeps at least
    a tenth of a layer.
    """
    import shapely

    if not slabs:
        return slabs
    rings = [r for r, _, _ in slabs]
    t0s = [a for _, a, _ in slabs]
    t1s = [b for _, _, b in slabs]
    polys = [shapely.Polygon(r).buffer(0) for r in rings]
    eps = 0.1 * min(b - a for a, b in zip(t0s, t1s, strict=True))

    def inside(small: Any, big: Any) -> bool:  # the small outline within the big one
        return bool(small.area > 0 and small.difference(big).area < 0.1 * small.area)

    def outside(lo: float, hi: float, outline: Any) -> NDArray[np.bool_]:
        """The points from ``lo`` to ``hi`` outside ``outline``."""
        sel = (tq >= lo) & (tq <= hi)
        sel[sel] = ~shapely.contains_xy(outline, q[sel, 0], q[sel, 1])
        return sel

    for k in range(len(slabs) - 1):
        b = t1s[k]
        if abs(t0s[k + 1] - b) > 1e-9 or not (polys[k].is_valid and polys[k + 1].is_valid):
            continue
        lo, hi = t0s[k], t1s[k + 1]
        if inside(polys[k + 1], polys[k]):  # a step in: the wider slab's top face
            own = outside(lo, b, polys[k + 1])
            if own.sum() >= min_points:
                b = min(b, max(_level(tq[own], win, top=True), lo + eps))
        elif inside(polys[k], polys[k + 1]):  # a step out: the wider slab's underside
            own = outside(b, hi, polys[k])
            if own.sum() >= min_points:
                b = max(b, min(_level(tq[own], win, top=False), hi - eps))
        t1s[k], t0s[k + 1] = b, b
    for k, top in ((0, False), (len(slabs) - 1, True)):
        sel = (tq >= t0s[k]) & (tq <= t1s[k])
        if sel.sum() >= min_points:  # the support's own end: the floor, the entablature
            lv = _level(tq[sel], win, top=top)
            if top:
                t1s[k] = min(t1s[k], max(lv, t0s[k] + eps))
            else:
                t0s[k] = max(t0s[k], min(lv, t1s[k] - eps))
    return [(r, a, b) for r, a, b in zip(rings, t0s, t1s, strict=True)]


def _merge_sparse_runs(
    runs: list[tuple[int, int]], reach: Array, per_layer: NDArray[np.intp], min_count: int
) -> list[tuple[int, int]]:
    """Runs of layers, adjacent runs of fewer than ``min_count`` points joined.

    On a sparse support (a few scan lines across its plinth or capital) every 3 cm layer
    has its own reach, each run holds a handful of points, and dropping such runs left
    the part out of the body (a column's 4-30 capital or plinth points 10-17 cm from its
    solid).  A sparse run joins an adjacent sparse run (the one whose median reach is
    nearest its own), the sparsest first, until it holds ``min_count`` points or has no
    sparse neighbour; a sparse run between dense ones stays a slab of its own (joined
    to a dense run, it widened that run's slab beyond the points of its other layers).
    """
    runs = list(runs)

    def count(r: tuple[int, int]) -> int:
        return int(per_layer[r[0] : r[1]].sum())

    def level(r: tuple[int, int]) -> float:
        return float(np.median(reach[r[0] : r[1]]))

    while True:
        counts = [count(r) for r in runs]
        pairs = [
            (counts[i], i, j)
            for i in range(len(runs))
            if counts[i] < min_count
            for j in (i - 1, i + 1)
            if 0 <= j < len(runs) and counts[j] < min_count
        ]
        if not pairs:
            return runs
        low = min(c for c, _, _ in pairs)
        i = next(i for c, i, _ in pairs if c == low)
        sides = [j for c, k, j in pairs if k == i]
        j = min(sides, key=lambda s: abs(level(runs[s]) - level(runs[i])))
        a, b = min(i, j), max(i, j)
        runs[a : b + 1] = [(runs[a][0], runs[b][1])]


def _no_radial_spikes(
    ang: Array, d: Array, tol: float, k: int = 4, min_points: int = 200
) -> NDArray[np.bool_]:
    """Points not sticking out of the outline their angular neighbours draw.

    A point more than ``tol`` farther from the axis than the second farthest of its
    ``k`` neighbours on each side in angle is a spike: a mixed pixel at a plinth's edge, a
    floor return beyond it.  The convex hull of a sparse slab passes through such
    points, and supports draw 3's plinths bulged 8 cm beyond their faces; a square's
    corner is no spike (its neighbours in angle are nearly as far).  Fewer than
    ``min_points`` points: all kept (a few scan lines across a moulding are neighbours
    in angle only far apart, and each of them draws the outline; in supports draw 7 a
    plinth's 140 points had its faces' points among those of its top face, nearer the
    axis, and they passed for spikes).
    """
    n = len(d)
    keep = np.ones(n, dtype=bool)
    if n < max(min_points, 4 * k):
        return keep
    order = np.argsort(ang)
    ds = d[order]
    # the neighbours' distances around the circle: columns -k .. -1, 1 .. k
    shifts = [s for s in range(-k, k + 1) if s]
    nb = np.column_stack([np.roll(ds, -s) for s in shifts])
    # beyond the second farthest of them: a face's point among points of the slab's top
    # face (nearer the axis) has another of the face's points among its neighbours
    keep[order] = ds <= np.sort(nb, axis=1)[:, -2] + tol
    return keep


def _hull(q: Array, inset: float) -> Array | None:
    """Convex hull of 2-D points ``q`` moved ``inset`` inwards (None if degenerate)."""
    import shapely

    poly = shapely.MultiPoint(q).convex_hull
    if poly.geom_type != "Polygon":
        return None
    inner = poly.buffer(-inset, join_style="mitre") if inset > 0 else poly
    if inner.is_empty or inner.geom_type != "Polygon" or inner.area < 0.5 * poly.area:
        inner = poly
    return np.asarray(inner.exterior.coords)[:-1]


def axis_base(
    pts: Array, xy: Array, axis: Array, radius: float, z_min: float, *, grid_m: float = 0.005
) -> Array:
    """Point of a support's fitted axis at height ``z_min``.

    The objects table gives the axis direction and one point of it in plan (``x``,
    ``y``), at the unknown height of the fit (mid-height of the fitted points): for a
    tilted axis the vertical through (``x``, ``y``) meets the axis there only.  The
    axis is the line of that direction through the vertical at the height that fits the
    points best at the table's ``radius`` (truncated least squares of the distance to
    the axis minus the radius, residuals beyond ``max(1 cm, 0.1 radius)`` count as
    that: mouldings, plinths, capitals); a grid of ``grid_m`` sideways steps, then a
    bounded refinement.  A vertical axis (sideways shift below ``grid_m`` over the
    points' height) is taken through (``x``, ``y``) as it is.
    """
    from scipy.optimize import minimize_scalar

    ez = np.array([0.0, 0.0, 1.0])
    lo, hi = (float(pts[:, 2].min()), float(pts[:, 2].max())) if len(pts) else (z_min, z_min)
    u = ez - axis[2] * axis  # sideways move of the axis per metre moved up the vertical
    sin_tilt = float(np.linalg.norm(u))
    ref = np.array([xy[0], xy[1], 0.5 * (lo + hi)])
    if len(pts) >= 20 and (hi - lo) * sin_tilt > grid_m:
        rel = pts - ref
        perp = rel - np.outer(rel @ axis, axis)
        cap = max(0.01, 0.1 * radius) ** 2

        def cost(s: float) -> float:
            d = np.linalg.norm(perp - s * u, axis=1) - radius
            return float(np.minimum(d * d, cap).sum())

        half = 0.5 * (hi - lo)
        grid = np.linspace(-half, half, max(3, int(2 * half * sin_tilt / grid_m) + 1))
        k = int(np.argmin([cost(s) for s in grid]))
        step = grid[1] - grid[0]
        s = minimize_scalar(cost, bounds=(grid[k] - step, grid[k] + step), method="bounded")
        ref = ref + float(s.x) * ez
    if axis[2] < 1e-6:  # a horizontal axis: no height to move along it
        return np.array([xy[0], xy[1], z_min])
    return ref + (z_min - ref[2]) / axis[2] * axis


def section_roll(q: Array, width: float, height: float, *, step_deg: float = 1.0) -> float:
    """Angle (rad) of the first side of a known rectangle that its points outline.

    ``q`` are 2-D points relative to the rectangle's centre: a member's points in its
    cross-section plane (first axis the horizontal across the member: the width
    direction of the objects table when the section is not rolled), or a pier's
    points in plan.  The angle puts the ``width`` x ``height`` rectangle where its
    boundary is closest to the points (truncated least squares of the distance to the
    boundary, residuals beyond ``max(1 cm, 0.1 x the smaller side)`` count as that:
    joints, neighbours), searched over half a turn (the rectangle's symmetry) in
    ``step_deg`` steps, then refined.  An element seen on one or two faces is placed by
    those faces (a principal direction of its points would not be a side); no
    points: 0.
    """
    from scipy.optimize import minimize_scalar

    if len(q) < 3 or not (width > 0 and height > 0):
        return 0.0
    if len(q) > 4000:
        q = q[np.linspace(0, len(q) - 1, 4000).astype(np.intp)]
    half = np.array([0.5 * width, 0.5 * height])
    cap = max(0.01, 0.1 * min(width, height)) ** 2

    def cost(a: float) -> float:
        c, s = math.cos(a), math.sin(a)
        loc = np.abs(q @ np.array([[c, -s], [s, c]])) - half
        out = np.linalg.norm(np.maximum(loc, 0.0), axis=1)
        d = np.where(out > 0, out, -loc.max(axis=1))
        return float(np.minimum(d * d, cap).sum())

    step = math.radians(step_deg)
    grid = np.arange(-0.5 * math.pi, 0.5 * math.pi, step)
    k = int(np.argmin([cost(a) for a in grid]))
    best = minimize_scalar(cost, bounds=(grid[k] - step, grid[k] + step), method="bounded")
    return float(best.x)
