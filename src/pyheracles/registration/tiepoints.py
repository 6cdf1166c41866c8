"""Automatic tie points between an exterior and an interior cloud through window panes.

The two clouds of a heritage building overlap only through its openings (thesis
ch. 3, Murtiyoso 2020: 35 tie points from 24 openings, RMS 4.4 cm against 2.5 cm
with manual tie points).  Pipeline, per cloud:

1. **Panes** - sequential MSAC planes (:func:`~pyheracles.geometry.fitting.fit_plane_msac`),
   each split into connected components (KD-tree pairs + sparse connected components);
   a component is a pane when it is a filled rectangle of window size.
2. **Keypoints** - the pane corners, refined as the intersection of the pane and the
   two adjacent reveal planes (:func:`~pyheracles.registration.targets.measure_plane_corner`)
   and moved by half the glass thickness onto the pane mid-plane, so that the same
   physical point is found from both sides.
3. **Descriptors** - FPFH (Rusu et al. 2009, 33 bins) and a spin image (Johnson &
   Hebert 1999) around each corner, with normals oriented to the viewer side, plus
   the pane geometry (width, height, which corner: bottom/top and left/right, the
   latter mirrored between the outside and the inside view).
4. **Matching** - reciprocal nearest neighbours in descriptor space among corners of
   compatible panes (same corner label, width and height within a tolerance).
5. **Robust rejection** - RANSAC on 3-correspondence samples (seeded), then the
   modified Danish similarity on the consensus; flagged pairs are dropped.

Assumptions (documented limits): both clouds are metric (scale within a few per cent)
and levelled (``up`` is the vertical in both), as TLS clouds and georeferenced
photogrammetric clouds are; the glass thickness is known.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from pyheracles.cloud import PointCloud
from pyheracles.errors import DegenerateGeometryError, EstimationError, InputError
from pyheracles.geometry.fitting import MSACParams, fit_plane_msac, min_area_rectangle
from pyheracles.geometry.neighbours import estimate_normals, point_spacing
from pyheracles.registration.points import PointList
from pyheracles.registration.similarity import (
    SimilarityParams,
    SimilarityResult,
    estimate_similarity,
)
from pyheracles.registration.targets import measure_plane_corner

__all__ = [
    "Keypoints",
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
    plane_threshold_m
        MSAC inlier distance for plane extraction.
    max_planes
        Planes extracted per cloud (walls, roof, ground first, then panes).
    min_pane_side_m, max_pane_side_m
        Accepted pane size (shorter and longer side of the rectangle).
    min_fill
        Fraction of the pane rectangle (5 cm cells) that must hold points.
    pane_thickness_m
        Glass thickness (2 cm, issue 5); corners move by half of it onto the mid-plane.
    corner_search_m
        Neighbourhood for the three-plane corner refinement.
    fpfh_radius_m, spin_radius_m
        Descriptor support radii.
    size_tolerance_m
        Largest width/height difference of two panes that may match.
    inlier_m
        RANSAC inlier distance between matched corners after the transform.
    ransac_trials
        Number of 3-correspondence RANSAC samples.
    up
        Vertical direction in both clouds.
    opposite_sides
        ``True`` when the clouds see the panes from opposite sides (exterior vs
        interior): left and right corners swap between the views.
    seed
        Seed of MSAC and RANSAC.
    """

    plane_threshold_m: float = 0.012
    max_planes: int = 24
    min_pane_side_m: float = 0.5
    max_pane_side_m: float = 5.0
    min_fill: float = 0.8
    pane_thickness_m: float = 0.02
    corner_search_m: float = 0.25
    fpfh_radius_m: float = 0.15
    spin_radius_m: float = 0.8
    size_tolerance_m: float = 0.08
    inlier_m: float = 0.08
    ransac_trials: int = 2000
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    opposite_sides: bool = True
    seed: int = 0


@dataclass(frozen=True, eq=False)
class Keypoints:
    """Pane corners of one cloud (cloud world frame) with their descriptors."""

    xyz: NDArray[np.float64]  # (K, 3) on the pane mid-plane
    pane: NDArray[np.int_]  # (K,) pane index
    label: NDArray[np.int_]  # (K,) 0 bottom-left, 1 bottom-right, 2 top-right, 3 top-left
    size: NDArray[np.float64]  # (K, 2) pane width (horizontal) and height
    normal: NDArray[np.float64]  # (K, 3) pane normal towards the viewer
    fpfh: NDArray[np.float64]  # (K, 33)
    spin: NDArray[np.float64]  # (K, n_bins)
    panes: pd.DataFrame


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
            "n_ransac_inliers": self.n_ransac_inliers,
            "n_tie_points": len(self.source),
            "similarity": self.similarity.to_dict(),
            **self.details,
        }


