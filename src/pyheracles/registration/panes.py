"""Glazed openings of a cloud: wall faces, the openings in them, the pane mid-plane outline.

A heritage window is a pane recessed behind a wall face inside an opening
(thesis ch. 3, Murtiyoso 2020).  Its outline on the pane mid-plane is the one
curve both an exterior and an interior cloud see: the outer reveal ends on the
glass from outside, the inner (often splayed) reveal from inside.  Per cloud:

1. **Wall faces** - points on a voxel grid, PCA normals; the cloud's own vertical
   refined from its walls (a levelling error of a degree bends a tall wall out of a
   vertical plane by more than a face band); the vertical ones are voted into a
   (normal azimuth, offset) histogram and the faces taken peak by peak (no global
   RANSAC budget spent on ground and roof).
2. **Openings** - each face rasterised with cells sized from its own point spacing;
   empty regions enclosed by the face (not touching its border: doors reaching the
   floor are excluded), and regions running into a part of the face nobody scanned
   that what lies behind the face fills (a clerestory window over an aisle roof), are
   candidate openings; each is rastered again at its own neighbourhood's spacing
   where a window was scanned closer than its wall
   (:mod:`~pyheracles.registration.face_holes`).
3. **Recess** - the full-resolution points inside the opening's prism: an opening
   has reveal points behind the face (shadows of furniture have none).  A filled,
   dense, planar patch at depth is a door leaf or a panel, not glass (glass
   returns few, weak points; photogrammetry none).
4. **Pane depth** - the glass points (a sparse plane parallel to the face, the layer
   spreading over most of the opening) where there are some, else the depth where the
   reveals end; the mid-plane lies half the glass thickness further.
5. **Outline** - each reveal point slid along its tangent plane onto the mid-plane
   (a straight reveal projects, a splayed one is followed down to the glass); any
   outline shape (rectangular, round-headed, pointed, leaded).  The opening's size and
   centre span the outline and the glass points together (a reveal hidden from the
   viewer leaves the outline partial, the glass still fills the opening), and a side
   that neither shows (a sill hidden in a deep recess seen from below) is taken from
   the hole in the wall face.

Assumptions (documented limits): the cloud is metric and roughly levelled (``up``
within ``max_level_deg`` of the vertical, walls of two directions at least to refine
it) and the glass thickness is known.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.spatial import cKDTree

from pyheracles.geometry.neighbours import estimate_normals
from pyheracles.registration.face_holes import (
    enclosed_holes,
    face_spacing,
    local_holes,
    occupancy,
    open_holes,
    raster_cell,
    unseen_sides_from_hole,
)

__all__ = [
    "Opening",
    "PaneParams",
    "detect_openings",
    "estimate_up",
    "recess_floor",
    "voxel_centroids",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class PaneParams:
    """Parameters of :func:`detect_openings` (metres unless stated).

    Attributes
    ----------
    search_voxel_m
        Voxel of the face search (normals, histogram votes).
    voxel_m
        Voxel of the face rasters.
    vertical_tolerance
        Largest ``|normal . up|`` of a wall point (0.2: about 11.5 deg).
    face_min_points
        Fewest voxels of a wall face.
    face_band_m
        Half-width of a face around its plane.
    azimuth_bin_deg, offset_bin_m
        Histogram bins of the face search.
    max_faces
        Faces taken at most (peaks of the histogram, largest first).
    cell_spacings, min_cell_m, max_cell_m
        Raster cell of a face: ``cell_spacings`` x the face's own median point
        spacing, clipped to ``[min_cell_m, max_cell_m]``.
    min_width_m, min_height_m, max_side_m
        Accepted opening size.
    max_recess_m
        Deepest pane searched behind the face (the wall thickness at most).
    min_boundary_coverage
        Share of the opening's boundary sectors (16 around its centre) that must hold
        reveal points.
    leaf_fill, leaf_density
        A planar patch at depth filling at least ``leaf_fill`` of the opening with at
        least ``leaf_density`` x the face's point density is a door leaf or a panel,
        not glass (glass returns about a fifth of the beams from its two faces, leaded
        cames included; photogrammetry none).
    pane_thickness_m
        Glass thickness: the mid-plane lies half of it behind the near glass face.
    outline_band_m
        Reveal points at most this far in front of the glass give the outline.
    max_recess_points
        Points of one opening's recess used at most (regularly thinned beyond).
    min_outline_points
        Reveal points taken for the outline at least (the band grows to hold them).
    min_glass_points
        Fewest points of a glass layer for the pane depth (fewer: the depth where the
        reveals end).  A sparse exterior TLS sees 20-30 returns on a high light.
    min_glass_extent_points
        With at least this many glass points the opening's size and centre span both
        the outline and the glass (a reveal hidden from the viewer leaves the outline
        partial; the glass still fills the opening).
    up
        Vertical direction (a prior: see ``level``).
    level
        Refine ``up`` from the cloud's own walls (:func:`estimate_up`) before the face
        search: a cloud tilted by a degree bends a 5 m wall 9 cm out of a vertical
        plane, more than ``face_band_m``, and its faces break into bands that hide the
        openings.
    max_level_deg
        Largest correction of ``up`` accepted from the walls.
    max_recess_keep
        Recess points (reveals and what is seen through the glass, not the glass
        itself) kept per opening for the restricted ICP of
        :mod:`~pyheracles.registration.pane_icp` (regularly thinned beyond).
    min_recess_depth_m, face_noise_factor
        The recess starts ``face_noise_factor`` robust standard deviations of the
        face's own scatter (measured on the face ring around the opening) behind the
        face plane, and at least ``min_recess_depth_m`` behind it: a photogrammetric
        face scatters 1-2 cm, and its points behind the plane passed for glass
        (a depth of 4 cm for a 10 cm reveal, widths 0.25 m too wide).
    min_side_seen
        A side of an opening (sill, head, jamb) counts as seen when reveal points facing
        out of that side span at least this share of the opening's extent along it;
        an unseen side is taken from the face's hole (:func:`unseen_sides_from_hole`).
        A semicircular head spans about 0.7 of the width within 45 deg of the top, a
        pointed one less; a sill hidden behind a deep reveal, none.
    """

    search_voxel_m: float = 0.08
    voxel_m: float = 0.04
    vertical_tolerance: float = 0.2
    face_min_points: int = 150
    face_band_m: float = 0.04
    azimuth_bin_deg: float = 1.0
    offset_bin_m: float = 0.05
    max_faces: int = 60
    cell_spacings: float = 2.5
    min_cell_m: float = 0.06
    max_cell_m: float = 0.6
    min_width_m: float = 0.25
    min_height_m: float = 0.4
    max_side_m: float = 8.0
    max_recess_m: float = 1.5
    min_boundary_coverage: float = 0.5
    leaf_fill: float = 0.6
    leaf_density: float = 0.7
    pane_thickness_m: float = 0.02
    outline_band_m: float = 0.25
    max_recess_points: int = 20000
    min_outline_points: int = 300
    min_glass_points: int = 20
    min_glass_extent_points: int = 30
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    level: bool = True
    max_level_deg: float = 5.0
    max_recess_keep: int = 2500
    min_recess_depth_m: float = 0.015
    face_noise_factor: float = 3.0
    min_side_seen: float = 0.25


@dataclass(frozen=True, eq=False)
class Opening:
    """A glazed opening seen in one cloud (cloud local frame).

    Attributes
    ----------
    centre
        Centre of the outline's bounding box on the pane mid-plane.
    normal
        Pane normal pointing to the viewer (out of the recess).
    h, v
        Horizontal and (nearly) vertical unit vectors of the pane plane; ``h`` is
        ``up x normal_face`` with the face normal of the histogram (not the viewer).
    width, height
        Outline size along ``h`` and ``v`` (1st to 99th percentile).
    outline
        ``(M, 3)`` outline points on the mid-plane.
    outline_normal
        ``(M, 3)`` in-plane unit normals of the outline (pointing out of the opening).
    depth_m
        Depth of the mid-plane behind the wall face.
    n_glass
        Glass points used for the pane depth (0: depth from the reveal ends).
    face
        Index of the wall face.
    recess, recess_normal
        ``(R, 3)`` points of the recess that are not glass (reveals from the face to the
        glass, the other side's reveals seen through it) and their unit normals (sign
        free): the raw surfaces of the restricted ICP (empty when not kept).
    sides_from_face
        Sides of the extent (``"left"``, ``"right"``, ``"bottom"``, ``"top"``) that no
        reveal showed, taken from the hole in the wall face instead
        (:func:`unseen_sides_from_hole`); ``width``, ``height`` and ``centre`` include them.
    """

    centre: Array
    normal: Array
    h: Array
    v: Array
    width: float
    height: float
    outline: Array
    outline_normal: Array
    depth_m: float
    n_glass: int
    face: int
    recess: Array = field(default_factory=lambda: np.zeros((0, 3)))
    recess_normal: Array = field(default_factory=lambda: np.zeros((0, 3)))
    sides_from_face: tuple[str, ...] = ()


def voxel_centroids(xyz: Array, voxel_m: float) -> Array:
    """Centroid of the points of every occupied voxel (``voxel_m`` cubes)."""
    key = np.floor((xyz - xyz.min(axis=0)) / voxel_m).astype(np.int64)
    span = key.max(axis=0) + 1
    flat = (key[:, 0] * span[1] + key[:, 1]) * span[2] + key[:, 2]
    _, inv, cnt = np.unique(flat, return_inverse=True, return_counts=True)
    out = np.column_stack(
        [np.bincount(inv, weights=xyz[:, k], minlength=len(cnt)) for k in range(3)]
    )
    return out / cnt[:, None]


def estimate_up(
    normals: Array, prior: Array, tolerance: float = 0.2, iterations: int = 6
) -> Array | None:
    """The vertical of a cloud from its walls: the direction most normal to their normals.

    Unit normals within ``tolerance`` (``|n . up|``) of the horizontal are walls; the
    vertical is the eigenvector of the smallest eigenvalue of their second-moment
    matrix, re-estimated on the normals within three robust spreads of it (reveals,
    splays and noisy edge normals drop out).

    Parameters
    ----------
    normals
        ``(N, 3)`` unit normals (sign free).
    prior
        Unit vertical to start from.
    tolerance
        First wall selection (``|n . prior|`` below it).
    iterations
        Trimmed re-estimates.

    Returns
    -------
    ndarray or None
        The unit vertical on the side of ``prior``; ``None`` when the walls do not fix
        it (fewer than 100 wall normals, or walls of one azimuth only: the direction
        along them is then free).
    """
    up = np.asarray(prior, float) / np.linalg.norm(prior)
    tol = tolerance
    for _ in range(iterations):  # a few trimmed eigen-solves of a 3 x 3 matrix
        N = normals[np.abs(normals @ up) < tol]
        if len(N) < 100:
            return None
        ev, vec = np.linalg.eigh(N.T @ N / len(N))
        if ev[1] < 10 * ev[0] + 0.01:  # one wall direction: the vertical is not fixed
            return None
        u = vec[:, 0] * np.sign(vec[:, 0] @ up)
        tol = max(3 * 1.4826 * float(np.median(np.abs(N @ u))), 0.01)
        up = u
    return up


# ----------------------------------------------------------------------------- faces
def _faces(vox: Array, normals: Array, p: PaneParams) -> list[tuple[Array, float]]:
    """Vertical planes (unit normal, offset) of centred voxels, peak by peak."""
    up = np.asarray(p.up, float)
    vert = np.abs(normals @ up) < p.vertical_tolerance
    idx = np.flatnonzero(vert & (np.linalg.norm(normals, axis=1) > 0.5))
    if len(idx) < p.face_min_points:  # no vertical surface at all
        return []
    nh = normals[idx] - np.outer(normals[idx] @ up, up)
    nh /= np.linalg.norm(nh, axis=1, keepdims=True)
    e1 = np.cross(up, [1.0, 0, 0]) if abs(up[0]) < 0.9 else np.cross(up, [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    az = np.arctan2(nh @ e2, nh @ e1) % np.pi  # unoriented normals: azimuth mod 180 deg
    canon = np.outer(np.cos(az), e1) + np.outer(np.sin(az), e2)
    off = np.einsum("ij,ij->i", canon, vox[idx])
    na = round(180.0 / p.azimuth_bin_deg)
    ia = np.minimum((az / np.pi * na).astype(int), na - 1)
    # offsets on a grid symmetric about 0: across the azimuth wrap (0 = 180 deg) the
    # canonical normal flips, and offset bin ``b`` becomes ``no - 1 - b``
    half = float(np.abs(off).max()) + p.offset_bin_m
    no = int(np.ceil(2 * half / p.offset_bin_m))
    io = np.clip(((off + half) / p.offset_bin_m).astype(int), 0, no - 1)
    alive = np.ones(len(idx), bool)
    faces = []
    for _ in range(p.max_faces):  # tens of faces, one histogram each
        hist = np.bincount(ia[alive] * no + io[alive], minlength=na * no).reshape(na, no)
        # 3x3 sums so that a face split over two bins still peaks; the azimuth wraps
        # with the offsets mirrored (a face at 0.5 deg and one at 179.5 deg are one
        # direction, the second's offsets negated)
        padded = np.vstack([hist[-1:, ::-1], hist, hist[:1, ::-1]]).astype(float)
        sm = ndimage.uniform_filter(padded, size=3, mode="constant")[1:-1] * 9
        k = int(np.argmax(sm))
        if sm.flat[k] < p.face_min_points:
            break
        a0, b0 = divmod(k, no)
        da = np.abs(ia - a0)
        wrapped = da > na - da
        da = np.minimum(da, na - da)
        ib = np.where(wrapped, no - 1 - io, io)
        cand = alive & (da <= 2) & (np.abs(ib - b0) <= 1)
        pts = vox[idx[cand]]
        # least squares plane through the candidates, then its band
        c = pts.mean(axis=0)
        _, vecs = np.linalg.eigh(np.cov((pts - c).T))
        n = vecs[:, 0]
        n = n - (n @ up) * up  # a wall face is vertical: keep the normal horizontal
        n /= np.linalg.norm(n)
        d = float(n @ c)
        dist = np.abs(vox[idx] @ n - d)
        cos = np.abs(normals[idx] @ n)
        member = alive & (dist < p.face_band_m) & (cos > 0.9)
        alive &= ~member
        alive &= ~cand
        if member.sum() >= p.face_min_points:
            faces.append((n, d))
    return faces


# ----------------------------------------------------------------------------- openings
def _plane_axes(n: Array, up: Array) -> tuple[Array, Array]:
    h = np.cross(up, n)
    h /= np.linalg.norm(h)
    return h, np.cross(n, h)


def recess_floor(face_depth: Array, p: PaneParams) -> float:
    """Depth behind a face plane where its recess starts, from the face's own scatter.

    Parameters
    ----------
    face_depth
        Signed distances (m) of the face points around an opening to the face plane.
    p
        :class:`PaneParams` (``min_recess_depth_m``, ``face_noise_factor``).

    Returns
    -------
    float
        ``|median| + face_noise_factor x 1.4826 x MAD`` of ``face_depth``, at least
        ``min_recess_depth_m`` (also with fewer than 20 face points).
    """
    if len(face_depth) < 20:
        return p.min_recess_depth_m
    med = float(np.median(face_depth))
    sigma = 1.4826 * float(np.median(np.abs(face_depth - med)))
    return max(p.min_recess_depth_m, abs(med) + p.face_noise_factor * sigma)


def _sector_coverage(uv: Array, centre: Array, n_sectors: int = 16) -> float:
    if len(uv) == 0:
        return 0.0
    ang = np.arctan2(uv[:, 1] - centre[1], uv[:, 0] - centre[0])
    sec = ((ang + np.pi) / (2 * np.pi) * n_sectors).astype(int) % n_sectors
    return len(np.unique(sec)) / n_sectors


def _two_face_depth(g: Array, thickness: float, iterations: int = 30) -> float:
    """Depth of the near face of a glass slab from returns of both faces (EM).

    A beam returns from the near face or, having passed it, from the far face
    ``thickness`` behind: a two-component Gaussian mixture with a known separation,
    a common spread and a free share, fitted by expectation-maximisation.
    """
    mu = float(np.percentile(g, 25))
    sig = max(float(np.std(g)) / 2, 1e-3)
    share = 0.5
    for _ in range(iterations):  # a few tens of EM steps on ~1000 values
        a = (1 - share) * np.exp(-0.5 * ((g - mu) / sig) ** 2)
        b = share * np.exp(-0.5 * ((g - mu - thickness) / sig) ** 2)
        w = b / np.maximum(a + b, 1e-300)
        share = float(np.clip(w.mean(), 0.05, 0.95))
        mu = float(np.mean(g - w * thickness))
        sig = max(float(np.sqrt(np.mean((g - mu - w * thickness) ** 2))), 1e-3)
    return mu


def _pane_depth(
    depth: Array,
    pane_like: NDArray[np.bool_],
    reveal_like: NDArray[np.bool_],
    thickness: float,
    cells: NDArray[np.int_] | None = None,
    min_glass: int = 20,
) -> tuple[float | None, int]:
    """Depth of the near glass face: the glass points' slab, else where the reveals end.

    Several layers parallel to the face may hold points (the glass, but also a
    pointed head's intrados or a mullion seen edge-on from below); the glass is the
    one that spreads over the opening, so with ``cells`` (the opening's raster cell
    of every point, -1 outside the hole) the layer covering most cells is taken, and
    a layer lying mostly outside the hole (the scatter of a noisy face around it) is
    no glass.
    """
    g = depth[pane_like]
    gc = cells[pane_like] if cells is not None else np.arange(len(g))
    if len(g) >= min_glass:
        hist, edges = np.histogram(g, bins=np.arange(0.0, g.max() + 0.02, 0.01))
        best: tuple[int, int, Array] | None = None
        for k in np.argsort(-hist)[:6]:  # the few strongest layers
            if hist[k] == 0:
                break
            peak = 0.5 * (edges[k] + edges[k + 1])
            sel = np.abs(g - peak) < thickness + 0.02
            near = g[sel]
            if len(near) < min_glass or len(near) <= 0.3 * len(g):
                continue
            covered = gc[sel]
            if (covered >= 0).mean() < 0.5:
                continue  # a layer over the face ring, not the hole: the face's own scatter
            score = (len(np.unique(covered[covered >= 0])), len(near))
            if best is None or score > best[:2]:
                best = (*score, near)
        if best is not None:
            return _two_face_depth(best[2], thickness), len(best[2])
    r = np.sort(depth[reveal_like])
    if len(r) < 20:
        return None, 0
    # reveals run continuously from the face to the glass; points seen through the
    # glass (the other side's reveal) lie beyond a gap
    gaps = np.flatnonzero(np.diff(r) > 0.04)
    end = r[gaps[0]] if len(gaps) else r[-1]
    part = r[r <= end]
    return float(np.percentile(part, 99.5)), 0


def _opening(
    xyz: Array,
    tree: cKDTree,
    n: Array,
    d: float,
    h: Array,
    v: Array,
    mask: NDArray[np.bool_],
    lo: Array,
    cell: float,
    face_density: float,
    face_id: int,
    p: PaneParams,
) -> Opening | None:
    """One candidate opening (raster ``mask`` of the face) -> its pane outline or None."""
    ii, jj = np.nonzero(mask)
    u0, u1 = lo[0] + ii.min() * cell, lo[0] + (ii.max() + 1) * cell
    v0, v1 = lo[1] + jj.min() * cell, lo[1] + (jj.max() + 1) * cell
    if u1 - u0 < p.min_width_m or v1 - v0 < p.min_height_m:
        return None
    if max(u1 - u0, v1 - v0) > p.max_side_m:
        return None
    grow = ndimage.binary_dilation(mask, iterations=2)
    near_edge = ndimage.binary_dilation(mask, iterations=1)
    cu, cv = 0.5 * (u0 + u1), 0.5 * (v0 + v1)
    c3 = d * n + cu * h + cv * v
    r = 0.5 * np.hypot(u1 - u0, v1 - v0) + 3 * cell + p.max_recess_m
    near = np.asarray(tree.query_ball_point(c3, r), dtype=int)
    if len(near) < 30:
        return None
    q = xyz[near]
    dep = q @ n - d
    qu, qv = q @ h, q @ v
    gi = np.floor((qu - lo[0]) / cell).astype(int)
    gj = np.floor((qv - lo[1]) / cell).astype(int)
    ok = (gi >= 0) & (gi < mask.shape[0]) & (gj >= 0) & (gj < mask.shape[1])
    inside = np.zeros(len(q), bool)
    inside[ok] = grow[gi[ok], gj[ok]]
    # the face's own scatter sets where the recess starts: a noisy face (photogrammetry,
    # a far TLS station) puts points centimetres behind its plane all round the hole,
    # and they would pass for glass or reveal
    ring = np.zeros(len(q), bool)
    ring[ok] = grow[gi[ok], gj[ok]] & ~near_edge[gi[ok], gj[ok]]
    on_ring = ring & (np.abs(dep) < p.face_band_m)
    floor = recess_floor(dep[on_ring], p)
    # the face's density round this opening (a detail scan of a window covers its
    # surroundings too, beyond the face's overall density)
    ring_cells = np.unique(gi[on_ring] * mask.shape[1] + gj[on_ring])
    if len(ring_cells) >= 8:
        face_density = max(face_density, on_ring.sum() / (len(ring_cells) * cell * cell))
    band = inside & (np.abs(dep) > floor) & (np.abs(dep) < p.max_recess_m)
    # the recess is on the side holding more points inside the opening's prism
    side = 1.0 if (dep[band] > 0).sum() >= (dep[band] < 0).sum() else -1.0
    rec = band & (side * dep > 0)
    if rec.sum() < 30:
        return None
    pts, dd = q[rec], side * dep[rec]
    if len(pts) > p.max_recess_points:  # regular thinning keeps the outline's spread
        keep = np.linspace(0, len(pts) - 1, p.max_recess_points).astype(int)
        pts, dd = pts[keep], dd[keep]
    k = min(12, len(pts))
    nrm, _ = estimate_normals(pts, k=k)
    e = side * n  # into the wall
    cosn = np.abs(nrm @ e)
    pane_like = cosn > 0.9
    reveal_like = cosn < 0.95  # splayed reveals stand up to about 70 deg off the face
    ci = np.floor((pts @ h - lo[0]) / cell).astype(int)
    cj = np.floor((pts @ v - lo[1]) / cell).astype(int)
    okc = (ci >= 0) & (ci < mask.shape[0]) & (cj >= 0) & (cj < mask.shape[1])
    cells = np.where(okc, ci * mask.shape[1] + cj, -1)
    cells[okc] = np.where(mask[ci[okc], cj[okc]], cells[okc], -1)  # the hole's own cells
    depth_g, n_glass = _pane_depth(
        dd, pane_like, reveal_like, p.pane_thickness_m, cells, p.min_glass_points
    )
    if depth_g is None or depth_g < 0.03:
        return None
    mid = depth_g + p.pane_thickness_m / 2
    # door leaf or panel: a dense planar patch filling the opening at depth (as dense as
    # the face round it; glass returns a fraction of the beams)
    at = pane_like & (np.abs(dd - depth_g) < 0.03)
    if at.any():
        ci = np.floor((pts[at] @ h - lo[0]) / cell).astype(int)
        cj = np.floor((pts[at] @ v - lo[1]) / cell).astype(int)
        okc = (ci >= 0) & (ci < mask.shape[0]) & (cj >= 0) & (cj < mask.shape[1])
        cells = np.unique(ci[okc] * mask.shape[1] + cj[okc])
        fill = np.isin(cells, np.flatnonzero(mask.ravel())).sum() / max(mask.sum(), 1)
        area = mask.sum() * cell * cell
        density = at.sum() / max(area, 1e-9)
        if fill >= p.leaf_fill and density >= p.leaf_density * face_density:
            return None
    # outline: reveal points in front of the glass slid along their tangent plane
    # (the nearest ``outline_band_m`` to the glass, deeper where a deep reveal is seen
    # only near the face: at least ``min_outline_points``)
    front = reveal_like & (dd > 0.01) & (dd < depth_g - 0.003)
    gap = np.sort(depth_g - dd[front])
    band = max(p.outline_band_m, gap[min(p.min_outline_points, len(gap)) - 1] if len(gap) else 0)
    sel = front & (dd >= depth_g - band)
    if sel.sum() < 20:
        return None
    nn = nrm[sel]
    g = e - (nn @ e)[:, None] * nn
    ge = g @ e
    good = ge > 0.1
    if good.sum() < 20:
        return None
    P = pts[sel][good] + g[good] * ((mid - dd[sel][good]) / ge[good])[:, None]
    on = (P @ n - d) * side
    P = P + np.outer(mid - on, e)  # exactly on the mid-plane
    ou, ov = P @ h, P @ v
    if _sector_coverage(np.column_stack([ou, ov]), np.array([cu, cv])) < p.min_boundary_coverage:
        return None
    lo_u, hi_u = np.percentile(ou, [1, 99])
    lo_v, hi_v = np.percentile(ov, [1, 99])
    if at.sum() >= p.min_glass_extent_points:
        # the glass fills the opening up to its reveals: where a reveal is hidden from
        # the viewer (a jamb at a grazing angle, a sill seen from below) the glass still
        # shows the opening's extent, so the size and centre come from both
        gu, gv = pts[at] @ h, pts[at] @ v
        glo_u, ghi_u = np.percentile(gu, [1, 99])
        glo_v, ghi_v = np.percentile(gv, [1, 99])
        lo_u, hi_u = min(lo_u, glo_u), max(hi_u, ghi_u)
        lo_v, hi_v = min(lo_v, glo_v), max(hi_v, ghi_v)
    ip = nn[good] - np.outer(nn[good] @ e, e)
    ip /= np.maximum(np.linalg.norm(ip, axis=1, keepdims=True), 1e-12)
    cen2 = np.array([0.5 * (lo_u + hi_u), 0.5 * (lo_v + hi_v)])
    rel = np.column_stack([ou, ov]) - cen2
    flip = (ip @ h) * rel[:, 0] + (ip @ v) * rel[:, 1] < 0
    ip[flip] *= -1  # out of the opening
    # a side of the outline hidden from the viewer (a sill seen from below through a
    # deep reveal) leaves the extent short by decimetres: that side is taken from the
    # face's hole, less the splay measured on the sides that are seen
    hole = (u0, u1, v0, v1)
    extent = unseen_sides_from_hole(
        np.column_stack([ou, ov]),
        np.column_stack([ip @ h, ip @ v]),
        (lo_u, hi_u, lo_v, hi_v),
        hole,
        cell,
        p.min_side_seen,
    )
    lo_u, hi_u, lo_v, hi_v = extent.extent
    w, hgt = hi_u - lo_u, hi_v - lo_v
    if w < p.min_width_m or hgt < p.min_height_m:
        return None
    cen2 = np.array([0.5 * (lo_u + hi_u), 0.5 * (lo_v + hi_v)])
    centre = (d + side * mid) * n + cen2[0] * h + cen2[1] * v
    keep = np.flatnonzero(~pane_like)
    if len(keep) > p.max_recess_keep:  # regular thinning
        keep = keep[np.linspace(0, len(keep) - 1, p.max_recess_keep).astype(int)]
    return Opening(
        centre=centre,
        normal=-e,
        h=h,
        v=v,
        width=float(w),
        height=float(hgt),
        outline=P,
        outline_normal=ip,
        depth_m=float(mid),
        n_glass=int(n_glass),
        face=face_id,
        recess=pts[keep],
        recess_normal=nrm[keep],
        sides_from_face=extent.from_face,
    )


def detect_openings(
    xyz: Array, params: PaneParams | None = None, tree: cKDTree | None = None
) -> list[Opening]:
    """Glazed openings of a cloud with their pane mid-plane outlines.

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates in a local frame, metres.
    params
        :class:`PaneParams`.
    tree
        KD-tree on ``xyz`` (built if omitted).

    Returns
    -------
    list of Opening
        Empty when the cloud has no glazed opening (the caller decides what that means).
    """
    p = params or PaneParams()
    up = np.asarray(p.up, float) / np.linalg.norm(p.up)
    tree = tree if tree is not None else cKDTree(xyz)
    coarse = voxel_centroids(xyz, p.search_voxel_m)
    if len(coarse) < 50:
        return []
    c0 = coarse.mean(axis=0)  # votes on centred coordinates: offsets stay small
    normals, _ = estimate_normals(coarse - c0, k=12)
    if p.level:
        lev = estimate_up(normals, up, p.vertical_tolerance)
        if lev is not None and lev @ up >= np.cos(np.deg2rad(p.max_level_deg)):
            up = lev
            p = replace(p, up=tuple(float(x) for x in up))
    vox = voxel_centroids(xyz, p.voxel_m)
    out: list[Opening] = []
    for fi, (n, d0) in enumerate(_faces(coarse - c0, normals, p)):  # tens of faces
        d = d0 + float(n @ c0)
        h, v = _plane_axes(n, up)
        fpts = vox[np.abs(vox @ n - d) < p.face_band_m]
        if len(fpts) < p.face_min_points:
            continue
        # the face's own point spacing (full resolution) sizes the raster cells
        spacing = face_spacing(xyz, tree, fpts)
        cell = raster_cell(spacing, p)
        uv = np.column_stack([fpts @ h, fpts @ v])
        # raster of the face at voxel resolution (a cell holds a voxel where it has points)
        occ, lo = occupancy(uv, cell)
        lab, nlab = enclosed_holes(occ)
        if nlab == 0:
            continue
        face_density = 1.0 / max(spacing, 1e-4) ** 2  # points per square metre
        masks = []
        for k, sl in enumerate(ndimage.find_objects(lab), start=1):  # enclosed holes
            if sl is None:
                continue
            mask = np.zeros(lab.shape, bool)
            mask[sl] = lab[sl] == k
            masks.append(mask)
        depth = vox @ n - d
        rec = (np.abs(depth) > p.face_band_m) & (np.abs(depth) < p.max_recess_m)
        behind = [vox[rec & (sgn * depth > 0)] for sgn in (1.0, -1.0)]
        behind_uv = [np.column_stack([q @ h, q @ v]) for q in behind]
        masks += open_holes(occ, lo, cell, lab, behind_uv, p)
        for mask in masks:
            if mask.sum() * cell * cell < p.min_width_m * p.min_height_m * 0.5:
                continue
            for m2, lo2, cell2, dens2 in local_holes(
                mask, lo, cell, face_density, uv, fpts, xyz, tree, p
            ):
                op = _opening(xyz, tree, n, d, h, v, m2, lo2, cell2, dens2, fi, p)
                if op is not None:
                    out.append(op)
    return out
