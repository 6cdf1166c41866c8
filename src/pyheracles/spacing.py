"""Point spacing, the scale from which automatic parameters are derived (DESIGN.md rule 4)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.errors import InputError

__all__ = ["point_spacing"]


def point_spacing(xyz: NDArray[np.float64], *, sample: int = 50_000, seed: int = 0) -> float:
    """Median distance from a point to its nearest neighbour, metres.

    Measured on a random sample of at most ``sample`` points against the whole
    cloud, so it costs one KD-tree build and is deterministic for a seed.
    Duplicated points (distance 0) are ignored.

    Raises
    ------
    InputError
        Fewer than 2 distinct points.
    """
    pts = np.asarray(xyz, dtype=np.float64)
    if len(pts) < 2:
        raise InputError(f"cannot measure point spacing on {len(pts)} points")
    rng = np.random.default_rng(seed)
    idx = rng.choice(len(pts), size=min(sample, len(pts)), replace=False)
    tree = cKDTree(pts)
    dist, _ = tree.query(pts[idx], k=min(4, len(pts)), workers=-1)
    # first non-zero neighbour distance per sampled point
    first = np.where(dist[:, 1:] > 0, dist[:, 1:], np.inf).min(axis=1)
    first = first[np.isfinite(first)]
    if first.size == 0:
        raise InputError("all points are at the same position; the spacing is undefined")
    return float(np.median(first))