# ----------------------------------------------------------------------------- panes
def _components(xyz: NDArray[np.float64], radius: float) -> NDArray[np.int_]:
    tree = cKDTree(xyz)
    pairs = tree.query_pairs(radius, output_type="ndarray")
    n = len(xyz)
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    return lab


def _plane_basis(normal: NDArray[np.float64], up: NDArray[np.float64]):
    h = np.cross(up, normal)
    if np.linalg.norm(h) < 1e-6:  # horizontal pane (skylight): any basis
        h = np.cross([1.0, 0, 0], normal)
    h /= np.linalg.norm(h)
    v = np.cross(normal, h)
    return h, v


def _find_panes(
    xyz: NDArray[np.float64], tree: cKDTree, spacing: float, p: TiePointParams
) -> list[dict[str, Any]]:
    rng = np.random.default_rng(p.seed)
    remaining = np.ones(len(xyz), bool)
    up = np.asarray(p.up, float)
    panes = []
    min_pts = max(int(0.6 * p.min_pane_side_m**2 / spacing**2), 30)
    for _ in range(p.max_planes):
        idx = np.flatnonzero(remaining)
        if len(idx) < min_pts:
            break
        fit = fit_plane_msac(
            xyz[idx],
            MSACParams(threshold=p.plane_threshold_m, max_trials=400, min_inlier_fraction=0.0),
            rng=rng,
        )
        if not fit or fit.inliers.sum() < min_pts:
            break
        inl = idx[fit.inliers]
        remaining[inl] = False
        lab = _components(xyz[inl], 3.0 * spacing)
        counts = np.bincount(lab)
        for c in np.flatnonzero(counts >= min_pts):  # components of one plane (tens)
            pts = xyz[inl[lab == c]]
            h, v = _plane_basis(fit.normal, up)
            uv = np.column_stack([pts @ h, pts @ v])
            lo, hi = uv.min(axis=0), uv.max(axis=0)
            size = hi - lo
            if size.min() < p.min_pane_side_m or size.max() > p.max_pane_side_m:
                continue
            cells = np.floor((uv - lo) / 0.05).astype(int)
            shape = np.maximum(np.ceil(size / 0.05).astype(int), 1)
            occ = len(np.unique(cells[:, 0] * (shape[1] + 1) + cells[:, 1]))
            if occ / (shape[0] * shape[1]) < p.min_fill:
                continue
            _centre, angle, _ = min_area_rectangle(uv)
            if abs(np.sin(2 * angle)) > 0.2:  # not aligned with the vertical: not a window
                continue
            # viewer side: reveals stand out of the pane on the side of the scanner
            centre3 = fit.normal * fit.d + h * (lo[0] + hi[0]) / 2 + v * (lo[1] + hi[1]) / 2
            ring = np.asarray(
                tree.query_ball_point(centre3, 0.5 * np.hypot(*size) + 0.1), dtype=int
            )
            off = (xyz[ring] - centre3) @ fit.normal
            off = off[np.abs(off) > 3 * p.plane_threshold_m]
            if len(off) < 10:
                continue
            side = 1.0 if np.median(off) > 0 else -1.0
            panes.append(
                {
                    "normal_view": side * fit.normal,
                    "normal": fit.normal,
                    "plane_d": fit.d,
                    "h": h,
                    "v": v,
                    "lo": lo,
                    "hi": hi,
                    "n_points": len(pts),
                }
            )
    return panes


