"""Outlines: the envelope of a wall on its plane and the enclosed holes that are openings."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pyheracles.walls.bands import join_stray_bands
from pyheracles.walls.model import Array, Opening, WallParams
from pyheracles.walls.openings import (
    face_edge_table,
    face_spacing,
    merge_lights,
    pick_edges,
    splay_in,
)
from pyheracles.walls.planes import bridge_mullions
from pyheracles.walls.reveals import (
    RevealParams,
    fill_edges,
    glass_sill,
    reveal_edges,
    soffit_head,
)

__all__ = [
    "dense_cells",
    "floor_levels",
    "mask_polygon",
    "occupancy",
    "sill_faces",
    "sill_reach",
    "simplify_ring",
    "slim_runs",
    "splayed_in",
    "wall_outline",
]


def occupancy(ij: NDArray[np.int64], shape: tuple[int, ...],
              face_of: NDArray[np.int64] | None = None, gap: int = 0,
              hole: int = 1) -> NDArray[np.bool_]:  # fmt: skip
    """Cells of the wall plane covered by its faces, small gaps closed.

    A cell is covered when it holds a face point.  Each face (``face_of``; one face
    when omitted) is closed on its own, as the two faces of a wall are often scanned
    at very different densities (inside from near, outside from afar), by a
    morphological closing (square: a scan-line gap across a mullion one cell wide is
    bridged) whose size follows the face's local point density: one cell where its
    covered cells around (0.3 m) hold two points or more on average, two cells where
    they hold fewer (a grazing or distant scan whose lines are a cell or more apart).
    Openings are at least a few cells across and stay open.  The wall is covered where
    any of its faces is, and across the gaps of up to ``gap`` cells in a mullion's
    column between holes at least ``hole`` cells across
    (:func:`~pyheracles.walls.planes.bridge_mullions`): a mullion seen by a scan
    column or two of a sparse face is broken where a mixed pixel or two at its edges
    leave a gap of two or three spacings in each, and the lights joined there.
    """
    from scipy import ndimage

    faces = np.zeros(len(ij), dtype=np.int64) if face_of is None else face_of
    square = np.ones((3, 3), dtype=bool)
    out = np.zeros(shape, dtype=bool)
    for f in np.unique(faces):
        sel = faces == f
        cnt = np.zeros(shape, dtype=np.float64)
        np.add.at(cnt, (ij[sel, 0], ij[sel, 1]), 1.0)
        occ = cnt > 0
        size = 7  # cells: 0.3 m at 5 cm
        pts = ndimage.uniform_filter(cnt, size=size, mode="constant")
        covered = ndimage.uniform_filter(occ.astype(np.float64), size=size, mode="constant")
        sparse = pts < 2.0 * np.maximum(covered, 1e-9)
        one = ndimage.binary_closing(occ, structure=square, iterations=1, border_value=0)
        two = ndimage.binary_closing(occ, structure=square, iterations=2, border_value=0)
        out |= occ | np.where(sparse, two, one)
    return out | bridge_mullions(out, gap, hole)


def dense_cells(ij: NDArray[np.int64], shape: tuple[int, ...], share: float = 0.25,
                size: int = 7) -> NDArray[np.bool_]:  # fmt: skip
    """Cells of one face's points ``ij`` where the face is dense: the points in the
    ``size`` cells square around (0.35 m at 5 cm) at least ``share`` of the median of
    that count over the column's covered cells.

    Multipath returns of a face's points dropped 0.2-1.5 m straight down lie on its
    plane, below its foot, a point here and there (church draws 8 and 9: 15-40 points
    over a square metre under a door, a tenth to a hundredth of the face's density
    above): they cover cells, and the lowest covered cell, the envelope's foot, sank
    with them by up to a metre, and the empty band between them and the face joined a
    door's hole (draw 9's north door 13.7 m wide; draw 8's west door ran on to the
    wall's end and was lost).  A column of a face scanned from afar is sparse from its
    foot to its top alike and keeps its cells; a face's edge row keeps half its
    square's count.
    """
    from scipy import ndimage

    cnt = np.zeros(shape, dtype=np.float64)
    np.add.at(cnt, (ij[:, 0], ij[:, 1]), 1.0)
    occ = cnt > 0
    if not occ.any():
        return occ
    pts = ndimage.uniform_filter(cnt, size=size, mode="constant") * size * size
    ref = np.nanmedian(np.where(occ, pts, np.nan)[occ.any(axis=1)], axis=1)
    out = np.zeros(shape, dtype=bool)
    rows = np.flatnonzero(occ.any(axis=1))
    out[rows] = occ[rows] & (pts[rows] >= share * ref[:, None])
    return out


def wall_outline(w_uz: Array, face_of: NDArray[np.int64], on_plane: NDArray[np.bool_],
                 uz_all: Array,
                 near: NDArray[np.bool_], behind: NDArray[np.bool_], front: NDArray[np.bool_],
                 p: WallParams, side: NDArray[np.int64] | None = None,
                 depth: Array | None = None, between: tuple[Array, Array] | None = None,
                 ) -> tuple[Array, list[Opening], tuple[float, float],
                            tuple[float, float]]:  # fmt: skip
    """Envelope and openings of one wall from its face points ``w_uz`` (``(u, z)``).

    ``face_of`` gives the face of each point (its own foot decides what is a door);
    ``on_plane`` marks the points close enough to their face's plane to set the edges
    of openings (mixed pixels, off the plane, do not);
    ``uz_all`` are the detection sample's points on the plane, with the masks of those
    ``near`` the wall, ``behind`` its face(s) (inside the wall or beyond a lone face)
    and in ``front`` of it; ``side``: on which side of the wall's plane each of those
    lies (+1/-1; the floor inside and the ground outside under a door); ``depth``:
    their distance across the wall from its mid-plane (m): where both faces are seen,
    the points between them line the openings, and a window's jambs and head are put
    where its straight reveals stand (:func:`~pyheracles.walls.reveals.reveal_edges`);
    ``between``: the ``(u, z)`` and depth of every point between the two faces (full
    resolution), for a head nothing else measures
    (:func:`~pyheracles.walls.reveals.soffit_head`).
    """
    from scipy import ndimage

    c = p.cell_m
    lo = w_uz.min(axis=0)
    ij = np.floor((w_uz - lo) / c).astype(np.int64)
    shape = tuple(ij.max(axis=0) + 1)
    # a mullion's column is followed across gaps of run_gap_spacings of the sparsest
    # face's spacing, between holes an opening wide
    spacing = max(face_spacing(w_uz[face_of == f]) for f in np.unique(face_of))
    occ = occupancy(ij, shape, face_of, int(np.ceil(p.run_gap_spacings * spacing / c)),
                    int(np.ceil(p.min_opening_m / c)))  # fmt: skip
    cols = np.flatnonzero(occ.any(axis=1))
    nu = shape[0]
    dense = [dense_cells(ij[face_of == f], shape) for f in np.unique(face_of)]
    bot = _foot(np.logical_or.reduce(dense), c)
    top = np.where(occ, np.arange(shape[1])[None, :], -1).max(axis=1)
    keep = np.zeros(nu, dtype=bool)
    keep[cols.min() : cols.max() + 1] = True
    have = occ.any(axis=1)
    idx = np.arange(nu)
    top = np.interp(idx, idx[have], top[have]).round().astype(int)
    top = ndimage.maximum_filter1d(top, max(1, round(0.3 / c)), mode="nearest")
    rows = np.arange(shape[1])[None, :]
    env = keep[:, None] & (rows >= bot[:, None]) & (rows <= top[:, None])
    holes = slim_runs(env & ~occ, max(1, int(np.ceil(p.min_opening_m / c))), bot)
    holes = join_stray_bands(holes, [_raw_cells(ij[face_of == f], shape)
                                     for f in np.unique(face_of)])  # fmt: skip
    lab, k = ndimage.label(holes)
    openings: list[Opening] = []
    if k:
        feet = [_foot(fo, c) for fo in dense]  # each face's own (floor, ground)
        step = max(2, int(np.ceil(p.door_step_m / c)) + 1)
        rise = p.max_floor_rise_m / c
        # points through the wall plane, on the grid
        pij = np.floor((uz_all - lo) / c).astype(np.int64)
        inside = np.all((pij >= 0) & (pij < shape), axis=1)
        slices = ndimage.find_objects(lab)
        # the points between a wall's two faces line its openings (lone faces: no depth)
        lining = behind & near if depth is not None and len(np.unique(face_of)) == 2 else None
        for m, sl in enumerate(slices, start=1):
            if sl is None:
                continue
            region = lab[sl] == m
            w = (sl[0].stop - sl[0].start) * c
            h = (sl[1].stop - sl[1].start) * c
            if w < p.min_opening_m or h < p.min_opening_m:
                continue
            if region.sum() * c * c < p.min_opening_area_m2:
                continue
            if sl[0].start == 0 or sl[0].stop == nu or sl[1].stop >= shape[1]:
                continue  # open to the wall's end or top: not enclosed
            if _open_above(region, sl, top):
                continue  # under the envelope's top, raised by a few strays above
            at_foot = bool(np.any(sl[1].start <= bot[sl[0]] + 1))
            # a face's foot is a floor (inside) or the ground (outside) unless it stands
            # over the wall's foot by more than max_floor_rise_m: a clerestory's outer
            # face stands on an aisle's roof, and its windows' holes start at that foot
            # (church draws 12 and 15: taken for doors, their sills never measured)
            base = float(np.median(bot[sl[0]]))
            grounded = [ft for ft in feet if np.median(ft[sl[0]]) - base <= rise]
            on_floor = at_foot or any(sl[1].start <= np.median(ft[sl[0]]) + step
                                      for ft in grounded)  # fmt: skip
            grown = ndimage.binary_dilation(lab == m, iterations=1)
            z_lo = sl[1].start + (2 if on_floor else 0)
            sel = np.zeros(len(uz_all), dtype=bool)
            sel[inside] = grown[pij[inside, 0], pij[inside, 1]] & (pij[inside, 1] >= z_lo)
            n_behind = int(np.count_nonzero(sel & behind & near))
            n_front = int(np.count_nonzero(sel & front & near))
            if n_behind < 3 or n_behind < 0.5 * n_front:
                continue  # a shadow: what is seen through it stands in front of the wall
            u0, u1 = lo[0] + sl[0].start * c, lo[0] + sl[0].stop * c
            z0, z1 = lo[1] + sl[1].start * c, lo[1] + sl[1].stop * c
            # the jambs: rows where the hole is (nearly) at its full width, below any
            # round or pointed head (refining the sides in the head narrowed such
            # windows, and round-headed doors: church draws 8 and 9, 13-15 cm narrow)
            # (doors keep their upper part too: shadows merged at the foot widen them)
            # (the full width: the 75th percentile of the rows' widths, as a few rows
            # widened by a shadow or a gap at the foot would narrow the band to them)
            widths = region.sum(axis=0)
            full = np.flatnonzero(widths >= np.percentile(widths, 75) - 1)
            jambs = (lo[1] + (sl[1].start + full.min()) * c,
                     lo[1] + (sl[1].start + full.max() + 1) * c)  # fmt: skip
            local = _edge_points(ij, on_plane, sl, region)
            grid = (u0, u1, z0, z1)
            table = face_edge_table(w_uz[local], face_of[local], u0, u1, z0, z1, c, at_foot,
                                    jambs)  # fmt: skip
            (u0, u1, z0, z1), src = pick_edges(*table, grid, c)
            if lining is not None:  # the reveals between the faces (a door's too: its
                # leaf, seen on both its faces, is left out with the glass; church draws
                # 3 and 13: stray returns on a sparse face put door jambs 4-7 cm inward)
                box = lining & (np.abs(uz_all[:, 0] - 0.5 * (grid[0] + grid[1]))
                                < 0.5 * (grid[1] - grid[0]) + 0.5)  # fmt: skip
                box &= (uz_all[:, 1] > grid[2] - 0.5) & (uz_all[:, 1] < grid[3] + 0.5)
                found = reveal_edges(uz_all[box], depth[box], *grid, c, jambs,  # type: ignore[index]
                                     leaf=on_floor)  # fmt: skip
                # the opening is where every surface is open: the innermost jambs of
                # the faces' and the reveals' (a face's jamb, its innermost points and
                # part of the gap to the next, narrows a reveal's by more than its
                # point spacing, at most two cells, only: across a mullion of a sparse
                # face the next light's jamb is a reveal too); the head where the
                # soffit stands
                sp = min(2 * c, max(face_spacing(w_uz[local][face_of[local] == f])
                                    for f in np.unique(face_of[local])))  # fmt: skip
                took = np.array([np.isfinite(found[0]) and u0 - found[0] <= sp,
                                 np.isfinite(found[1]) and found[1] - u1 <= sp, False,
                                 np.isfinite(found[3])])  # fmt: skip
                u0 = found[0] if took[0] else u0
                u1 = found[1] if took[1] else u1
                z1 = found[3] if took[3] else z1
                if not took[3] and src[3] < 0 and between is not None:  # the grid's head
                    # (a pointed apex closed): the soffit's top at full resolution
                    apex = soffit_head(*between, u0, u1, z1, c)
                    z1 = apex if np.isfinite(apex) and apex > z1 else z1
                    # (a splayed face's hole, the other face's too sparse to close it):
                    # the soffit's narrowest section, searched from a splay under it, and
                    # no lower than the glass's highest returns (a depth holding only
                    # glass, its top not seen, is no soffit)
                    low = soffit_head(*between, u0, u1, z1, c, below_m=RevealParams().inward_m)
                    glass_top = fill_edges(uz_all[box], depth[box], *grid)[3]  # type: ignore[index]
                    low = max(low, glass_top) if np.isfinite(glass_top) else low
                    z1 = low if np.isfinite(low) and low < z1 else z1
                if not on_floor:  # the edges the reveals did not see, of a splayed face
                    u0, u1, z0, z1 = splayed_in((u0, u1, z0, z1), src, *table,
                                                np.asarray(found), took, c)  # fmt: skip
                    # a splayed face's hole, the other face's not measured (a
                    # clerestory's outer face on an aisle's roof, open to its foot here
                    # and sparse; church draws 12 and 15: sills 0.2-0.3 m low, 0.1-0.4 m
                    # wide): the glass, in from every side by one splay
                    fill = fill_edges(uz_all[box], depth[box], *grid)  # type: ignore[index]
                    u0, u1, z0, z1 = _splay_to_fill(fill, grid, (u0, u1, z0, z1), c)
                    if between is not None:  # a sill under the faces' (a splayed or
                        # sparse face's hole): the glass's foot, where the splay is seen
                        rows = (
                            [int(src[2])]
                            if src[2] >= 0
                            else sill_faces(
                                w_uz[local], face_of[local], (u0, u1, z0, z1), table[1], c
                            )
                        )
                        up = sill_reach(rows, *table, (u0, u1, z0, z1))
                        z0 = _up_to(z0, glass_sill(*between, grid, (u0, u1)), up)
            if on_floor:  # a door: the opening through the wall starts at the highest
                # face foot under it (the floor inside above a step down outside)
                levels = [lo[1] + float(np.median(ft[sl[0]])) * c for ft in grounded]
                if side is not None:
                    levels += floor_levels(uz_all, front & near, side, u0 + c, u1 - c, z0,
                                           p.door_step_m + c, p.distance_m)  # fmt: skip
                z0 = _threshold(z0, levels, p.door_step_m + c)
            poly = mask_polygon(region, lo + np.array([sl[0].start, sl[1].start]) * c, c)
            openings.append(Opening("door" if on_floor else "window", float(u0), float(u1),
                                    float(z0), float(z1), poly))  # fmt: skip
    openings = merge_lights(openings, p.max_mullion_m)
    a, b = int(cols.min()), int(cols.max()) + 1
    us = lo[0] + np.arange(a, b + 1) * c
    tz = lo[1] + (top[np.r_[a:b, b - 1]] + 1) * c
    bz = lo[1] + bot[np.r_[a:b, b - 1]] * c
    outline = np.r_[np.c_[us, bz], np.c_[us[::-1], tz[::-1]]]
    outline = simplify_ring(outline, c)
    return outline, openings, (float(us[0]), float(us[-1])), (float(bz.min()), float(tz.max()))


def floor_levels(uz: Array, front: NDArray[np.bool_], side: NDArray[np.int64], u0: float,
                 u1: float, z0: float, step: float, flat: float) -> list[float]:  # fmt: skip
    """Heights (m) of the floor or ground on each side of a door ``u0``-``u1`` whose
    foot is measured at ``z0``: the median height of the points in front of the wall on
    that side, between ``u0`` and ``u1`` and from half a metre below ``z0`` to ``step``
    above it, when at least 10 and flat (interquartile range within ``flat``, m: an
    open leaf or clutter in the doorway is no floor; church draws 1 and 2).

    A face's own foot under a door is that of its points beside it, and clutter along an
    inner face (pews, a dado in shadow) lifts it out of reach: church draw 4's inner
    faces stood 0.58 m above the floor by the north door, the door's foot stayed on the
    ground outside, 11 cm low.  The floor itself, seen through the doorway, is there.
    """
    sel = front & (uz[:, 0] > u0) & (uz[:, 0] < u1) & (uz[:, 1] > z0 - 0.5)
    sel &= uz[:, 1] < z0 + step
    out = []
    for s in (1, -1):
        z = uz[sel & (side == s), 1]
        if len(z) < 10:
            continue
        q25, q50, q75 = np.percentile(z, [25, 50, 75])
        if q75 - q25 <= flat:  # a floor, not a leaf or clutter standing in the doorway
            out.append(float(q50))
    return out


def slim_runs(holes: NDArray[np.bool_], n: int, foot: NDArray[np.int64]) -> NDArray[np.bool_]:
    """``holes`` (columns along ``u``, rows up ``z``) without the vertical runs of
    fewer than ``n`` cells that start at the envelope's ``foot`` (its row per column):
    slivers along the foot, lower than any opening, that would join a door to the empty
    cells along the foot beside it, up to the wall's end (a run within an opening,
    between a transom and the stray cells across a light, is left: cut, it would split
    the light).
    """
    if n <= 1 or not holes.any():
        return holes
    h = np.pad(holes, ((0, 0), (1, 1)))
    d = np.diff(h.astype(np.int8), axis=1)
    cols, starts = np.nonzero(d == 1)
    _, ends = np.nonzero(d == -1)  # same order: row-major, one end per start
    drop = (ends - starts < n) & (starts <= foot[cols] + 1)
    cum = np.zeros((holes.shape[0], holes.shape[1] + 1), dtype=np.int32)
    np.add.at(cum, (cols[drop], starts[drop]), 1)
    np.add.at(cum, (cols[drop], ends[drop]), -1)
    return holes & ~(np.cumsum(cum, axis=1)[:, :-1] > 0)


def splayed_in(edges: tuple[float, float, float, float], src: NDArray[np.int64],
               faces: Array, spacing: Array, reveals: Array, took: NDArray[np.bool_],
               c: float, p: RevealParams | None = None,
               ) -> tuple[float, float, float, float]:  # fmt: skip
    """A window's ``edges`` ``(u0, u1, z0, z1)``, each one set by a face (``src``: its
    row of ``faces``, the faces' own edges, and of their point ``spacing``; -1: the
    grid's) and not by the reveals (``reveals``; ``took``: the edges taken from them)
    moved into the opening by that face's splay
    (:func:`~pyheracles.walls.openings.splay_in`: how far its jambs stand outside the
    reveals'), when more than half a cell ``c`` and the face's spacing, and at most
    ``inward_m``: a sparse face's jamb is read between its points, up to its spacing
    off either way, and its other edges are not off by as much (a face 30 cm between
    points put a jamb 10 cm inside the opening).

    A splayed face's hole is the opening grown by the splay on every side.  Its sill
    is the opening's where the other face has no points under it (a clerestory's
    outer face behind an aisle's roof) or too few to measure it (sparse), and the
    reveals never measure a sill (its straight part faces up): church draws 14 and 15,
    sills 5-28 cm low by the inner face's splay while the reveals put the jambs back
    (draw 14, round windows in a 1.09 m wall: inner face 6 cm out on every side, outer
    face 15-30 cm between points); a jamb or head the reveals did not see likewise.
    """
    p = p or RevealParams()
    out = list(edges)
    for k, f in enumerate(src):
        if took[k] or f < 0:
            continue
        s = splay_in(faces[f], reveals, took)
        if np.isfinite(s) and max(0.5 * c, spacing[f]) < s <= p.inward_m:
            out[k] += s if k in (0, 2) else -s
    return out[0], out[1], out[2], out[3]


def _splay_to_fill(fill: tuple[float, float, float, float], hole: tuple[float, ...],
                   edges: tuple[float, float, float, float], c: float,
                   ) -> tuple[float, float, float, float]:  # fmt: skip
    """Edges ``(u0, u1, z0, z1)`` of a window: ``edges``, or its glass's (``fill``, from
    :func:`~pyheracles.walls.reveals.fill_edges`) where the glass stands inside the
    grid's ``hole`` by one splay: in from both jambs and the sill by more than two
    cells ``c`` each, and by the same within two cells (the head too when it is in by
    as much; else ``edges``' head).

    The grid's hole is where every face is open; where one face does not close it
    (sparse, or hidden below by a roof) it is a splayed face's hole, the opening grown
    by the splay on every side, and the faces' edges are the splay's or a mix.  Glass
    seen over part of its pane (its lower part hidden behind the sill from scanners
    below, one side in a reveal's shadow) stands in from one or two edges only, and
    is no measure of the opening.
    """
    if not np.all(np.isfinite(fill)):
        return edges
    off = np.array([fill[0] - hole[0], hole[1] - fill[1], fill[2] - hole[2], hole[3] - fill[3]])
    lo, hi = off[:3].min(), off[:3].max()
    if lo <= 2 * c or hi - lo > 2 * c:
        return edges
    head = fill[3] if max(hi, off[3]) - min(lo, off[3]) <= 2 * c else edges[3]
    return fill[0], fill[1], fill[2], head


def sill_reach(rows: list[int], faces: Array, spacing: Array, edges: tuple[float, ...],
               p: RevealParams | None = None) -> float:  # fmt: skip
    """How far (m) the glass's foot (:func:`~pyheracles.walls.reveals.glass_sill`) may
    lift the sill of a window with jambs ``edges[:2]`` (m) set by the faces of
    ``rows`` of ``faces`` (their edges and point ``spacing``; none: unknown): the least
    spacing of those whose splay is measured (their jambs against the window's,
    :func:`~pyheracles.walls.openings.splay_in`), as such a face lines the narrowest
    section or was moved in by its splay (:func:`splayed_in`), and reads the sill up
    to its spacing low; else ``inward_m`` (a splayed face's hole).  The glass's lowest
    returns stand over a sill whose splay is seen from afar by more than such a face's
    spacing (church draws 1, 7, 14 and 22: 8-14 cm over sills that faces 2-12 cm
    between points measured within 5 cm).
    """
    p = p or RevealParams()
    reach = [
        float(spacing[r])
        for r in rows
        if np.isfinite(
            splay_in(faces[r], np.asarray(edges, dtype=np.float64), np.ones(4, dtype=bool))
        )
    ]
    return min(reach, default=p.inward_m)


def sill_faces(
    uz: Array, face_of: NDArray[np.int64], edges: tuple[float, ...], spacing: Array, c: float
) -> list[int]:
    """Rows (in the order of ``np.unique(face_of)``) of the faces whose points ``uz``
    stand under the sill of an opening ``edges`` ``(u0, u1, z0, z1)`` within a cell
    ``c`` and their ``spacing``, at least three of them between its jambs: the faces
    that close the grid's hole there."""
    u0, u1, z0, _ = edges
    out = []
    for k, f in enumerate(np.unique(face_of)):
        q = uz[face_of == f]
        sel = (q[:, 0] > u0) & (q[:, 0] < u1) & (q[:, 1] < z0) & (q[:, 1] >= z0 - c - spacing[k])
        if np.count_nonzero(sel) >= 3:
            out.append(k)
    return out


def _up_to(edge: float, found: float, reach: float) -> float:
    """``found`` where it stands above ``edge`` by up to ``reach`` (m), else ``edge``."""
    return found if np.isfinite(found) and edge < found <= edge + reach else edge


def _threshold(z0: float, feet: list[float], step: float) -> float:
    """Foot of a door: the highest of the faces' feet under it (``feet``, m) between
    the grid's foot ``z0`` and ``step`` above it, else ``z0``.

    Each face is open from its own foot (the floor inside, the ground outside), and
    the opening through the wall is where every face is: a wall standing on a step
    down to the outside has its door from the floor, not from the ground (church
    draw 4: doors 18 cm too tall).
    """
    up = [f for f in feet if z0 <= f <= z0 + step]
    return max([z0, *up])


def _foot(occ: NDArray[np.bool_], c: float, stray_m: float = 0.5, wide_m: float = 10.0,
          rise_m: float = 1.5) -> NDArray[np.int64]:  # fmt: skip
    """Lowest covered row per column, across empty columns from their neighbours, and
    the lowest within 2.5 m but for the ``stray_m`` (m) of columns lowest there (a
    door or an occluder does not lift the foot, a few stray cells do not lower it);
    where that stands more than ``rise_m`` above the same within ``wide_m``, between
    columns that do on either side, one of them within half of ``wide_m``, the latter
    (under an arch or a door wider than 2.5 m less ``stray_m``; not at a wall's end).

    Returns below a face's foot (multipath ghosts of its points, dropped 0.2-1.5 m
    straight down, on its plane) cover a cell here and there: with the plain lowest
    row within 2.5 m, each such cell lowered the envelope's foot by up to a metre along
    2.5 m of wall, and the empty band between it and the true foot joined a door's hole
    (church draw 9's north door 13.7 m wide; draw 8's west door ran on to the wall's
    end and was lost).  A door up to 2.5 m less ``stray_m`` wide still leaves that much
    of true foot in every window over it.  Over the middle of a wider one (church draw
    2's arch into the apse, 5 m wide) every column's lowest cell is the head: the foot
    rose to it there, and the arch was two openings either side of a pillar of wall.
    A rise of ``rise_m`` within ``wide_m`` is no slope of the ground.  Under an arch
    wider than half of ``wide_m`` plus 2.5 m less ``stray_m``, a column near one jamb
    stands more than half of ``wide_m`` from the other: the low foot on both sides
    within half of ``wide_m`` held in its middle only, and the head's columns on either
    side were two pillars of wall (church draw 15's chancel arch, 8.9 m wide: three
    openings).  The low foot within half of ``wide_m`` on one side is the foot (the
    ``wide_m`` rank filter reaches it), when there is one on the other side too.
    """
    from scipy import ndimage

    nz = occ.shape[1]
    bot = np.where(occ, np.arange(nz)[None, :], nz).min(axis=1)
    have = occ.any(axis=1)
    if not have.any():
        return np.full(occ.shape[0], nz, dtype=np.int64)
    idx = np.arange(occ.shape[0])
    bot = np.interp(idx, idx[have], bot[have]).round().astype(np.int64)
    size = max(3, round(2.5 / c))
    rank = min(size - 1, round(stray_m / c))
    near = ndimage.rank_filter(bot, rank, size=size, mode="nearest")
    size = max(3, round(wide_m / c))
    wide = ndimage.rank_filter(bot, min(size - 1, rank), size=size, mode="nearest")
    low = near - wide <= rise_m / c
    if low.all() or not low.any():
        return near
    # under an opening: low foot on both sides (not a wall's end), on one within half
    # of wide_m (the wide filter's reach)
    left = np.maximum.accumulate(np.where(low, idx, -size))
    right = np.minimum.accumulate(np.where(low, idx, 2 * len(idx) + size)[::-1])[::-1]
    both = (left >= 0) & (right < len(idx))
    between = both & (np.minimum(idx - left, right - idx) <= size // 2)
    return np.where(~low & between, wide, near)


def _open_above(region: NDArray[np.bool_], sl: tuple[slice, ...], top: NDArray[np.int64]) -> bool:
    """Whether a hole ``region`` (its box ``sl`` in the grid) reaches the envelope's
    ``top`` (row per column) over most of its columns: no face covers it there, and it
    is open to the top, not enclosed.

    The envelope's top is the highest covered cell of each column, raised over 0.3 m
    around it: a few returns above a wall's top (mixed pixels at its coping, the eaves'
    returns on its plane) raise it over a stretch, and the empty band between the wall's
    top and them was a window (church draw 23: 0.3 x 0.46 m on the north wall's top;
    draw 6: 0.25 x 0.8 m on the east gable).
    """
    has = region.any(axis=1)
    hi = sl[1].start + region.shape[1] - 1 - np.argmax(region[:, ::-1], axis=1)
    cols = np.arange(sl[0].start, sl[0].stop)
    return bool(np.mean(hi[has] >= top[cols[has]]) > 0.5)


def _raw_cells(ij: NDArray[np.int64], shape: tuple[int, ...]) -> NDArray[np.bool_]:
    """Cells ``shape`` of the grid holding a point ``ij`` (no closing)."""
    out = np.zeros(shape, dtype=bool)
    out[ij[:, 0], ij[:, 1]] = True
    return out


def _edge_points(ij: NDArray[np.int64], on_plane: NDArray[np.bool_], sl: tuple[slice, ...],
                 region: NDArray[np.bool_], margin: int = 3) -> NDArray[np.int64]:  # fmt: skip
    """Indices of the face points around one opening, without the stray ones inside it.

    Points of cells enclosed by the opening (returns of glass or leaves, mixed pixels
    within ``distance_m`` of the plane) would set its edges inside it; the opening
    with its islands filled is where no edge can be.
    """
    from scipy import ndimage

    filled = ndimage.binary_fill_holes(region)
    a0, b0 = sl[0].start - margin, sl[1].start - margin
    box = on_plane & ((ij[:, 0] >= a0) & (ij[:, 0] < sl[0].stop + margin)
           & (ij[:, 1] >= b0) & (ij[:, 1] < sl[1].stop + margin))  # fmt: skip
    sel = np.flatnonzero(box)
    li, lj = ij[sel, 0] - sl[0].start, ij[sel, 1] - sl[1].start
    inr = (li >= 0) & (li < region.shape[0]) & (lj >= 0) & (lj < region.shape[1])
    stray = np.zeros(len(sel), dtype=bool)
    stray[inr] = filled[li[inr], lj[inr]]
    return sel[~stray]


def simplify_ring(ring: Array, tol: float) -> Array:
    import shapely

    poly = shapely.Polygon(ring).buffer(0)
    if poly.geom_type != "Polygon":
        poly = max(poly.geoms, key=lambda g: g.area)
    poly = poly.simplify(tol, preserve_topology=True)
    return np.asarray(poly.exterior.coords)[:-1]


def mask_polygon(region: NDArray[np.bool_], origin: Array, c: float) -> Array:
    """Outline ``(K, 2)`` of a boolean grid region (cells of size ``c`` from ``origin``)."""
    import rasterio.features
    import shapely

    shapes = [shapely.geometry.shape(g) for g, v in
              rasterio.features.shapes(region.T.astype(np.uint8), mask=region.T) if v]  # fmt: skip
    poly = max(shapes, key=lambda g: g.area).simplify(0.5, preserve_topology=True)
    return np.asarray(poly.exterior.coords)[:-1] * c + origin
