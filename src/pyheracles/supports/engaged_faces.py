"""Free column shapes standing against a wall's face turned into engaged columns: the
face found among the points beside the shaft, or, where the shaft shadows them, on the
slab's wall face lines the column's ring meets (:mod:`pyheracles.supports.engaged_fronts`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.core import Array, Scales
from pyheracles.supports.engaged_fronts import ring_on_face_line
from pyheracles.supports.line_responds import face_lines
from pyheracles.supports.rings import WALL_BAND_M, wall_face_beside


def engage_on_wall_faces(
    p: Array,
    order: NDArray[np.intp],
    z_sorted: Array,
    shapes: list[dict],
    h_sec: float,
    sc: Scales,
    rng: np.random.Generator,
    seed: int = 0,
) -> None:
    """Turn the free column shapes that stand against a wall's face into engaged ones,
    in place.

    The section's wall islands next to an engaged column are often missing: the shaft
    shadows the wall beside it, and high up a wall's face is sparse in a thin slab
    (:func:`~pyheracles.supports.rings.detached_half_column` needs wall points within a
    few centimetres).  Here the face is sought among the points of a slab
    ``WALL_BAND_M`` above and below the shape's section, within ``radius + max(1 m,
    radius)`` of its centre (:func:`~pyheracles.supports.rings.wall_face_beside`); where
    too few of them show it (the wall beside the shaft shadowed or cut by a window: draw 38),
    on the slab's wall face lines
    (:func:`~pyheracles.supports.line_responds.face_lines`, drawn with a generator of
    their own seeded with ``seed``) that the column's ring meets
    (:func:`~pyheracles.supports.engaged_fronts.ring_on_face_line`).
    """
    # per section height the slab's plan points sorted by x: each column takes its
    # window by two binary searches, not a mask over the whole slab
    slabs: dict[float, tuple[Array, Array, Array, NDArray[np.intp]]] = {}
    lines: dict[float, list[tuple[Array, float, float, Array]]] = {}  # face lines per slab
    for sh in shapes:
        if sh["class"] != "column":
            continue
        h = float(sh.get("h_sec", h_sec))
        if h not in slabs:
            a, b = np.searchsorted(z_sorted, [h - WALL_BAND_M, h + WALL_BAND_M])
            idx = order[a:b]
            perm = np.argsort(p[idx, 0], kind="stable")
            idx = idx[perm]
            slabs[h] = (p[idx, :3], np.abs(p[idx, 2] - h) <= sc.thickness / 2, p[idx, 0], perm)
        xyz, thin, xs, perm = slabs[h]
        xy = xyz[:, :2]
        c, r = np.asarray(sh["centre"], dtype=np.float64), float(sh["radius"])
        reach = r + max(1.0, r)
        a, b = np.searchsorted(xs, [c[0] - reach, c[0] + reach])
        box = a + np.flatnonzero(np.abs(xy[a:b, 1] - c[1]) <= reach)
        box = box[np.argsort(perm[box])]  # in the slab's own order (the face search samples)
        near = xy[box]
        dist = np.hypot(*(near - c).T)
        ring = near[thin[box] & (np.abs(dist - r) <= max(2.0 * sc.tol, 0.1 * r))]
        inside = dist <= reach
        up = xyz[box[inside], 2] - (h - WALL_BAND_M)
        face = wall_face_beside(near[inside], ring, c, r, sc.tol, rng, up)
        if face is None:  # the wall beside it shadowed or sparse: the slab's face lines
            if h not in lines:
                found = face_lines(xy, sc.tol, np.random.default_rng(seed))
                lines[h] = [(n, d, rms, xy[m]) for n, d, rms, m in found]
            face = ring_on_face_line(ring, c, r, lines[h], sc.tol)
        if face is None:
            continue
        n, d, face_rms = face
        sh["class"] = "engaged_column"
        sh.update(normal=n, d=d, face_gap=max(0.01, 3.0 * face_rms), angle=0.0)
        sh["half"] = np.array([r, r])
