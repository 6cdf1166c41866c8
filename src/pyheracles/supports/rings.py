"""Circles in a section: column rings from their arcs, engaged (half-) columns on walls."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.geometry.fitting import MSACParams, fit_circle
from pyheracles.segment.euclidean import euclidean_clusters
from pyheracles.supports.core import Array, Island, SupportParams, check_pair_memory, trimmed_rms

#: Arcs of one ring are grouped across gaps up to this wide (metres): the scan lines of a
#: distant terrestrial scan cross a column this far apart (4 cm at 10 m and 0.23 deg,
#: three times that on the grazing flanks of the ring).
ARC_GAP_M = 0.2


#: Radii of the rings recognised from arcs (metres): from the smallest support island
#: (``min_support_size_m`` 0.1 m across) to the largest column of the family.
RING_RADIUS_M = (0.05, 1.5)


def rings_from_arcs(
    xy: Array,
    labels: NDArray[np.intp],
    islands: list[Island],
    params: SupportParams,
    distance_m: float,
) -> list[Island]:
    """Columns whose section ring is broken into arcs and scattered scan-line pieces.

    The clustering distance comes from the spacing of the densest surfaces; a column
    far from the scanners is crossed by scan lines further apart, so its ring falls
    apart into arcs (noise islands) and groups below ``min_points`` (unclustered).
    These leftovers are grouped again with the gap of a distant scan
    (``ARC_GAP_M``), and a group is a column when a circle explains it: radius in
    ``RING_RADIUS_M``, trimmed RMS within a few centimetres and well below that of a
    straight line, the points spread over at least a quarter of the ring.
    """
    noise = [k for k, i in enumerate(islands) if i.kind == "noise"]
    left = np.flatnonzero(labels == 0)
    if noise:
        left = np.r_[left, np.concatenate([islands[k].index for k in noise])]
    gap = max(distance_m, ARC_GAP_M)
    if len(left) < params.min_points or gap <= distance_m:
        return islands
    q = xy[left]
    tree = cKDTree(q)
    check_pair_memory(q, tree, gap)
    lab = euclidean_clusters(q, gap, params.min_points, tree=tree)
    order = np.argsort(lab, kind="stable")
    bounds = np.r_[0, np.cumsum(np.bincount(lab))]
    rings: list[Island] = []
    for g in range(1, len(bounds) - 1):  # loop over groups of arcs
        sub = order[bounds[g] : bounds[g + 1]]
        p = q[sub]
        ext = np.ptp(p, axis=0)
        if np.hypot(*ext) < params.min_support_size_m:
            continue
        circle = fit_circle(p)
        if not circle or not RING_RADIUS_M[0] <= circle.radius <= RING_RADIUS_M[1]:
            continue
        c_rms = trimmed_rms(circle.residuals(p))
        centre = p.mean(axis=0)
        ev = np.linalg.eigvalsh(np.cov((p - centre).T))
        line_rms = float(np.sqrt(max(ev[0], 0.0)))
        ang = np.arctan2(p[:, 1] - circle.center[1], p[:, 0] - circle.center[0])
        sectors = np.unique(np.floor((ang + np.pi) / (2 * np.pi) * 36).astype(int))
        if c_rms > 0.01 + 0.03 * circle.radius or c_rms > 0.5 * line_rms or len(sectors) < 9:
            continue
        rings.append(
            Island(
                "column", left[sub], np.asarray(circle.center), float(circle.radius), 0.0,
                ext, float("nan"), c_rms, line_rms,
            )
        )  # fmt: skip
    if not rings:
        return islands
    used = np.zeros(len(xy), dtype=bool)
    for r in rings:
        used[r.index] = True
    kept = [i for i in islands if i.kind != "noise" or not used[i.index].any()]
    return kept + rings


def engaged_on_wall(
    xy: Array, params: SupportParams, tol: float, distance: float, rng: np.random.Generator
) -> list[tuple[Array, float, Array, float]]:
    """Half-columns on a wall island.

    Returns ``(centre, radius, unit face normal into the room, face offset, face RMS)``.
    """
    rest = np.arange(len(xy))
    lines: list[tuple[Array, float, float]] = []  # (unit normal n, offset d, rms): n.x = d
    msac = MSACParams(threshold=tol, max_trials=300, min_inlier_fraction=0.0)
    for _ in range(12):  # wall faces (a closed wall ring has 8 and more)
        if len(rest) < 20:
            break
        p = xy[rest]
        idx = rng.integers(0, len(p), size=(msac.max_trials, 2))
        dvec = p[idx[:, 1]] - p[idx[:, 0]]
        nrm = np.c_[-dvec[:, 1], dvec[:, 0]]
        ln = np.linalg.norm(nrm, axis=1)
        good = ln > 1e-6
        nrm = nrm[good] / ln[good, None]
        off = np.einsum("ij,ij->i", nrm, p[idx[good, 0]])
        sub = p if len(p) <= 3000 else p[rng.choice(len(p), 3000, replace=False)]
        cost = np.minimum((sub @ nrm.T - off) ** 2, tol**2).sum(axis=0)
        b = int(np.argmin(cost))
        inl = np.abs(p @ nrm[b] - off[b]) <= tol
        if inl.sum() < max(20, 0.02 * len(xy)):
            break
        # refine the face line on its inliers
        q = p[inl]
        m = q.mean(axis=0)
        _, v = np.linalg.eigh((q - m).T @ (q - m))
        n = v[:, 0]
        d = float(n @ m)
        inl = np.abs(p @ n - d) <= tol
        # a face is continuous: its inliers fill most of their span along the line (the
        # aligned apexes of several half-columns are not a face)
        along = p[inl] @ np.array([-n[1], n[0]])
        span = np.ptp(along) if inl.any() else 0.0
        bins = np.unique(np.floor(along / (2 * distance)))
        if span < 1.0 or len(bins) * 2 * distance < 0.7 * span:  # not a chord of a bump
            break
        lines.append((n, d, float(np.sqrt(np.mean((p[inl] @ n - d) ** 2)))))
        rest = rest[~inl]
    if not lines or len(rest) < params.min_points:
        return []
    labels = euclidean_clusters(xy[rest], distance, params.min_points)
    found = []
    for lab in range(1, int(labels.max()) + 1 if len(labels) else 1):
        p = xy[rest[labels == lab]]
        ext = np.ptp(p, axis=0).max()
        if ext < params.min_support_size_m:
            continue
        circle = fit_circle(p)
        lo, hi = params.engaged_radius_m
        noise = float(np.median([f[2] for f in lines]))  # the faces' RMS is the noise level
        if (
            not circle
            or not lo <= circle.radius <= hi
            or circle.rms > min(max(tol, 0.05 * circle.radius), 3 * noise + 0.002)
        ):
            continue
        q = p - circle.center
        arc = np.unique(np.floor((np.arctan2(q[:, 1], q[:, 0]) + np.pi) / (2 * np.pi) * 36))
        if len(arc) < 7:  # less than 70 degrees of arc: a corner, not a half-column
            continue
        # attached to a face: centre close to a face line, bump standing out of it
        for n, d, face_rms in lines:
            dc = float(circle.center @ n - d)
            if abs(dc) <= 0.6 * circle.radius + tol:
                off = p @ n - d
                side = np.sign(np.median(off))
                if side == 0 or np.max(side * off) < 0.5 * circle.radius:
                    continue
                found.append((circle.center, circle.radius, side * n, side * d, face_rms))
                break
    return found


def detached_half_column(
    xy: Array, isl: Island, wall_tree: cKDTree, distance: float
) -> dict | None:
    """A column island that is only an arc and stands against a wall is an engaged column
    whose junction with the wall was not captured (occlusion in the re-entrant corner)."""
    q = xy - isl.center
    bins = np.unique(np.floor((np.arctan2(q[:, 1], q[:, 0]) + np.pi) / (2 * np.pi) * 36))
    if len(bins) > 0.75 * 36:
        return None
    near = wall_tree.query_ball_point(isl.center, isl.radius + 3 * distance)
    if len(near) < 10:
        return None
    w = wall_tree.data[near]
    m = w.mean(axis=0)
    _, vec = np.linalg.eigh(np.cov((w - m).T))
    n = vec[:, 0]  # face normal (smallest spread)
    d = float(n @ m)
    side = np.sign(np.median(xy @ n - d))
    if side == 0 or abs(float(isl.center @ n - d)) > 0.6 * isl.radius + distance:
        return None
    face_rms = float(np.sqrt(np.mean((w @ n - d) ** 2)))
    return {
        "class": "engaged_column",
        "island": None,
        "centre": isl.center,
        "radius": isl.radius,
        "half": np.array([isl.radius, isl.radius]),
        "angle": 0.0,
        "normal": side * n,
        "d": side * d,
        "face_gap": max(0.01, 3 * face_rms),
        "circularity": isl.circularity,
    }