def detect_pane_corners(
    cloud: PointCloud, params: TiePointParams | None = None
) -> tuple[NDArray[np.float64], pd.DataFrame, cKDTree, float]:
    """Window pane corners of a cloud (local frame), on the pane mid-plane.

    Returns
    -------
    corners
        ``(K, 3)`` corner coordinates in the cloud's local frame.
    table
        One row per corner: pane index, corner label (0 bottom-left, 1 bottom-right,
        2 top-right, 3 top-left, seen from the viewer), pane width and height, and the
        viewer-side normal.
    tree, spacing
        The cloud's KD-tree and point spacing (reused for descriptors).
    """
    p = params or TiePointParams()
    cloud.validate(what="cloud for tie points")
    xyz = cloud.xyz
    tree = cKDTree(xyz, balanced_tree=False, compact_nodes=False)
    spacing = point_spacing(xyz, tree)
    panes = _find_panes(xyz, tree, spacing, p)
    rows = []
    corners = []
    rng = np.random.default_rng(p.seed)
    for k, pane in enumerate(panes):  # tens of panes
        h, v, n = pane["h"], pane["v"], pane["normal_view"]
        lo, hi = pane["lo"], pane["hi"]
        # seen from the viewer (looking along -n, up = v), +h points right when n = +normal
        ordered = [(lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1])]
        if n @ pane["normal"] < 0:
            ordered = [ordered[1], ordered[0], ordered[3], ordered[2]]
        for label, (a, b) in enumerate(ordered):
            rough = a * h + b * v + pane["normal"] * pane["plane_d"]
            try:
                c = measure_plane_corner(
                    xyz,
                    rough,
                    tree=tree,
                    search_m=p.corner_search_m,
                    threshold_m=max(p.plane_threshold_m / 2, 2.5 * spacing / 4),
                    rng=rng,
                )
            except DegenerateGeometryError:
                continue
            if np.linalg.norm(c.point - rough) > 0.1:
                continue
            corners.append(c.point - n * p.pane_thickness_m / 2)
            rows.append(
                {
                    "pane": k,
                    "label": label,
                    "width": hi[0] - lo[0],
                    "height": hi[1] - lo[1],
                    "nx": n[0],
                    "ny": n[1],
                    "nz": n[2],
                }
            )
    table = pd.DataFrame(rows, columns=["pane", "label", "width", "height", "nx", "ny", "nz"])
    return np.array(corners).reshape(-1, 3), table, tree, spacing


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


def _keypoints(cloud: PointCloud, p: TiePointParams) -> Keypoints:
    corners, table, tree, _spacing = detect_pane_corners(cloud, p)
    if len(corners) == 0:
        raise InputError(
            "no window pane corners found",
            path=cloud.source,
            hint="the automatic tie points need glazed openings seen from both sides; "
            "use --tiepoints with manual tie points instead",
        )
    normals_view = table[["nx", "ny", "nz"]].to_numpy(float)
    # normals of the support points, oriented towards the viewer side of the nearest corner
    support = np.unique(
        np.concatenate(
            [
                np.asarray(x, dtype=int)
                for x in tree.query_ball_point(corners, 2 * p.fpfh_radius_m, workers=-1)
            ]
        )
    )
    sub = cloud.xyz[support]
    n_sub, _ = estimate_normals(sub, k=12)
    # orient every normal towards a viewpoint 0.5 m in front of its nearest corner: the
    # pane and both reveals then face the inside of the opening from either side
    _, near_corner = cKDTree(corners).query(sub)
    viewpoint = corners[near_corner] + 0.5 * normals_view[near_corner]
    toward = np.einsum("ij,ij->i", n_sub, viewpoint - sub) < 0
    n_sub[toward] *= -1
    sub_tree = cKDTree(sub)
    f = fpfh(sub, n_sub, sub_tree, corners, p.fpfh_radius_m)
    s = spin_images(cloud.xyz, tree, corners, normals_view, p.spin_radius_m)
    return Keypoints(
        xyz=corners + cloud.offset,
        pane=table["pane"].to_numpy(int),
        label=table["label"].to_numpy(int),
        size=table[["width", "height"]].to_numpy(float),
        normal=normals_view,
        fpfh=f,
        spin=s,
        panes=table,
    )


# ----------------------------------------------------------------------------- matching
def _match(ks: Keypoints, kt: Keypoints, p: TiePointParams) -> NDArray[np.int_]:
    """Reciprocal nearest neighbours in descriptor space among compatible corners."""
    desc_s = np.hstack([ks.fpfh, ks.spin])
    desc_t = np.hstack([kt.fpfh, kt.spin])
    # chi-square-like distance via Hellinger embedding (sqrt of histograms), then L2
    D = np.linalg.norm(np.sqrt(desc_s)[:, None, :] - np.sqrt(desc_t)[None, :, :], axis=2)
    # left/right are mirrored between an outside and an inside view of the same pane
    mirrored = np.array([1, 0, 3, 2]) if p.opposite_sides else np.arange(4)
    compatible = (mirrored[ks.label][:, None] == kt.label[None, :]) & np.all(
        np.abs(ks.size[:, None, :] - kt.size[None, :, :]) <= p.size_tolerance_m, axis=2
    )
    D = np.where(compatible, D, np.inf)
    best_t = np.argmin(D, axis=1)
    best_s = np.argmin(D, axis=0)
    i = np.arange(len(ks.xyz))
    ok = np.isfinite(D[i, best_t]) & (best_s[best_t] == i)
    return np.column_stack([i[ok], best_t[ok]])


