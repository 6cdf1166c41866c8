"""Region growing again on the sparse parts no facet took, with fewer neighbours.

Region growing of the facets takes the normals and curvature of ``k``
neighbours (24 at the step's 8 mm spacing: about 2.5 cm round a point).  Far
from the stations a slope is scanned at 1.5-3 cm, and there the same ``k``
neighbours span 4-8 cm, the whole width of a narrow face (a common rafter's
8 cm side) and round its edges: the curvature of every point is several
times the threshold and no facet forms; the member is lost whole.  The points
that no facet took and that lie in such sparse parts are grown again with
``k`` scaled down by the square of the spacing ratio (the same neighbourhood
radius as the first pass at the sparse limit).  The angle and curvature
thresholds of that pass are measured on all the points of the sparse parts,
the faces the first pass took included: the points no facet took are mostly
edges and corners, and thresholds measured on them alone let regions grow
round edges (a member's side, the boarding and the next member in one region).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from pyheracles.beams.facets import face_noise_thresholds
from pyheracles.beams.thinning import CELL_SPACINGS, local_spacing
from pyheracles.errors import InputError
from pyheracles.geometry.neighbours import build_tree
from pyheracles.segment.regiongrow import RegionGrowingParams, Regions, region_growing

__all__ = [
    "SparseFaceParams",
    "sparse_k",
    "sparse_leftover",
    "sparse_regions",
    "with_sparse_regions",
]


@dataclass(frozen=True)
class SparseFaceParams:
    """Parameters of the second region growing on sparse parts.

    Attributes
    ----------
    spacing_ratio
        A point is in a sparse part when its local spacing (mean nearest-neighbour
        distance over cells of ``CELL_SPACINGS`` step spacings) is at least this
        many times the step's spacing (dimensionless).
    min_k
        Fewest neighbours of the second pass's normals (a plane through fewer is
        noise), points.
    """

    spacing_ratio: float = 1.5
    min_k: int = 8

    def validate(self) -> SparseFaceParams:
        if self.spacing_ratio <= 1.0:
            raise InputError(f"spacing_ratio must be > 1, got {self.spacing_ratio}")
        if self.min_k < 5:
            raise InputError(f"min_k must be >= 5 points, got {self.min_k}")
        return self


def sparse_k(k: int, p: SparseFaceParams) -> int:
    """Neighbours of the second pass: ``k / ratio**2`` (same radius), at least ``min_k``."""
    return max(p.min_k, round(k / p.spacing_ratio**2))


def sparse_leftover(
    xyz: NDArray[np.float64],
    tree,
    spacing: float,
    left: NDArray[np.int64],
    p: SparseFaceParams,
) -> NDArray[np.int64]:
    """The indices ``left`` (e.g. the points in no facet) that lie in sparse parts of ``xyz``.

    Parameters
    ----------
    xyz
        ``(N, 3)`` points of the step, metres.
    tree
        KD-tree on ``xyz``.
    spacing
        The step's point spacing, metres.
    left
        Candidate indices into ``xyz``.
    p
        :class:`SparseFaceParams`.

    Returns
    -------
    numpy.ndarray
        The subset of ``left`` whose local spacing is at least ``spacing_ratio``
        times ``spacing`` (cells with too few points to measure count as sparse).
    """
    if len(left) == 0:
        return left
    s = local_spacing(xyz, tree, CELL_SPACINGS * spacing)
    return left[s[left] >= p.spacing_ratio * spacing]


def sparse_regions(
    xyz: NDArray[np.float64],
    region: RegionGrowingParams,
    gen: np.random.Generator,
    p: SparseFaceParams,
    faces: NDArray[np.float64] | None = None,
) -> Regions | None:
    """Region growing of sparse points with fewer neighbours, or ``None`` (too few points).

    Parameters
    ----------
    xyz
        ``(m, 3)`` the sparse points no facet took, metres.
    region
        The first pass's parameters (``k``, ``min_points``; the thresholds are
        measured again, on ``faces``).
    gen
        Random generator of the threshold sample.
    p
        :class:`SparseFaceParams`.
    faces
        ``(M, 3)`` all the candidate points of the sparse parts (those the first
        pass took included), metres: the angle and curvature thresholds are
        measured on them (:func:`~pyheracles.beams.facets.face_noise_thresholds`);
        ``None`` (or fewer than ``4 k`` points): on ``xyz``.

    Returns
    -------
    Regions or None
        Regions over ``xyz`` (labels 1..R, 0 = none); ``None`` when ``xyz``
        holds fewer than ``region.min_points`` points.
    """
    k = sparse_k(region.k, p)
    if len(xyz) < max(region.min_points, 4 * k):
        return None
    tree = build_tree(xyz)
    # the thresholds from the whole sparse part, faces the first pass took
    # included: the points no facet took are mostly edges and corners, whose
    # normals and curvature are an edge's (on them alone the angle reaches its
    # cap and the curvature is several times a face's: regions grow round the
    # edges, over a member, the boarding and the next member)
    sample = xyz if faces is None or len(faces) < 4 * k else faces
    ang, curv = face_noise_thresholds(sample, build_tree(sample), k, gen)
    return region_growing(xyz, replace(region, k=k, angle_deg=ang, curvature_max=curv), tree=tree)


def with_sparse_regions(
    xyz: NDArray[np.float64],
    tree,
    spacing: float,
    cand: NDArray[np.int64],
    regions: Regions,
    gen: np.random.Generator,
    p: SparseFaceParams,
) -> tuple[NDArray[np.int32], NDArray[np.float64], NDArray[np.float64]]:
    """The first pass's labels, normals and curvature over ``cand``, with the sparse regions added.

    Parameters
    ----------
    xyz
        ``(N, 3)`` points of the step, metres.
    tree
        KD-tree on ``xyz``.
    spacing
        The step's point spacing, metres.
    cand
        ``(m,)`` indices of the points the first pass grew (not wide surfaces).
    regions
        The first pass's :class:`Regions` over ``xyz[cand]``.
    gen
        Random generator; the second pass draws from a generator spawned from it,
        so the stages after it draw the same numbers whether or not it runs.
    p
        :class:`SparseFaceParams`.

    Returns
    -------
    labels, normals, curvature
        Over ``cand``: the sparse regions numbered after the first pass's.
    """
    labels = regions.labels.copy()
    normals, curvature = regions.normals.copy(), regions.curvature.copy()
    sparse_all = sparse_leftover(xyz, tree, spacing, cand, p)
    left = np.flatnonzero(labels == 0)
    where = left[np.isin(cand[left], sparse_all)]
    second = sparse_regions(
        xyz[cand[where]], regions.params, gen.spawn(1)[0], p, faces=xyz[sparse_all]
    )
    if second is None or second.n_regions == 0:
        return labels, normals, curvature
    got = second.labels > 0
    labels[where[got]] = second.labels[got] + regions.n_regions
    normals[where[got]] = second.normals[got]
    curvature[where[got]] = second.curvature[got]
    return labels, normals, curvature
