"""Automatic tie points between an exterior and an interior cloud through window panes.

The two clouds of a heritage building overlap only through its openings (thesis
ch. 3, Murtiyoso 2020: 35 tie points from 24 openings, RMS 4.4 cm against 2.5 cm
with manual tie points).  Pipeline:

1. **Openings** (:func:`~pyheracles.registration.panes.detect_openings`) - wall faces
   from a normal/offset histogram, enclosed holes of each face raster (cells from the
   face's own spacing), a recess behind the face, the pane depth from the sparse
   glass points or the end of the reveals, and the outline on the pane mid-plane
   (glass thickness compensated) for any outline shape.
2. **Matching** (:func:`~pyheracles.registration.pane_matching.match_openings`) -
   size-compatible pairs, rigid-invariant consistency, greedy cliques, point-to-line
   least squares on the mid-plane outlines with the pane depths, explicit refusal of
   ambiguous (one-bay shifted) and mirrored solutions; every hypothesis also refined by
   ICP restricted to the raw recess points of its openings
   (:mod:`~pyheracles.registration.pane_icp`), taken when it verifies.
3. **Tie points** - four outline points per matched opening in both frames (local
   fit of that opening's outline and depth), then the robust similarity (modified
   Danish method) and its report, as for manual tie points.

Assumptions (documented limits): both clouds are metric and roughly levelled (``up``
within a few degrees of the vertical) and the glass thickness is known.

Descriptors for other keypoint pipelines (:func:`fpfh`, :func:`spin_images`) stay here.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles import progress
from pyheracles.cloud import PointCloud
from pyheracles.errors import DegenerateGeometryError, EstimationError, InputError
from pyheracles.registration.pane_matching import LOOSE, MatchParams, OpeningMatch, match_openings
from pyheracles.registration.panes import Opening, PaneParams, detect_openings
from pyheracles.registration.points import PointList
from pyheracles.registration.similarity import (
    SimilarityParams,
    SimilarityResult,
    estimate_similarity,
)

__all__ = [
    "TiePointParams",
    "TiePointResult",
    "detect_pane_corners",
    "find_tie_points",
    "fpfh",
    "spin_images",
]


@dataclass(frozen=True)
class TiePointParams:
    """Parameters of :func:`find_tie_points` (metres unless stated).

    Attributes
    ----------
    pane_thickness_m
        Glass thickness (2 cm default, issue 5): outlines are taken on the mid-plane.
    panes
        Opening detection (:class:`~pyheracles.registration.panes.PaneParams`); its
        ``pane_thickness_m`` and ``up`` are replaced by the fields here.
    matching
        Opening matching (:class:`~pyheracles.registration.pane_matching.MatchParams`);
        its ``opposite_sides`` is replaced by the field here.
    max_tie_rms_m
        Largest 3D RMS of the tie points about the final similarity: beyond it the
        openings disagree and no transform is returned.
    up
        Vertical direction in both clouds.
    opposite_sides
        ``True`` when the clouds see the panes from opposite sides (exterior vs
        interior).
    seed
        Kept for reproducible extensions; the pipeline itself draws no random numbers.
    """

    pane_thickness_m: float = 0.02
    panes: PaneParams = field(default_factory=PaneParams)
    matching: MatchParams = field(default_factory=MatchParams)
    max_tie_rms_m: float = 0.02
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    opposite_sides: bool = True
    seed: int = 0

    def pane_params(self) -> PaneParams:
        from dataclasses import replace

        return replace(self.panes, pane_thickness_m=self.pane_thickness_m, up=self.up)

    def match_params(self) -> MatchParams:
        from dataclasses import replace

        return replace(self.matching, opposite_sides=self.opposite_sides, up=self.up)


@dataclass(frozen=True, eq=False)
class TiePointResult:
    """Automatic tie points: ``source``/``target`` point lists with the same ids."""

    source: PointList
    target: PointList
    similarity: SimilarityResult
    n_panes: tuple[int, int]
    n_keypoints: tuple[int, int]
    n_putative: int
    n_ransac_inliers: int
    details: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "n_panes_source": self.n_panes[0],
            "n_panes_target": self.n_panes[1],
            "n_keypoints_source": self.n_keypoints[0],
            "n_keypoints_target": self.n_keypoints[1],
            "n_putative_matches": self.n_putative,
            "n_consistent_openings": self.n_ransac_inliers,
            "n_tie_points": len(self.source),
            "similarity": self.similarity.to_dict(),
            **self.details,
        }


#: What to do when the openings both clouds see are too few to fix the pose.
_LOOSE_HINT = (
    "measure targets or control points seen in both clouds (spheres, marks on walls "
    "seen through a door or window) and give them as tie points (heracles register "
    "SOURCE TARGET --tiepoints ties.csv), or georeference each cloud on its own control "
    "points (heracles georef)"
)


# ----------------------------------------------------------------------------- openings
def _openings(cloud: PointCloud, p: TiePointParams, what: str) -> list[Opening]:
    cloud.validate(what=what)
    with progress.stage(f"glazed openings of {cloud.source or what}"):
        ops = detect_openings(cloud.xyz, p.pane_params())
    if not ops:
        raise InputError(
            "no glazed window openings found",
            path=cloud.source,
            hint="the automatic tie points need glazed openings seen from both sides; "
            "use --tiepoints with manual tie points instead",
        )
    return ops


def _outline_points(o: Opening) -> NDArray[np.float64]:
    """Left, right, bottom and top points of an opening's mid-plane outline."""
    rel = o.outline - o.centre
    u, v = rel @ o.h, rel @ o.v
    out = []
    for coord, other in ((u, v), (v, u)):  # the extremes along h, then along v
        lo, hi = np.percentile(coord, [1, 99])
        for val in (lo, hi):
            band = np.abs(coord - val) < 0.02
            mid = float(np.median(other[band])) if band.any() else 0.0
            out.append((val, mid) if coord is u else (mid, val))
    return np.array([o.centre + a * o.h + b * o.v for a, b in out])


