"""Pairing: the two faces of one wall, faces inside a wall, the side of a lone face."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.walls.model import Array, WallFace, WallParams
from pyheracles.walls.planes import fit_vertical, plane_frame

__all__ = ["join_coplanar", "material_side", "pair_faces", "reveal_drafts", "shared_cells"]


def pair_faces(xyz: Array, faces: list[WallFace], p: WallParams) -> list[tuple[int, ...]]:
    """Groups of face indices: pairs forming one wall, singles.

    Two parallel faces a wall thickness apart are candidates when they are seen over the
    same stretch of wall: at least half of the smaller face's cells on the plane (a grid
    of ``max(2 cell_m, 0.1 m)``) are cells of the other too, or past the other's end in
    their row by no more than the faces' separation (:func:`shared_cells`: a corner),
    and the cells they share make a face's smallest area (``min_area_m2``: a face
    wholly past the other's end, a pier's or a respond's near a corner, is no part of
    it) or the smaller lies over the other's stretch (:func:`_over_stretch`: an outer
    face seen beside an apse and above its roof only).  Glass and door leaves recessed
    in the openings of a face lie in its holes and share few cells with it.
    Candidates are taken in decreasing shared area (not by separation: a face of the
    panes of a row of windows is nearer the outer face than the inner face is), and a
    face lying between the two faces of a chosen pair over their extent is inside that
    wall (glass, leaves, reveals): it is no wall face and is left out of every group.
    """
    cos_par = math.cos(math.radians(p.parallel_deg))
    cell = max(2 * p.cell_m, 0.1)
    cands = []
    for i in range(len(faces)):
        for j in range(i + 1, len(faces)):
            fi, fj = faces[i], faces[j]
            c = float(fi.normal @ fj.normal)
            if abs(c) < cos_par:
                continue
            s = math.copysign(1.0, c)
            sep = abs(fi.d - s * fj.d)
            if not p.min_thickness_m <= sep <= p.max_thickness_m:
                continue
            _, u = plane_frame(fi.normal, fi.d)
            ci, cj = _cells(xyz[fi.indices], u, cell), _cells(xyz[fj.indices], u, cell)
            small, big = (ci, cj) if len(ci) <= len(cj) else (cj, ci)
            shared = len(np.intersect1d(ci, cj, assume_unique=True))
            if shared * cell**2 < p.min_area_m2 and not _over_stretch(small, big, cell, p):
                continue  # not over one stretch of wall
            if shared_cells(small, big, int(np.ceil(sep / cell))) < 0.5 * len(small):
                continue
            cands.append((-shared, sep, i, j))
    cands.sort()
    used: set[int] = set()
    groups: list[tuple[int, ...]] = []
    for _, _, i, j in cands:
        if i in used or j in used:
            continue
        used |= {i, j}
        groups.append((i, j))
    inner = {k for k in range(len(faces)) if k not in used
             and any(_between(xyz, faces, k, g, cos_par, p) for g in groups)}  # fmt: skip
    groups += [(i,) for i in range(len(faces)) if i not in used and i not in inner]
    return groups


def join_coplanar(
    xyz: Array, faces: list[WallFace], groups: list[tuple[int, ...]], p: WallParams
) -> tuple[list[WallFace], list[tuple[int, ...]]]:
    """Faces and groups (:func:`pair_faces`) with every lone face that lies on a face of
    a pair joined to that face: on its plane (median distance within a third of
    ``distance_m``), and within the other face's extent (nine tenths of its points
    within its ends and between its foot and top).

    A wall's face crossed by a roof is seen in two pieces, one above the other: a nave
    arcade's aisle side below the aisle's lean-to roof and its clerestory above it.  Only
    the clerestory pairs with the nave side; the aisle side alone was a wall of its
    own, seen on one face, and its junctions, judged with a lone face's reach, cut the
    arcade's clerestory face too (church draw 29: an apse facet's end 0.9 m from the
    arcade cut it, and the clerestory's piece beyond the cut left a false 0.29 m window
    beside a real one).  A piece wholly past the other face's end (a tower's face on the
    plane of the wall's outer face) stays a face of its own.
    """
    pairs = [g for g in groups if len(g) == 2]
    cos_par = math.cos(math.radians(p.parallel_deg))
    joins: dict[int, list[int]] = {}
    for g in groups:
        if len(g) != 1:
            continue
        k = g[0]
        fk = faces[k]
        qk = xyz[fk.indices]
        for a, b in (h for pair in pairs for h in (pair, pair[::-1])):
            fa, fb = faces[a], faces[b]
            if abs(float(fk.normal @ fa.normal)) < cos_par:
                continue
            if np.median(np.abs(qk @ fa.normal - fa.d)) > p.distance_m / 3:
                continue
            _, u = plane_frame(fa.normal, fa.d)
            qb = xyz[fb.indices]
            ub, uk = qb @ u, qk @ u
            within = ((uk >= ub.min()) & (uk <= ub.max()) & (qk[:, 2] >= qb[:, 2].min())
                      & (qk[:, 2] <= qb[:, 2].max()))  # fmt: skip
            if np.mean(within) >= 0.9:
                joins.setdefault(a, []).append(k)
                break
    if not joins:
        return faces, groups
    out = list(faces)
    gone: set[int] = set()
    for a, ks in joins.items():
        idx = np.concatenate([faces[a].indices, *(faces[k].indices for k in ks)])
        n, d, rms = fit_vertical(xyz[idx])
        if rms > p.distance_m / 3:
            continue
        if float(n @ faces[a].normal) < 0:
            n, d = -n, -d
        out[a] = WallFace(n, d, idx, rms)
        gone.update(ks)
    keep = [i for i in range(len(out)) if i not in gone]
    new = {i: j for j, i in enumerate(keep)}
    return [out[i] for i in keep], [tuple(new[i] for i in g) for g in groups
                                    if not set(g) & gone]  # fmt: skip


def _over_stretch(
    small: NDArray[np.int64], big: NDArray[np.int64], cell: float, p: WallParams
) -> bool:
    """Whether the face of the cells ``small`` lies over the stretch of the face of the
    cells ``big``: its columns (along ``u``) within the other's ends make
    ``min_length_m``.

    An east wall's outer face, against whose middle an apse is built, is seen in a strip
    beside the apse at either end or both, each past an end of the inner face by the
    thickness of the nave's side wall, and in the gable's band over the apse's roof,
    above the inner face's top: it shares few cells outright with the inner face (church
    draws 14 and 22: 0.07 and 0.7 m2), where a pier's face wholly past the end of a
    wall's face (draw 8) lies over none of its stretch.
    """
    su, _ = _split(small)
    bu, _ = _split(big)
    cols = np.unique(su)
    over = (cols >= bu.min()) & (cols <= bu.max())
    return bool(np.count_nonzero(over) * cell >= p.min_length_m)


def shared_cells(small: NDArray[np.int64], big: NDArray[np.int64], reach: int) -> int:
    """How many of the cells ``small`` (sorted keys of :func:`_cells`) the face of the
    cells ``big`` covers, or reaches past its end in their row by up to ``reach`` cells.

    At a convex corner a wall's outer face runs past its inner face's end by the
    thickness of the wall it meets (at a concave corner the inner face does): a strip of
    a face between a corner and a tower or an apse (church draw 3's west wall, 1.3 m
    of outer face beside the tower; draw 5's east wall beside the apse) shares only
    39-47 % of its cells with the other face, and stayed a wall of its own.  The rows'
    ends are those of the other face in the same row of cells, so a face's openings
    (glass, leaves recessed in them) are not reached.
    """
    if len(small) == 0 or len(big) == 0:
        return 0
    inside = np.isin(small, big, assume_unique=True)
    su, sz = _split(small)
    bu, bz = _split(big)
    rows = np.unique(bz)
    lo = np.full(len(rows), np.iinfo(np.int64).max)
    hi = np.full(len(rows), np.iinfo(np.int64).min)
    r = np.searchsorted(rows, bz)
    np.minimum.at(lo, r, bu)
    np.maximum.at(hi, r, bu)
    k = np.clip(np.searchsorted(rows, sz), 0, len(rows) - 1)
    same = rows[k] == sz
    past = same & (((su < lo[k]) & (su >= lo[k] - reach)) | ((su > hi[k]) & (su <= hi[k] + reach)))
    return int(np.count_nonzero(inside | past))


def _split(keys: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The ``(u, z)`` cell indices of keys of :func:`_cells` (either may be negative)."""
    z = ((keys + (1 << 31)) & 0xFFFFFFFF) - (1 << 31)
    return (keys - z) >> 32, z


def _cells(pts: Array, u: Array, cell: float) -> np.ndarray:
    """Sorted unique keys of the ``(u, z)`` cells holding points."""
    iu = np.floor(pts @ u / cell).astype(np.int64)
    iz = np.floor(pts[:, 2] / cell).astype(np.int64)
    return np.unique(iu * (1 << 32) + iz)


def _between(xyz: Array, faces: list[WallFace], k: int, pair: tuple[int, ...],
             cos_par: float, p: WallParams) -> bool:  # fmt: skip
    """Whether face ``k`` lies between the two faces of ``pair`` (beyond ``distance_m``
    of both) and within their extent along the wall (most of its length and height)."""
    fk, fa, fb = faces[k], faces[pair[0]], faces[pair[1]]
    n = fa.normal
    if abs(float(n @ fk.normal)) < cos_par:
        return False
    da = fa.d
    db = fb.d * math.copysign(1.0, float(n @ fb.normal))
    dk = fk.d * math.copysign(1.0, float(n @ fk.normal))
    if not min(da, db) + p.distance_m < dk < max(da, db) - p.distance_m:
        return False
    _, u = plane_frame(n, da)
    pk = xyz[fk.indices]
    pw = xyz[np.r_[fa.indices, fb.indices]]
    uk, uw = pk @ u, pw @ u
    inside = ((uk >= uw.min()) & (uk <= uw.max()) & (pk[:, 2] >= pw[:, 2].min())
              & (pk[:, 2] <= pw[:, 2].max()))  # fmt: skip
    return bool(np.mean(inside) >= 0.5)


def material_side(xyz: Array, tree: Any, face: WallFace, p: WallParams) -> int:
    """Side (+1/-1 along the face normal) where the wall's material lies, for a lone face:
    the floor or ground runs up to the foot of a face on the seen side only."""
    pts = xyz[face.indices]
    z0 = np.percentile(pts[:, 2], 1)
    foot = pts[pts[:, 2] <= z0 + 0.3]
    if len(foot) > 400:
        foot = foot[np.linspace(0, len(foot) - 1, 400).astype(np.int64)]
    counts = []
    for s in (1.0, -1.0):
        probe = foot + s * 0.25 * face.normal
        probe[:, 2] = z0
        counts.append(sum(len(v) for v in tree.query_ball_point(probe, 0.12)))
    if counts[0] == counts[1]:
        return 0
    return -1 if counts[0] > counts[1] else 1  # material away from the floor


def reveal_drafts(xyz: Array, drafts: list[dict[str, Any]], run_on: set[int],
                  p: WallParams) -> list[int]:  # fmt: skip
    """Indices of the draft walls that are reveals of another wall: with a face in
    ``run_on`` (the ``id`` of faces long enough only when run on to their corners), at
    more than 45 deg to a wall seen on both faces, and every face lying between that
    wall's faces (nine tenths of its points within half its thickness plus
    ``distance_m`` of its mid-plane, and within its stretch).

    A reveal spans its wall's thickness: in a wall as thick as ``min_length_m``, run on
    to its corners, it is as long as a facet of an apse, and a window's two jambs face
    each other like the faces of a wall (church draw 14, 1.09 m thick: eleven reveals
    became walls of their own).
    """
    cos_max = math.cos(math.radians(45.0))
    walls = [w for w in drafts if len(w["faces"]) == 2]
    out = []
    for k, w in enumerate(drafts):
        if not any(id(f) in run_on for f in w["faces"]):
            continue
        for v in walls:
            if v is w or abs(float(w["faces"][0].normal @ v["normal"])) > cos_max:
                continue
            uv = np.concatenate([(xyz[g.indices] - v["origin"]) @ v["u_axis"] for g in v["faces"]])
            half = 0.5 * float(v["thickness"]) + p.distance_m
            inside = []
            for f in w["faces"]:
                q = xyz[f.indices]
                u = (q - v["origin"]) @ v["u_axis"]
                within = (np.abs(q @ v["normal"] - float(v["d"])) <= half) & (u >= uv.min())
                inside.append(float(np.mean(within & (u <= uv.max()))))
            if min(inside) >= 0.9:
                out.append(k)
                break
    return out
