"""Parameters, result types and the lengths derived from the point spacing."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from threadpoolctl import threadpool_limits

from pyheracles.resources import check_grid_memory

Array = NDArray[np.float64]


SUPPORT_CLASSES = ("column", "pier", "engaged_column")


#: The automatic section may be at most this share of the body height thick: thicker, a
#: slab at mid-height reaches floor and ceiling (the cloud is too sparse for sections).
MAX_SECTION_SHARE = 0.5


@dataclass(frozen=True)
class SupportParams:
    """Parameters of the support detection.  ``None`` means automatic.

    Attributes
    ----------
    section_height_m
        Height of the cross-section above the floor of the body (its lowest dense level,
        :func:`~pyheracles.supports.height.dense_extent`), metres;
        ``None`` chooses it automatically (the thesis took the middle).
    section_thickness_m
        Slab thickness, metres; auto ``max(0.05, 3 x point spacing)`` (thesis: 5 cm).
    cluster_distance_m
        Largest gap inside an island, metres; auto ``clip(2.5 x spacing, 0.03, 0.15)``.
    candidate_step_m
        Step between candidate section heights, metres.
    persistence_m
        An island counts only if found again this far above and below, metres.
    min_support_size_m
        Islands whose longest side is shorter are noise (fence bars, chair legs), metres.
    max_support_size_m
        Islands whose longest side is longer are walls, metres.
    wall_min_aspect
        Islands longer than 1 m with length / width above this are walls.
    circularity_max
        Largest hull circularity ``P^2 / (4 pi A)`` of a column (thesis: 1.12).
    buffer_fraction, pier_buffer_fraction, buffer_min_m
        Cookie-cutter buffer: ``max(buffer_min_m, buffer_fraction x radius)`` for columns
        (2.6: square plinths and abaci of up to 2.5 r half width, reached at their
        corners 3.5 r from the axis), ``max(buffer_min_m, pier_buffer_fraction x half
        length)`` for piers (their plinths and imposts project little), metres.  How far
        a support really reaches at each height comes from its own profile
        (:func:`pyheracles.supports.profile.band_reach`).
    floor_tolerance_m, ceiling_tolerance_m
        Points closer than this to the floor below / to the underside of what a support
        carries are not part of it, metres; auto: three robust standard deviations of
        that surface's heights, 1-5 cm.
    surface_tolerance_m
        Largest distance behind the innermost surface of a sector kept in the
        support, metres; auto ``max(0.03, 2 x spacing)``.
    min_height_fraction
        A support must span at least this fraction of the height from its floor to the
        underside of what it carries.
    min_free_height_m
        A support that carries nothing (a broken column, a column under the open sky)
        must be at least this tall (or ``min_height_fraction`` of the body), metres.
    engaged
        Look for engaged (half-) columns on walls.
    engaged_radius_m
        Plausible radius range of engaged columns, metres.
    min_points
        Smallest island / support, points.
    seed
        Seed of the random sampling (MSAC).
    """

    section_height_m: float | None = None
    section_thickness_m: float | None = None
    cluster_distance_m: float | None = None
    candidate_step_m: float = 0.15
    persistence_m: float = 0.45
    min_support_size_m: float = 0.1
    max_support_size_m: float = 2.5
    wall_min_aspect: float = 3.0
    circularity_max: float = 1.12
    buffer_fraction: float = 2.6
    pier_buffer_fraction: float = 0.5
    buffer_min_m: float = 0.2
    floor_tolerance_m: float | None = None
    ceiling_tolerance_m: float | None = None
    surface_tolerance_m: float | None = None
    min_height_fraction: float = 0.5
    min_free_height_m: float = 1.5
    engaged: bool = True
    engaged_radius_m: tuple[float, float] = (0.08, 1.0)
    min_points: int = 10
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("candidate_step_m", "persistence_m", "min_support_size_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.max_support_size_m <= self.min_support_size_m:
            raise ValueError("max_support_size_m must exceed min_support_size_m")
        if not 0 < self.min_height_fraction <= 1:
            raise ValueError("min_height_fraction must be in (0, 1]")


@dataclass(frozen=True)
class Island:
    """One island of a cross-section.

    ``kind`` is ``noise``, ``wall``, ``column`` or ``pier``; the shape is a circle
    (``center``, ``radius``) for columns and a rectangle (``center``, ``angle``,
    ``size``) otherwise.
    """

    kind: str
    index: NDArray[np.intp]
    center: Array
    radius: float
    angle: float
    size: Array
    circularity: float
    circle_rms: float
    rect_rms: float


@dataclass(frozen=True)
class SupportResult:
    """Supports found in a body cloud.

    Attributes
    ----------
    instance
        ``(N,)`` int32 support id per input point (1..K), 0 elsewhere.
    objects
        One row per support: ``instance``, ``class``, ``n_points``, ``x``, ``y``,
        ``z_min``, ``z_max``, ``height_m``, ``radius_m``, ``axis_x/y/z``,
        ``box_length_m``, ``box_width_m``, ``box_height_m``, ``fit_rms_m``,
        ``circularity``.
    section_height
        z of the cross-section used (same frame as the input).
    spacing_m
        Estimated point spacing.
    islands
        Islands of the section (diagnostics).
    notes
        Things the user should know (no supports found, fallbacks).
    height_scores
        ``(height, persistent support islands)`` of the automatic section height search.
    """

    instance: NDArray[np.int32]
    objects: pd.DataFrame
    section_height: float
    spacing_m: float
    islands: list[Island] = field(default_factory=list)
    notes: tuple[str, ...] = ()
    height_scores: list[tuple[float, int]] = field(default_factory=list)


@dataclass(frozen=True)
class Scales:
    """Automatic lengths derived from the point spacing (metres)."""

    spacing: float
    distance: float  # island clustering distance
    thickness: float  # section slab thickness
    tol: float  # surface tolerance


def scales(spacing: float, params: SupportParams) -> Scales:
    distance = params.cluster_distance_m or float(np.clip(4.0 * spacing, 0.03, 0.1))
    # A slab of thickness t through a vertical surface of density lam (points / m^2) has
    # lam * t points per metre of outline; gaps are exponential, so P(gap > d) =
    # exp(-lam t d).  t = 9 / (lam d) keeps that below 1e-4: islands do not break up.
    # lam from the median nearest-neighbour distance of a Poisson sample: ln 2 / (pi s^2).
    lam = np.log(2) / (np.pi * spacing**2)
    thickness = params.section_thickness_m or float(max(0.05, 9.0 / (lam * distance)))
    tol = params.surface_tolerance_m or max(0.03, 2.0 * spacing)
    return Scales(spacing, distance, thickness, tol)


# ------------------------------------------------------------------------------ helpers
def estimate_spacing(xyz: Array, z_sorted: Array, rng: np.random.Generator) -> float:
    """Median 3D nearest-neighbour distance on a thick mid-height slab (surface spacing)."""
    z = xyz[:, 2]
    lo, hi = np.quantile(z_sorted, [0.3, 0.7], method="linear")
    slab = np.flatnonzero((z >= lo) & (z <= hi))
    cand = slab
    if len(cand) > 100_000:
        cand = rng.choice(cand, 100_000, replace=False)
    pts = np.take(xyz, cand, axis=0)
    if len(pts) < 10:
        return 0.05
    tree = cKDTree(pts)
    q = pts if len(pts) <= 20000 else pts[rng.choice(len(pts), 20000, replace=False)]
    d, _ = tree.query(q, k=2)
    d = d[:, 1][d[:, 1] > 0]
    # the sub-sampling inflates the distance by sqrt(total / kept) on a surface
    inflate = np.sqrt(max(len(cand), 1) / max(len(slab), 1))
    return float(np.median(d) * inflate) if len(d) else 0.05


def trimmed_rms(residuals: Array, keep: float = 0.9) -> float:
    """RMS of the ``keep`` fraction of smallest residuals: a fence bar or a chair leg
    touching an island does not decide whether it is round or rectangular."""
    r = np.sort(np.abs(residuals))
    return float(np.sqrt(np.mean(r[: max(1, int(keep * len(r)))] ** 2)))


#: Bytes per neighbour pair of the section clustering (the pair list, the sparse graph).
BYTES_PER_PAIR = 48


def check_pair_memory(xy: Array, tree: cKDTree, distance_m: float) -> None:
    """Refuse a section clustering whose neighbour pairs would not fit in memory (a cloud
    in millimetres read as metres puts thousands of points within the distance)."""
    sample = xy[np.linspace(0, len(xy) - 1, min(len(xy), 200)).astype(np.intp)]
    k = float(np.mean(tree.query_ball_point(sample, distance_m, return_length=True)))
    check_grid_memory(
        len(xy) * k / 2, BYTES_PER_PAIR,
        f"clustering the section ({len(xy):,} points, about {k:.0f} neighbours each within "
        f"{distance_m:g} m)",
        "check the cloud's units (metres expected); in Python: a smaller "
        "SupportParams(cluster_distance_m=...)",
    )  # fmt: skip


def one_blas_thread() -> threadpool_limits:
    """Context: BLAS on one thread.  The matrices here are thin (N x 3 and 3000 x 5):
    OpenBLAS threads only busy-wait on them (without this limit the 3.5 M point hall of
    the benchmark used ~0.2 s more CPU than wall time, a second core spinning that a
    shared machine takes from other work)."""
    return threadpool_limits(limits=1, user_api="blas")


def empty_table() -> pd.DataFrame:
    cols = [
        "instance",
        "class",
        "n_points",
        "x",
        "y",
        "z_min",
        "z_max",
        "height_m",
        "radius_m",
        "axis_x",
        "axis_y",
        "axis_z",
        "box_length_m",
        "box_width_m",
        "box_height_m",
        "fit_rms_m",
        "circularity",
    ]
    return pd.DataFrame(
        {c: pd.Series(dtype="int32" if c == "instance" else "float64") for c in cols}
    )