def detect_pane_corners(
    cloud: PointCloud, params: TiePointParams | None = None
) -> tuple[NDArray[np.float64], pd.DataFrame, cKDTree, float]:
    """Corners of the outline bounding box of every glazed opening (local frame, mid-plane).

    For rectangular lights these are the pane corners; for arched lights the two
    upper ones lie outside the glass (on the box).

    Returns
    -------
    corners
        ``(K, 3)`` corner coordinates in the cloud's local frame.
    table
        One row per corner: opening index, corner label (0 bottom-left, 1 bottom-right,
        2 top-right, 3 top-left, seen from the viewer), width, height and the
        viewer-side normal.
    tree, spacing
        The cloud's KD-tree and median point spacing.
    """
    from pyheracles.geometry.neighbours import point_spacing

    p = params or TiePointParams()
    cloud.validate(what="cloud for tie points")
    ops = detect_openings(cloud.xyz, p.pane_params())
    rows, corners = [], []
    for k, o in enumerate(ops):  # tens of openings
        rel = o.outline - o.centre
        lo_u, hi_u = np.percentile(rel @ o.h, [1, 99])
        lo_v, hi_v = np.percentile(rel @ o.v, [1, 99])
        # seen from the viewer (looking along -normal, up = v), right is normal x v
        right = 1.0 if np.cross(o.normal, o.v) @ o.h > 0 else -1.0
        uu = (lo_u, hi_u) if right > 0 else (hi_u, lo_u)
        for label, (a, b) in enumerate(
            [(uu[0], lo_v), (uu[1], lo_v), (uu[1], hi_v), (uu[0], hi_v)]
        ):
            corners.append(o.centre + a * o.h + b * o.v)
            rows.append(
                {"pane": k, "label": label, "width": o.width, "height": o.height,
                 "nx": o.normal[0], "ny": o.normal[1], "nz": o.normal[2]}
            )  # fmt: skip
    table = pd.DataFrame(rows, columns=["pane", "label", "width", "height", "nx", "ny", "nz"])
    tree = cKDTree(cloud.xyz)
    return np.array(corners).reshape(-1, 3), table, tree, point_spacing(cloud.xyz, tree)


