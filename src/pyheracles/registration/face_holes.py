"""Holes in the wall faces of a cloud: where its glazed openings are looked for.

A face of :mod:`~pyheracles.registration.panes` is rastered with cells sized from its
point spacing; an opening is an empty region of that raster:

* enclosed by the face (:func:`enclosed_holes`), or running into a part of the face
  nobody scanned while what lies behind the face fills it (:func:`open_holes`: a
  clerestory window over an aisle roof);
* rastered again at its own neighbourhood's spacing (:func:`local_holes`) where a
  window was scanned closer than its wall;
* with a side that no reveal shows taken from the hole's edge
  (:func:`unseen_sides_from_hole`: a sill hidden in a deep recess seen from below).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.spatial import cKDTree

if TYPE_CHECKING:
    from pyheracles.registration.panes import PaneParams

__all__ = [
    "SIDES",
    "OpeningExtent",
    "enclosed_holes",
    "face_spacing",
    "holes_by_reach",
    "local_holes",
    "occupancy",
    "open_holes",
    "raster_cell",
    "sides_bounded",
    "unseen_sides_from_hole",
]

Array = NDArray[np.float64]


def occupancy(uv: Array, cell: float) -> tuple[NDArray[np.bool_], Array]:
    """Raster of a face (cells holding a point, small gaps closed) and its origin."""
    lo = uv.min(axis=0) - cell
    ij = np.floor((uv - lo) / cell).astype(int)
    shape = ij.max(axis=0) + 2
    occ = np.zeros(shape, bool)
    occ[ij[:, 0], ij[:, 1]] = True
    return ndimage.binary_closing(occ, structure=np.ones((3, 3)), border_value=0) | occ, lo


def enclosed_holes(occ: NDArray[np.bool_]) -> tuple[NDArray, int]:
    """Labels of the empty regions of a face raster ``occ`` that the face encloses (0
    elsewhere, also on regions reaching the raster's border) and the count of regions."""
    lab, n = ndimage.label(~occ)
    border = np.unique(np.concatenate([lab[0], lab[-1], lab[:, 0], lab[:, -1]]))
    lab[np.isin(lab, border)] = 0
    return lab, n


def open_holes(
    occ: NDArray[np.bool_],
    lo: Array,
    cell: float,
    lab: NDArray,
    behind: list[Array],
    p: PaneParams,
) -> list[NDArray[np.bool_]]:
    """Openings of a face whose hole runs into a part of the face nobody scanned.

    A clerestory window seen from the ground over an aisle roof, or a light with the
    wall under its sill hidden, leaves an empty region of the face raster ``occ``
    (origin ``lo``, cells of ``cell`` metres) that reaches its edge, and
    :func:`enclosed_holes` (labels ``lab``) keeps enclosed regions only (church draw
    49: 9 of 38 exterior windows so).  Such a region holds an opening where what lies
    behind the face (glass, reveals: ``behind``, the ``(K, 2)`` face coordinates of
    points between the face band and ``max_recess_m`` behind it, one array per side of
    the face) fills it, and the face bounds it on three of its four sides
    (:func:`sides_bounded`).
    """
    open_empty = ~occ & (lab == 0)
    out = []
    for q in behind:
        if len(q) < 30:
            continue
        ij = np.floor((q - lo) / cell).astype(int)
        ok = np.all((ij >= 0) & (ij < np.array(occ.shape)), axis=1)
        rec = np.zeros(occ.shape, bool)
        rec[ij[ok, 0], ij[ok, 1]] = True
        rec = ndimage.binary_closing(rec, structure=np.ones((3, 3))) | rec
        comp, n = ndimage.label(open_empty & rec)
        area = np.bincount(comp.ravel(), minlength=n + 1) * cell * cell
        for k, sl in enumerate(ndimage.find_objects(comp), start=1):
            if sl is None or area[k] < p.min_width_m * p.min_height_m * 0.5:
                continue
            # the region's box grown by one cell: its edge cells lie within
            win = tuple(slice(max(s.start - 1, 0), s.stop + 1) for s in sl)
            mk = comp[win] == k
            if sides_bounded(mk, occ[win]) >= 3:
                m = np.zeros(occ.shape, bool)
                m[win] = mk
                out.append(m)
    return out


def sides_bounded(region: NDArray[np.bool_], occ: NDArray[np.bool_], share: float = 0.5) -> int:
    """How many of a region's four sides the face bounds.

    A side (left, right, bottom, top of the raster) is bounded when, for at least
    ``share`` of the region's rows (columns), the cell just beyond the region's last
    cell on that side is face (``occ``).  An opening whose wall is unscanned under its
    sill is bounded on three sides; a patch of clutter or shadow open to unscanned
    space on two or more sides is not (an interior view: 23 such patches besides 17
    windows on a small church).
    """
    n = 0
    for axis in (0, 1):
        r = np.moveaxis(region, axis, 0)
        o = np.moveaxis(occ, axis, 0)
        lines = np.flatnonzero(r.any(axis=0))
        first = r[:, lines].argmax(axis=0)
        last = r.shape[0] - 1 - r[::-1, lines].argmax(axis=0)
        for idx in (first - 1, last + 1):
            ok = (idx >= 0) & (idx < r.shape[0])
            hit = np.zeros(len(lines), bool)
            hit[ok] = o[idx[ok], lines[ok]]
            n += int(hit.mean() >= share)
    return n


def holes_by_reach(uv: Array, cell: float) -> tuple[NDArray, Array, int]:
    """Labels of the empty regions of a face raster (enclosed or not), origin, count.

    A cell is face where a face point lies within 0.8 x that point's distance to its
    4th neighbour (a point of a regular grid of spacing s covers the plane within
    0.71 s): dense and sparse parts of one face are filled each at its own density,
    and a hole keeps its edges to a few centimetres where the face round it is dense.
    Unlike :func:`enclosed_holes`, regions reaching the raster's border are kept (label > 0).
    """
    lo = uv.min(axis=0) - cell
    shape = np.floor((uv.max(axis=0) - lo) / cell).astype(int) + 2
    t = cKDTree(uv)
    k = min(5, len(uv))
    reach = 0.8 * t.query(uv, k=k)[0][:, -1]
    gi, gj = np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij")
    centres = lo + (np.column_stack([gi.ravel(), gj.ravel()]) + 0.5) * cell
    dist, idx = t.query(centres, distance_upper_bound=float(reach.max()) + cell)
    ok = np.isfinite(dist)
    occ = np.zeros(len(centres), bool)
    occ[ok] = dist[ok] <= np.maximum(reach[idx[ok]], 0.5 * cell)
    lab, n = ndimage.label(~occ.reshape(shape))
    return lab, lo, n


@dataclass(frozen=True)
class OpeningExtent:
    """Extent of an opening on its mid-plane and the sides taken from the face's hole."""

    extent: tuple[float, float, float, float]  # u_min, u_max, v_min, v_max (metres)
    from_face: tuple[str, ...]


SIDES = ("left", "right", "bottom", "top")


def unseen_sides_from_hole(
    uv: Array,
    normal_uv: Array,
    extent: tuple[float, float, float, float],
    hole: tuple[float, float, float, float],
    cell: float,
    min_seen: float = 0.25,
) -> OpeningExtent:
    """Complete an opening's extent where no reveal shows a side.

    From below, the sill of a window recessed deep in a thick wall is hidden (its top
    faces up, away from the viewer) and so is the glass behind it: the outline stops
    where the visible jambs stop, decimetres above the true sill, and the opening looks
    shorter than its partner in the other cloud (church draw 9: 2.6-2.8 m seen from
    outside for 3.8-4.0 m windows).  The hole in the wall face still shows that side.

    Parameters
    ----------
    uv
        ``(M, 2)`` outline points on the mid-plane in face coordinates (metres).
    normal_uv
        ``(M, 2)`` their in-plane unit normals, pointing out of the opening.
    extent
        Measured ``(u_min, u_max, v_min, v_max)`` of the outline (and glass).
    hole
        ``(u_min, u_max, v_min, v_max)`` of the face raster's empty cells: each edge
        lies within one ``cell`` outside them (a boundary cell holding a face point
        counts as full).
    cell
        Raster cell, metres.
    min_seen
        A side is seen when outline points facing out of it (within 45 deg) near it
        span at least this share of the extent along it, with at least this share of
        the points per metre of the best seen side.

    Returns
    -------
    OpeningExtent
        The extent, moved outwards only, on the unseen sides to the hole's edge less
        the splay measured on the opposite side (or the mean of the seen sides; none
        seen: the hole itself).
    """
    lo_u, hi_u, lo_v, hi_v = extent
    size = (hi_u - lo_u, hi_v - lo_v)
    # side: (normal direction, coordinate across it, coordinate along it)
    dirs = {"left": (-1, 0), "right": (1, 0), "bottom": (-1, 1), "top": (1, 1)}
    now = {"left": lo_u, "right": hi_u, "bottom": lo_v, "top": hi_v}
    span, density = {}, {}
    for name, (sgn, axis) in dirs.items():
        # reveal points facing out of this side, near it (a jamb's normals scatter
        # where it ends, and a few of them face down anywhere along it)
        band = max(2 * cell, 0.15 * size[axis])
        facing = (sgn * normal_uv[:, axis] > np.cos(np.pi / 4)) & (
            sgn * (uv[:, axis] - now[name]) > -band
        )
        along = uv[facing, 1 - axis]
        span[name] = float(np.ptp(along)) if len(along) >= 3 else 0.0
        density[name] = len(along) / max(size[1 - axis], 1e-9)  # points per metre
    top_density = max(density.values())
    seen = {
        k: span[k] >= min_seen * size[1 - dirs[k][1]] and density[k] >= min_seen * top_density
        for k in dirs
    }
    edges = {  # the hole's edge: half a cell outside its empty cells
        "left": hole[0] - cell / 2,
        "right": hole[1] + cell / 2,
        "bottom": hole[2] - cell / 2,
        "top": hole[3] + cell / 2,
    }
    # splay: how far outside the opening's outline the face's hole lies on a seen side
    splay = {k: abs(edges[k] - now[k]) for k in SIDES if seen[k]}
    opposite = {"left": "right", "right": "left", "bottom": "top", "top": "bottom"}
    out = dict(now)
    moved = []
    for k in SIDES:
        if seen[k]:
            continue
        s = splay.get(opposite[k], float(np.mean(list(splay.values()))) if splay else 0.0)
        sgn = dirs[k][0]
        est = edges[k] - sgn * s
        if sgn * (est - now[k]) > cell:  # outwards, by more than the raster's resolution
            out[k] = est
            moved.append(k)
    return OpeningExtent((out["left"], out["right"], out["bottom"], out["top"]), tuple(moved))


def face_spacing(xyz: Array, tree: cKDTree, pts: Array, samples: int = 300) -> float:
    """Median spacing of the full-resolution cloud at (up to ``samples``) of ``pts``."""
    pick = pts[:: max(1, len(pts) // samples)]
    _, nearest = tree.query(pick, k=1)
    dist, _ = tree.query(xyz[nearest], k=2)
    return float(np.median(dist[:, 1]))


def raster_cell(spacing: float, p: PaneParams) -> float:
    """Raster cell of a face (or of its part) whose point spacing is ``spacing``."""
    return float(np.clip(p.cell_spacings * max(spacing, p.voxel_m / 2), p.min_cell_m, p.max_cell_m))


def local_holes(
    mask: NDArray[np.bool_],
    lo: Array,
    cell: float,
    face_density: float,
    uv: Array,
    fpts: Array,
    xyz: Array,
    tree: cKDTree,
    p: PaneParams,
) -> list[tuple[NDArray[np.bool_], Array, float, float]]:
    """A hole of a face raster again, at the face's point spacing round it.

    The face raster's cell follows the face's median spacing; a window scanned closer
    (a detail scan, a station beside it) is dense while the wall above it is sparse, and
    the coarse cells with their closing cut the narrow head of a pointed light and
    round the sill off by decimetres (church draw 9: 0.2 m cells on a 2 cm window
    scan, the hole 1 m short).  The hole's neighbourhood (3 cells round it) is
    rastered again at its own spacing when that gives cells under 0.7 of the face's,
    each face point filling its own neighbourhood (:func:`holes_by_reach`);
    its holes lying mostly within the coarse hole replace it (mullioned lights may
    part).  Returns ``(mask, origin, cell, density)`` per hole: the coarse one when
    nothing finer holds.
    """
    coarse = [(mask, lo, cell, face_density)]
    ii, jj = np.nonzero(mask)
    near = ndimage.binary_dilation(mask, iterations=1)
    margin = 3
    for _ in range(3):  # a window wider than the coarse hole (its head was closed)
        a = lo + np.array([ii.min() - margin, jj.min() - margin]) * cell
        b = lo + np.array([ii.max() + 1 + margin, jj.max() + 1 + margin]) * cell
        sel = np.all((uv >= a) & (uv < b), axis=1)
        if sel.sum() < p.face_min_points:
            return coarse
        spacing = face_spacing(xyz, tree, fpts[sel])
        fine = raster_cell(spacing, p)
        if fine >= 0.7 * cell:
            return coarse
        lab, lo2, _ = holes_by_reach(uv[sel], fine)
        border = set(np.unique(np.concatenate([lab[0], lab[-1], lab[:, 0], lab[:, -1]])))
        out, leaks = [], False
        for k, sl in enumerate(ndimage.find_objects(lab), start=1):
            if sl is None:
                continue
            m2 = np.zeros(lab.shape, bool)
            m2[sl] = lab[sl] == k
            i2, j2 = np.nonzero(m2)
            cu = np.floor((lo2[0] + (i2 + 0.5) * fine - lo[0]) / cell).astype(int)
            cv = np.floor((lo2[1] + (j2 + 0.5) * fine - lo[1]) / cell).astype(int)
            ok = (cu >= 0) & (cu < mask.shape[0]) & (cv >= 0) & (cv < mask.shape[1])
            within = np.zeros(len(cu), bool)
            within[ok] = near[cu[ok], cv[ok]]
            if k in border:  # open to the window's edge: the hole reaches further
                leaks |= bool(within.sum() * fine * fine >= 0.25 * mask.sum() * cell * cell)
                continue
            if m2.sum() * fine * fine < p.min_width_m * p.min_height_m * 0.5:
                continue
            if within.mean() >= 0.5:
                out.append((m2, lo2, fine, max(face_density, 1.0 / max(spacing, 1e-4) ** 2)))
        if out or not leaks:
            break
        margin *= 3
    return out or coarse
