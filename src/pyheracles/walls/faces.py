"""Faces: vertical planes of the detection sample and all their input points."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from pyheracles.walls.model import Array, WallParams
from pyheracles.walls.openings import face_spacing
from pyheracles.walls.planes import (
    bridge_runs,
    fit_vertical,
    grid_components,
    plane_frame,
    run_on_ends,
)

__all__ = ["face_points", "find_faces"]


def find_faces(
    xyz: Array, sample: NDArray[np.int64], normals: Array, p: WallParams
) -> list[tuple[Array, float, NDArray[np.int64], bool]]:
    """Faces on the sample: (normal, d, sample-point indices into ``xyz``, whether the
    face reaches ``min_length_m`` only when run on to its corners).

    A face run on to its corners (:func:`_corner_length`) may be a reveal of a wall as
    thick as ``min_length_m``; :func:`~pyheracles.walls.pairing.reveal_drafts` tells.
    """
    nz_max = math.sin(math.radians(p.max_tilt_deg))
    cand = np.flatnonzero(np.abs(normals[:, 2]) <= nz_max)
    if len(cand) < 3:
        return []
    pts = xyz[sample[cand]]
    nrm = normals[cand]
    theta = np.mod(np.arctan2(nrm[:, 1], nrm[:, 0]), np.pi)
    h = np.c_[np.cos(theta), np.sin(theta)]
    off = np.einsum("ij,ij->i", pts[:, :2], h)
    alive = np.ones(len(cand), dtype=bool)
    cos_n = math.cos(math.radians(p.normal_angle_deg))
    spacing = p.voxel_m or 0.06
    min_pts = max(30, int(0.25 * p.min_area_m2 / spacing**2))
    faces: list[tuple[Array, float, NDArray[np.int64], bool]] = []
    dbin = 2 * p.distance_m
    lo, hi = off.min() - dbin, off.max() + dbin
    abins = np.linspace(0, np.pi, 181)
    dbins = np.arange(lo, hi + dbin, dbin)
    for _ in range(200):
        idx = np.flatnonzero(alive)
        if len(idx) < min_pts:
            break
        hist, _, _ = np.histogram2d(theta[idx], off[idx], bins=(abins, dbins))
        # neighbouring bins together (azimuth wraps at 180 deg)
        from scipy import ndimage

        smooth = ndimage.uniform_filter(hist, size=3, mode=("wrap", "constant")) * 9
        a, b = np.unravel_index(int(np.argmax(smooth)), smooth.shape)
        if smooth[a, b] < min_pts:
            break
        t0 = 0.5 * (abins[a] + abins[a + 1])
        d0 = 0.5 * (dbins[b] + dbins[b + 1])
        dt = np.abs(np.angle(np.exp(2j * (theta[idx] - t0)))) / 2
        seed = idx[(dt <= math.radians(2.0)) & (np.abs(off[idx] - d0) <= 1.5 * dbin)]
        # the bin may sit across the wrap at 0/180 deg: flip the offsets of the far side
        if len(seed) < 3:
            alive[idx[(dt <= math.radians(1.0)) & (np.abs(off[idx] - d0) <= dbin)]] = False
            continue
        n, d, _ = fit_vertical(pts[seed])
        inl = _refine(pts, nrm, idx, n, d, p.distance_m, cos_n)
        if len(inl) < 0.5 * len(seed):
            # the seeds are not one plane: a few sharing the peak's bin from other
            # planes pulled the least-squares fit off (church draw 8's apse facet,
            # 2 x 5 m, tilted 23 deg by 44 of 466): from the peak's own plane, its
            # azimuth at the seeds' median offset
            n0 = np.array([math.cos(t0), math.sin(t0), 0.0])
            again = _refine(pts, nrm, idx, n0, float(np.median(pts[seed] @ n0)),
                            p.distance_m, cos_n)  # fmt: skip
            if len(again) > len(inl):
                inl = again
        if len(inl) >= 3:
            n, d, _ = fit_vertical(pts[inl])
        alive[seed] = False
        if len(inl) < min_pts:
            continue
        alive[inl] = False
        if abs(n[2]) > nz_max:
            continue
        # split into connected parts along the plane
        origin, u = plane_frame(n, d)
        q = pts[inl] - origin
        uz = np.c_[q @ u, q[:, 2]]
        cell = 0.2
        ij = np.floor((uz - uz.min(axis=0)) / cell).astype(np.int64)
        grid = np.zeros(ij.max(axis=0) + 1, dtype=bool)
        grid[ij[:, 0], ij[:, 1]] = True
        lab, k = grid_components(grid, 2)
        plab = lab[ij[:, 0], ij[:, 1]]
        # the plane's points whatever their normals (a face's corners, see run_on_ends)
        on = np.abs(pts @ n - d) <= p.distance_m
        on_uz = np.c_[(pts[on] - origin) @ u, pts[on, 2]]
        for c in range(1, k + 1):
            part = inl[plab == c]
            if len(part) < min_pts:
                continue
            puz = uz[plab == c]
            height = np.ptp(puz[:, 1])
            comp = lab == c
            area = np.count_nonzero(comp) * cell**2
            length = _corner_length(on_uz, puz, area, p)
            if length < p.min_length_m or height < p.min_height_m or area < p.min_area_m2:
                continue
            if not _solid(comp, cell, p):
                continue
            faces.append((n, d, sample[cand[part]], bool(np.ptp(puz[:, 0]) < p.min_length_m)))
    return faces


def _solid(comp: NDArray[np.bool_], cell: float, p: WallParams) -> bool:
    """Whether a part of a plane (cells ``comp`` of ``cell`` m, axis 0 along it, axis 1
    up) is solid like a wall: its columns hold ``min_height_m`` of it over most of its
    length, or its columns that do are ``min_length_m`` wide together and hold most of
    its area.

    Rows of pew ends and railings hold less than ``min_height_m`` in every column.  The
    outer face of an east wall against which an apse is built is seen in two strips
    beside the apse, joined by the band of the gable above the apse's roof, a metre or
    two high: its tall columns are a third of its length (church draws 14 and 22: the
    strips, 1.0-1.2 m wide and 8-14 m high, held 67-77 % of its area, and the east
    wall's outer face was no face).  The short columns must then stand ``min_height_m``
    above the foot of the tall ones (a gable's band over a roof): a pier's face with the
    pew ends of its row at its foot is no face (held-out church draws 35, 37, 38).
    """
    used = comp.any(axis=1)
    col_h = comp.sum(axis=1)[used] * cell
    tall = col_h >= p.min_height_m
    if np.mean(tall) >= 0.5:
        return True
    if not (
        np.count_nonzero(tall) * cell >= p.min_length_m and col_h[tall].sum() >= 0.5 * col_h.sum()
    ):
        return False
    foot = np.argmax(comp[used], axis=1) * cell  # lowest cell of each column
    return bool(np.median(foot[~tall]) >= foot[tall].min() + p.min_height_m)


def _corner_length(on_uz: Array, puz: Array, area: float, p: WallParams) -> float:
    """Length (m) of a face whose points by their normals are ``puz`` (``(u, z)`` on its
    plane, covering ``area`` m2), run on to its corners over its plane's points
    ``on_uz`` between its foot and top (:func:`~pyheracles.walls.planes.run_on_ends`):
    up to the normals' neighbourhood radius (``normal_neighbours`` points at the face's
    spacing) beyond each end, across gaps of two spacings.

    A facet of a polygonal apse, 1.0-1.1 m long inside, lost 0.05-0.15 m at both of
    its corners, where the normals turn, and was shorter than ``min_length_m`` (church
    draw 16: the inner face of the apse's middle facet, 0.95 m between its seeds, was
    no face, and the facet no wall).
    """
    spacing = max(math.sqrt(area / len(puz)), p.voxel_m or 0.06)
    reach = math.sqrt(p.normal_neighbours / math.pi) * spacing
    z0, z1 = float(puz[:, 1].min()), float(puz[:, 1].max())
    u = on_uz[(on_uz[:, 1] >= z0) & (on_uz[:, 1] <= z1), 0]
    lo, hi = run_on_ends(u, float(puz[:, 0].min()), float(puz[:, 0].max()), reach, 2 * spacing)
    return hi - lo


def _refine(pts: Array, nrm: Array, idx: NDArray[np.int64], n: Array, d: float,
            distance: float, cos_n: float) -> NDArray[np.int64]:  # fmt: skip
    """Inliers ``idx`` of the plane ``(n, d)`` refitted three times: within
    ``distance`` (m) of it and with normals within ``cos_n`` of its."""
    inl = idx
    for k in range(3):
        dist = np.abs(pts[idx] @ n - d)
        inl = idx[(dist <= distance) & (np.abs(nrm[idx] @ n) >= cos_n)]
        if len(inl) < 3 or k == 2:
            break
        n, d, _ = fit_vertical(pts[inl])
    return inl


def face_points(
    xyz: Array, n: Array, d: float, seeds: NDArray[np.int64], p: WallParams
) -> NDArray[np.int64]:
    """All input points of a face: near its plane and within its seeds' footprint."""
    origin, u = plane_frame(n, d)
    sq = xyz[seeds] - origin
    suz = np.c_[sq @ u, sq[:, 2]]
    lo = suz.min(axis=0) - p.cell_m
    hi = suz.max(axis=0) + p.cell_m
    box = np.all((xyz >= np.minimum(xyz[seeds].min(axis=0), xyz[seeds].max(axis=0))
                  - p.distance_m - 0.1), axis=1)  # fmt: skip
    box &= np.all(xyz <= xyz[seeds].max(axis=0) + p.distance_m + 0.1, axis=1)
    idx = np.flatnonzero(box)
    idx = idx[np.abs(xyz[idx] @ n - d) <= p.distance_m]
    q = xyz[idx] - origin
    uz = np.c_[q @ u, q[:, 2]]
    inside = np.all((uz >= lo) & (uz <= hi), axis=1)
    idx, uz = idx[inside], uz[inside]
    cell = max(2 * (p.voxel_m or 0.06), p.cell_m)
    ij = np.floor((suz - lo) / cell).astype(np.int64)
    shape = np.floor((hi - lo) / cell).astype(np.int64) + 2
    from scipy import ndimage

    grid = np.zeros(shape, dtype=bool)
    grid[ij[:, 0], ij[:, 1]] = True
    grid = ndimage.binary_dilation(grid, iterations=1)
    pij = np.clip(np.floor((uz - lo) / cell).astype(np.int64), 0, shape - 1)
    own = grid[pij[:, 0], pij[:, 1]]
    res = np.abs(xyz[idx] @ n - d)
    seed_rms = float(np.sqrt(np.mean((xyz[seeds] @ n - d) ** 2)))
    on_plane = res <= max(3.0 * seed_rms, 0.005)  # not reveals' or mixed pixels' returns
    # a strip's run bridges gaps of up to run_gap_spacings of the face's spacing
    gap = int(np.ceil(p.run_gap_spacings * face_spacing(uz[on_plane]) / cell))
    return idx[own | (on_plane & _strips(pij, grid, on_plane, gap))]


def _strips(pij: NDArray[np.int64], grid: NDArray[np.bool_], on_plane: NDArray[np.bool_],
            gap: int = 0) -> NDArray[np.bool_]:  # fmt: skip
    """Points in the holes of a face's footprint ``grid`` (cells ``pij``) that are face
    too: mullions and transoms, from the points ``on_plane`` (within three RMS of it:
    the returns of reveals near the plane and mixed pixels spread across the band).

    A stone strip between the lights of a window, narrower than the normals'
    neighbourhood, seeds nothing, and its points lie in a hole of the footprint.  A run
    of points across a hole, touching the footprint at both ends (sill and head, or
    both jambs), is such a strip; returns of the reveals near the plane, along one
    edge of the hole, touch it along one stretch only and are left out.  The run is
    followed across gaps of up to ``gap`` cells along it, open on both sides
    (:func:`~pyheracles.walls.planes.bridge_runs`): a sparse face's strip is a column of
    points a spacing apart, and a mixed pixel or two at its edge break it.
    """
    from scipy import ndimage

    holes = ndimage.binary_fill_holes(grid) & ~grid
    cand = holes[pij[:, 0], pij[:, 1]] & on_plane
    keep = np.zeros(len(pij), dtype=bool)
    if np.count_nonzero(cand) < 10:
        return keep
    occ = np.zeros(grid.shape, dtype=bool)
    occ[pij[cand, 0], pij[cand, 1]] = True
    eight = np.ones((3, 3), dtype=bool)
    run = ndimage.binary_closing(occ, eight) & holes
    run |= bridge_runs(run | grid, gap) & holes
    lab, _ = ndimage.label(run, structure=eight)
    plab = lab[pij[:, 0], pij[:, 1]]
    for c, sl in enumerate(ndimage.find_objects(lab), start=1):
        if sl is None:
            continue
        box = tuple(slice(max(s.start - 2, 0), s.stop + 2) for s in sl)
        touch = ndimage.binary_dilation(lab[box] == c, eight) & grid[box]
        if ndimage.label(touch, structure=eight)[1] >= 2:
            keep |= cand & (plab == c)
    return keep