# ----------------------------------------------------------------------------- descriptors
def fpfh(
    xyz: NDArray[np.float64],
    normals: NDArray[np.float64],
    tree: cKDTree,
    keypoints: NDArray[np.float64],
    radius: float,
    bins: int = 11,
) -> NDArray[np.float64]:
    """Fast Point Feature Histograms (Rusu, Blodow & Beetz 2009) at ``keypoints``.

    SPFH of every point within ``radius`` of a keypoint (pair angles alpha, phi,
    theta of the Darboux frame, ``bins`` bins each), then the keypoint's FPFH as its
    SPFH plus the distance-weighted mean of its neighbours' SPFH.  Hand-written
    (vectorised over all point pairs) because Open3D is only an optional extra.
    The keypoint itself takes the normal of its nearest cloud point.
    """
    nb_lists = tree.query_ball_point(keypoints, radius, workers=-1)
    support = np.unique(np.concatenate([np.asarray(x, dtype=int) for x in nb_lists]))
    if len(support) == 0:
        return np.zeros((len(keypoints), 3 * bins))
    lists = tree.query_ball_point(xyz[support], radius, workers=-1)
    lens = np.array([len(x) for x in lists])
    src = np.repeat(np.arange(len(support)), lens)
    dst = np.concatenate([np.asarray(x, dtype=int) for x in lists])
    ps, pt = xyz[support[src]], xyz[dst]
    ns, nt = normals[support[src]], normals[dst]
    d = pt - ps
    dist = np.linalg.norm(d, axis=1)
    ok = dist > 1e-9
    src, d, dist, ns, nt = src[ok], d[ok], dist[ok], ns[ok], nt[ok]
    d /= dist[:, None]
    u = ns
    v = np.cross(u, d)
    vn = np.linalg.norm(v, axis=1)
    good = vn > 1e-9
    v[good] /= vn[good, None]
    w = np.cross(u, v)
    alpha = np.einsum("ij,ij->i", v, nt)
    phi = np.einsum("ij,ij->i", u, d)
    theta = np.arctan2(np.einsum("ij,ij->i", w, nt), np.einsum("ij,ij->i", u, nt))
    b1 = np.clip(((alpha + 1) / 2 * bins).astype(int), 0, bins - 1)
    b2 = np.clip(((phi + 1) / 2 * bins).astype(int), 0, bins - 1)
    b3 = np.clip(((theta + np.pi) / (2 * np.pi) * bins).astype(int), 0, bins - 1)
    spfh = np.zeros((len(support), 3 * bins))
    for j, b in enumerate((b1, b2, b3)):
        spfh[:, j * bins : (j + 1) * bins] = np.bincount(
            src * bins + b, minlength=len(support) * bins
        ).reshape(len(support), bins)
    spfh /= np.maximum(spfh.sum(axis=1, keepdims=True) / 3, 1)
    pos = {int(s): i for i, s in enumerate(support)}
    _, nearest = tree.query(keypoints, k=1)
    out = np.zeros((len(keypoints), 3 * bins))
    for k, nb in enumerate(nb_lists):  # one weighted sum per keypoint (about 100 keypoints)
        nb = np.asarray(nb, dtype=int)
        if len(nb) == 0:
            continue
        rows = np.array([pos[int(i)] for i in nb])
        dk = np.linalg.norm(xyz[nb] - keypoints[k], axis=1)
        wk = 1.0 / np.maximum(dk, 0.1 * radius)
        own = spfh[pos[int(nearest[k])]] if int(nearest[k]) in pos else 0.0
        out[k] = own + (wk[:, None] * spfh[rows]).sum(axis=0) / len(nb)
    out /= np.maximum(out.sum(axis=1, keepdims=True), 1e-12)
    return out


def spin_images(
    xyz: NDArray[np.float64],
    tree: cKDTree,
    keypoints: NDArray[np.float64],
    normals: NDArray[np.float64],
    radius: float,
    n_alpha: int = 8,
    n_beta: int = 8,
    beta_range: tuple[float, float] = (-0.2, 0.6),
) -> NDArray[np.float64]:
    """Spin images (Johnson & Hebert 1999): histogram of (radial, height) around the normal.

    ``normals`` are oriented towards the viewer, so the reveals of a window have
    positive height from both sides of the wall.
    """
    lists = tree.query_ball_point(keypoints, radius, workers=-1)
    lens = np.array([len(x) for x in lists])
    k_idx = np.repeat(np.arange(len(keypoints)), lens)
    p_idx = (
        np.concatenate([np.asarray(x, dtype=int) for x in lists])
        if lens.sum()
        else np.zeros(0, int)
    )
    d = xyz[p_idx] - keypoints[k_idx]
    beta = np.einsum("ij,ij->i", d, normals[k_idx])
    alpha = np.linalg.norm(d - beta[:, None] * normals[k_idx], axis=1)
    ia = np.clip((alpha / radius * n_alpha).astype(int), 0, n_alpha - 1)
    ib = ((beta - beta_range[0]) / (beta_range[1] - beta_range[0]) * n_beta).astype(int)
    ok = (ib >= 0) & (ib < n_beta)
    flat = (k_idx[ok] * n_alpha + ia[ok]) * n_beta + ib[ok]
    h = np.bincount(flat, minlength=len(keypoints) * n_alpha * n_beta).astype(float)
    h = h.reshape(len(keypoints), n_alpha * n_beta)
    return h / np.maximum(h.sum(axis=1, keepdims=True), 1e-12)