def _ransac(a: NDArray[np.float64], b: NDArray[np.float64], p: TiePointParams) -> NDArray[np.bool_]:
    """Consensus of 3-point similarity hypotheses (vectorised scoring per batch)."""
    n = len(a)
    rng = np.random.default_rng(p.seed)
    best = np.zeros(n, bool)
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    a0, b0 = a - ca, b - cb
    needed = p.ransac_trials
    trial = 0
    while trial < min(needed, p.ransac_trials):  # adaptive stop (Fischler & Bolles 1981)
        trial += 1
        s = rng.choice(n, size=3, replace=False)
        pa, pb = a0[s], b0[s]
        if np.linalg.norm(np.cross(pa[1] - pa[0], pa[2] - pa[0])) < 0.05:
            continue
        ma, mb = pa.mean(0), pb.mean(0)
        rot, _ = Rotation.align_vectors(pb - mb, pa - ma)
        R = rot.as_matrix()
        ra = (pa - ma) @ R.T
        sc = float(np.sum(ra * (pb - mb)) / max(np.sum(ra * ra), 1e-12))
        if not 0.8 < sc < 1.25:
            continue
        pred = sc * (a0 - ma) @ R.T + mb
        inl = np.linalg.norm(pred - b0, axis=1) < p.inlier_m
        if inl.sum() > best.sum():
            best = inl
            w3 = (best.sum() / n) ** 3
            if w3 >= 1.0:
                break
            needed = int(np.ceil(np.log(1e-4) / np.log(1.0 - max(w3, 1e-9)))) + 10
    return best


def find_tie_points(
    source: PointCloud,
    target: PointCloud,
    params: TiePointParams | None = None,
    *,
    similarity: SimilarityParams | None = None,
) -> TiePointResult:
    """Automatic tie points between two clouds that see the same window panes.

    Returns the matched corners as two point lists (source and target world frames,
    same ids ``AUTO001``...) and the robust similarity ``T_target_source`` estimated
    from them (modified Danish method by default).

    Raises
    ------
    InputError
        No panes in one cloud, or fewer than 3 consistent matches (clouds that do not
        share openings).
    """
    p = params or TiePointParams()
    sp = similarity or SimilarityParams(estimator="danish")
    ks = _keypoints(source, p)
    kt = _keypoints(target, p)
    pairs = _match(ks, kt, p)
    if len(pairs) < 3:
        raise InputError(
            f"only {len(pairs)} tentative tie point matches between the clouds",
            path=source.source,
            hint="check that both clouds see the same window panes, or give manual tie points",
        )
    a = ks.xyz[pairs[:, 0]]
    b = kt.xyz[pairs[:, 1]]
    inl = _ransac(a, b, p)
    if inl.sum() < 3:
        raise InputError(
            f"no consistent set of tie points ({int(inl.sum())} of {len(pairs)} matches agree)",
            path=source.source,
            hint="the clouds may not overlap through the same openings",
        )
    try:
        sim = estimate_similarity(a[inl], b[inl], sp)
    except DegenerateGeometryError as exc:
        raise EstimationError(f"tie points are degenerate: {exc}") from exc
    keep = np.flatnonzero(inl)[~sim.outliers]
    ids = tuple(f"AUTO{i + 1:03d}" for i in range(len(keep)))
    final = estimate_similarity(
        a[keep], b[keep], SimilarityParams(with_scale=sp.with_scale), ids=ids
    )
    return TiePointResult(
        source=PointList(ids, a[keep], source=source.source),
        target=PointList(ids, b[keep], source=target.source),
        similarity=final,
        n_panes=(int(ks.panes["pane"].nunique()), int(kt.panes["pane"].nunique())),
        n_keypoints=(len(ks.xyz), len(kt.xyz)),
        n_putative=len(pairs),
        n_ransac_inliers=int(inl.sum()),
        details={"robust_flagged": int(sim.outliers.sum())},
    )
