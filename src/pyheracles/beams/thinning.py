"""Random thinning of a cloud to a target spacing, measured locally.

A terrestrial scan is dense near its stations and sparse far away: on one
roof the faces of the nearest tie beam hold a point every 2-3 mm and the
common rafters in the far slope one every 1-2 cm.  Thinning the whole cloud by
the ratio of its median spacing to the target leaves the near faces too dense
(24 neighbours then span less than the noise allows: noisy normals, high
curvature) and thins the far faces further, below the five or so points across
a narrow face that a normal needs (roof draw 6: eight common rafters seen at
1.1-1.7 cm came out with normals 15-25 degrees off and no facet).  Each point
is kept with the probability that brings *its neighbourhood* to the target
spacing, so sparse parts are kept whole.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

__all__ = ["local_spacing", "thin_to_spacing"]

#: Side of the cells over which the local spacing is averaged, in target spacings.
CELL_SPACINGS = 10.0


def local_spacing(
    xyz: NDArray[np.float64], tree: cKDTree, cell_m: float, stride: int = 4
) -> NDArray[np.float64]:
    """Per point, the mean nearest-neighbour distance in its cell, metres.

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates, metres.
    tree
        KD-tree on ``xyz``.
    cell_m
        Side of the cubic cells (a voxel grid) the distances are averaged over,
        metres: one point's nearest-neighbour distance is noisy, a cell's mean
        is the spacing of the surface there.
    stride
        The distances are measured on every ``stride``-th point (in the
        cloud's order; a cell of a dense surface holds hundreds); a cell with
        none of them gets ``inf`` (it holds fewer than ``stride`` points or so:
        sparse).

    Returns
    -------
    numpy.ndarray
        ``(N,)`` spacing, metres (exact duplicates count as the spacing of
        the distinct positions: distance 0 is skipped).
    """
    n = len(xyz)
    if n < 3:
        return np.full(n, np.inf)
    cell = np.floor((xyz - xyz.min(axis=0)) / cell_m).astype(np.int64)
    key = np.ravel_multi_index(cell.T, tuple(cell.max(axis=0) + 1))
    _, inverse = np.unique(key, return_inverse=True)
    sample = np.arange(0, n, max(1, stride))
    dist, _ = tree.query(xyz[sample], k=3, workers=-1)
    d = np.where(dist[:, 1] > 0, dist[:, 1], dist[:, 2])
    n_cells = int(inverse.max()) + 1
    total = np.bincount(inverse[sample], weights=d, minlength=n_cells)
    count = np.bincount(inverse[sample], minlength=n_cells)
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = np.where(count > 0, total / np.maximum(count, 1), np.inf)
    return mean[inverse]


def thin_to_spacing(
    xyz: NDArray[np.float64],
    tree: cKDTree,
    spacing_m: float,
    gen: np.random.Generator,
) -> NDArray[np.int64]:
    """Indices of the points kept by random thinning to ``spacing_m``, locally.

    A point whose cell (:func:`local_spacing`, cells of ``CELL_SPACINGS``
    target spacings) has the spacing ``s`` is kept with the probability
    ``min(1, (s / spacing_m) ** 2)``: its surface density is brought down to
    the target where it is above it, and left alone where it is below.
    Random thinning, unlike a voxel grid, leaves no layering of noisy surfaces.

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates, metres.
    tree
        KD-tree on ``xyz``.
    spacing_m
        Target spacing (median nearest-neighbour distance), metres.
    gen
        Random generator (the same seed gives the same points).

    Returns
    -------
    numpy.ndarray
        Sorted ``int64`` indices into ``xyz``.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.spatial import cKDTree
    >>> g = np.arange(0.0, 1.0, 0.002)
    >>> dense = np.column_stack([np.repeat(g, 20), np.tile(np.arange(20) * 0.002, 500),
    ...                          np.zeros(10000)])
    >>> xyz = np.vstack([dense, dense[::64] + [0, 0, 5.0]])  # a sparse patch far away
    >>> kept = thin_to_spacing(xyz, cKDTree(xyz), 0.008, np.random.default_rng(0))
    >>> bool(np.all(np.isin(np.arange(10000, len(xyz)), kept)))  # the sparse patch is whole
    True
    """
    s = local_spacing(xyz, tree, CELL_SPACINGS * spacing_m)
    keep = np.minimum(1.0, (s / spacing_m) ** 2)
    return np.flatnonzero(gen.random(len(xyz)) < keep)