def find_tie_points(
    source: PointCloud,
    target: PointCloud,
    params: TiePointParams | None = None,
    *,
    similarity: SimilarityParams | None = None,
) -> TiePointResult:
    """Automatic tie points between two clouds that see the same glazed openings.

    Returns four mid-plane outline points per matched opening as two point lists
    (source and target world frames, same ids ``AUTO001``...) and the robust
    similarity ``T_target_source`` estimated from them (modified Danish method by
    default), with its standard deviations and residuals as for manual tie points.

    Raises
    ------
    InputError
        No glazed opening in one cloud, or no trustworthy match: fewer than three
        openings in a consistent arrangement, outlines that do not agree, or an
        ambiguous arrangement (two different solutions explain nearly as many
        openings: repeated bays, a mirrored building).  The message says which.
    EstimationError
        The tie points are degenerate for the similarity.
    """
    p = params or TiePointParams()
    sp = similarity or SimilarityParams(estimator="danish")
    ops_s = _openings(source, p, "source cloud for tie points")
    ops_t = _openings(target, p, "target cloud for tie points")
    with progress.stage("matching the openings"):
        m = match_openings(ops_s, ops_t, p.match_params())
    if not isinstance(m, OpeningMatch):
        raise InputError(
            f"no trustworthy match of the window openings: {m} "
            f"({len(ops_s)} and {len(ops_t)} openings found)",
            path=source.source,
            hint=_LOOSE_HINT
            if m.startswith(LOOSE)
            else "check that both clouds see the same glazed openings, or give manual "
            "tie points (--tiepoints)",
        )
    a_list, b_list = [], []
    for (i, _j), L in zip(m.pairs, m.local, strict=True):  # tens of openings
        pts = _outline_points(ops_s[i])
        a_list.append(pts)
        b_list.append(pts @ L[:3, :3].T + L[:3, 3])
    a = np.vstack(a_list) + source.offset
    b = np.vstack(b_list) + target.offset
    ids = tuple(f"AUTO{i + 1:03d}" for i in range(len(a)))
    try:
        sim = estimate_similarity(a, b, sp, ids=ids)
    except DegenerateGeometryError as exc:
        raise EstimationError(f"tie points are degenerate: {exc}") from exc
    keep = np.flatnonzero(~sim.outliers)
    if len(keep) < 3:
        raise InputError(
            f"only {len(keep)} tie points survive the robust estimate",
            path=source.source,
            hint="give manual tie points (--tiepoints)",
        )
    kid = tuple(ids[i] for i in keep)
    final = estimate_similarity(
        a[keep], b[keep], SimilarityParams(with_scale=sp.with_scale), ids=kid
    )
    rms = final.rms()["3d"]
    if rms > p.max_tie_rms_m:
        raise InputError(
            f"the automatic tie points disagree: RMS {rms * 100:.1f} cm about the "
            f"similarity (at most {p.max_tie_rms_m * 100:.1f} cm accepted)",
            path=source.source,
            hint="give manual tie points (--tiepoints)",
        )
    return TiePointResult(
        source=PointList(kid, a[keep], source=source.source),
        target=PointList(kid, b[keep], source=target.source),
        similarity=final,
        n_panes=(len(ops_s), len(ops_t)),
        n_keypoints=(len(a), len(b)),
        n_putative=m.n_candidates,
        n_ransac_inliers=m.n_consistent,
        details={
            "robust_flagged": int(sim.outliers.sum()),
            "n_matched_openings": len(m.pairs),
            "runner_up_openings": m.runner_up,
            "contradicting_openings": m.n_contradicted,
            "mirrored_arrangements_refused": m.n_mirrored,
            "outline_rms_median_m": float(np.median(m.outline_rms)),
            "method": m.method,
            "n_recess_verified": m.n_recess_verified,
            "recess_rms_m": m.recess_rms_m,
            "recess_basin_m": m.recess_basin_m,
        },
    )
