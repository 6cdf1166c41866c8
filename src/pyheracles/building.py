"""Step 2a: one building cloud -> attic / body and structural supports.

Thesis chapter 6.2 (Murtiyoso 2020), MATLAB ``atticsegment`` and
``supportdetect``.  The pipeline reads top-down::

    cloud   = prepare_building(xyz)            # units (mm -> m), level a tilted cloud
    split   = attic_split(cloud.xyz)           # slices, hull areas, attic limit
    found   = detect_supports(body points)     # pyheracles.supports
    result  = Segmentation(...)                # labels aligned with the input

:func:`segment_building` does all of it and returns a
:class:`pyheracles.labels.Segmentation` whose objects are the supports
(``column``, ``pier``, ``engaged_column``), the ``attic`` and the rest of the
``body`` -- every input point is in exactly one of them.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from pyheracles.cloud import PointCloud, all_finite
from pyheracles.errors import InputError
from pyheracles.forks import ForkedCall
from pyheracles.geometry.sections import SliceParams, SliceProfile, slice_profile, sort_order
from pyheracles.labels import Segmentation
from pyheracles.resources import check_spread
from pyheracles.supports import (
    SupportParams,
    SupportResult,
    detect_supports_checked,
    one_blas_thread,
)

__all__ = [
    "CLASSES",
    "AtticParams",
    "AtticSplit",
    "BuildingParams",
    "PreparedCloud",
    "attic_split",
    "level_cloud",
    "objects_in_world",
    "prepare_building",
    "segment_attic",
    "segment_building",
    "to_input_frame",
]

Array = NDArray[np.float64]

#: Class codes written in ``class_id`` of the outputs.
CLASSES: dict[int, str] = {1: "body", 2: "attic", 3: "column", 4: "pier", 5: "engaged_column"}
_CODE = {v: k for k, v in CLASSES.items()}

#: Fewest points of a building cloud (an attic split needs slices, a support an island).
MIN_BUILDING_POINTS = 10
#: Smallest plausible extent of one building, metres: a cloud read as millimetres that
#: comes out smaller was in metres already.
MIN_BUILDING_EXTENT_M = 1.0


# ------------------------------------------------------------------------------ parameters
@dataclass(frozen=True)
class AtticParams:
    """Attic / body split by slice hull areas.

    Attributes
    ----------
    interval_m, thickness_m, ground_tolerance_m
        Slicing (thesis: 0.2 m interval, 5 cm thickness).
    area_change
        Relative change of the hull area between consecutive slices that marks the
        attic limit (thesis: 10 %).
    min_body_height_m
        The body must be at least this tall: area changes closer to the ground
        (steps, plinths, a stylobate) restart the search, metres.
    min_attic_fraction
        An "attic" with fewer points than this fraction of the cloud is not one
        (the top of the walls, a parapet): the result is "no attic".
    """

    interval_m: float = 0.2
    thickness_m: float = 0.05
    ground_tolerance_m: float = 0.1
    area_change: float = 0.10
    min_body_height_m: float = 1.0
    min_attic_fraction: float = 0.01

    def slices(self) -> SliceParams:
        return SliceParams(self.interval_m, self.thickness_m, self.ground_tolerance_m)


@dataclass(frozen=True)
class BuildingParams:
    """Cloud preparation before step 2.

    Attributes
    ----------
    units
        ``"auto"`` (an extent above ``mm_extent_threshold`` means millimetres, which
        are rescaled to metres with a note), ``"m"`` or ``"mm"``.
    mm_extent_threshold
        Largest plausible extent of one building in metres.
    level
        Level a tilted cloud on its dominant horizontal surfaces (floor, ceiling).
    tilt_tolerance_deg
        Tilts below this are left alone, degrees.
    seed
        Seed of the sub-sampling used to find the vertical.
    """

    units: str = "auto"
    mm_extent_threshold: float = 1000.0
    level: bool = True
    tilt_tolerance_deg: float = 0.5
    seed: int = 0

    def __post_init__(self) -> None:
        if self.units not in {"auto", "m", "mm"}:
            raise InputError(f"units must be one of 'auto', 'm', 'mm', got {self.units!r}")


@dataclass(frozen=True)
class PreparedCloud:
    """Levelled coordinates in metres and how they were obtained.

    ``xyz = (scale * input - centre) @ rotation.T + centre`` where ``centre`` is the
    centroid of the scaled cloud.
    """

    xyz: Array
    scale_to_m: float
    rotation: Array
    centre: Array
    tilt_deg: float
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class AtticSplit:
    """Attic / body split.

    Attributes
    ----------
    attic
        ``(N,)`` True for attic points.
    limit_z
        Height of the limit (same frame as the input z), ``None`` without attic.
    profile
        Slice heights and hull areas that led to it.
    """

    attic: NDArray[np.bool_]
    limit_z: float | None
    profile: SliceProfile
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def has_attic(self) -> bool:
        return self.limit_z is not None


# ------------------------------------------------------------------------------ preparation
def level_cloud(
    xyz: Array, *, sample: int = 40_000, rng: np.random.Generator | int | None = 0
) -> tuple[Array, float]:
    """Vertical of a building cloud from its dominant horizontal surfaces.

    Normals are estimated on a random sample; those within 30 degrees of +z are
    averaged, then re-averaged within 5 degrees of the estimate (floors and
    ceilings dominate; walls and vaults drop out).

    Returns
    -------
    up : (3,) unit vector
        The measured vertical in the input frame.
    tilt_deg : float
        Angle between ``up`` and +z, degrees (0 when undetermined).
    """
    from pyheracles.geometry.neighbours import estimate_normals

    gen = np.random.default_rng(rng)
    pts = xyz if len(xyz) <= sample else xyz[gen.choice(len(xyz), sample, replace=False)]
    if len(pts) < 50:
        return np.array([0.0, 0.0, 1.0]), 0.0
    normals, _ = estimate_normals(pts, k=12)
    normals = normals * np.where(normals[:, 2] < 0, -1.0, 1.0)[:, None]
    up = np.array([0.0, 0.0, 1.0])
    for cone in (30.0, 10.0, 5.0, 5.0):
        sel = normals @ up >= np.cos(np.deg2rad(cone))
        if sel.sum() < 0.02 * len(normals):
            return np.array([0.0, 0.0, 1.0]), 0.0
        m = normals[sel].mean(axis=0)
        up = m / np.linalg.norm(m)
    return up, float(np.degrees(np.arccos(np.clip(up[2], -1, 1))))


def prepare_building(
    xyz: Array,
    params: BuildingParams | None = None,
    *,
    source: str | None = None,
    step: str = "building analyses",
    min_points: int = MIN_BUILDING_POINTS,
) -> PreparedCloud:
    """Check units and level the cloud (both reported in ``notes``).

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates.
    params
        Units and levelling.
    source
        File name for error messages.
    step, min_points
        What the cloud is for (plural, for messages: ``"supports"``) and the fewest
        points it needs.

    Raises
    ------
    InputError
        Empty input, NaN coordinates, fewer than ``min_points`` points, all points at
        one location, on one vertical line or at one height, a cloud too large for one
        building even in millimetres, or ``units='mm'`` on a cloud that is then smaller
        than a building (it is in metres already).
    """
    params = params or BuildingParams()
    p = np.asarray(xyz, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(f"coordinates must have shape (N, 3), got {p.shape}", path=source)
    if len(p) == 0:
        raise InputError(
            "the building cloud has no points",
            path=source,
            hint="check the file and any filter applied before this step",
        )
    if not all_finite(p):
        raise InputError(
            "the building cloud has NaN or infinite coordinates",
            path=source,
            hint="remove those points first",
        )
    # extents column by column (numpy reduces an (N, 3) array along axis 0 more slowly)
    extent = float(check_spread(p, step=step, min_points=min_points, path=source,
                                need_z=True).max())  # fmt: skip
    notes: list[str] = []
    if params.units == "mm" and extent * 1e-3 < MIN_BUILDING_EXTENT_M:
        raise InputError(
            f"the cloud is {extent:.3g} units across: read as millimetres it would be "
            f"{extent * 1e-3:.3g} m, too small for a building; it looks to be in metres "
            "already",
            path=source,
            hint="drop --units mm, or give --units m",
        )
    scale = 1.0
    if params.units == "mm" or (params.units == "auto" and extent > params.mm_extent_threshold):
        scale = 1e-3
        if params.units == "auto":
            notes.append(
                f"the cloud is {extent:.0f} units across, too large for one building in "
                "metres: read as millimetres and rescaled to metres (pass units='m' to refuse)"
            )
        if extent * scale > params.mm_extent_threshold:
            raise InputError(
                f"the cloud is {extent:.0f} units across: too large for one building even "
                "in millimetres",
                path=source,
                hint="clip the cloud to one building (step 1) before this step",
            )
    if scale != 1.0:  # no copy of the cloud (240 MB for 10 M points) when it is in metres
        p = p * scale
    centre = np.array([p[:, k].mean() for k in range(3)])
    rot = np.eye(3)
    tilt = 0.0
    if params.level:
        up, tilt = level_cloud(p, rng=params.seed)
        if tilt > params.tilt_tolerance_deg:
            r, _ = Rotation.align_vectors([[0.0, 0.0, 1.0]], [up])
            rot = r.as_matrix()
            p = (p - centre) @ rot.T + centre
            notes.append(f"the cloud was tilted by {tilt:.2f} degrees; levelled on its floor")
    return PreparedCloud(p, scale, rot, centre, tilt, tuple(notes))


# ------------------------------------------------------------------------------ attic
def attic_split(
    xyz: Array,
    params: AtticParams | None = None,
    *,
    z_order: NDArray[np.intp] | None = None,
    z_sorted: Array | None = None,
) -> AtticSplit:
    """Split a levelled building cloud into attic and body by slice hull areas.

    Slices every ``interval_m`` from the ground tolerance up; going up from the
    lowest slice, the first change of the convex-hull area by more than
    ``area_change`` after at least ``min_body_height_m`` of body is the attic limit.
    The limit is then refined to the point level: for a widening attic (eaves,
    cornice) it is the low end of the points outside the body hull; for a narrowing
    one the high end of the points outside the attic hull.

    Parameters
    ----------
    xyz
        ``(N, 3)`` levelled coordinates, metres.
    params
        Thesis defaults: 0.2 m interval, 5 cm slices, 10 % area change.
    z_order, z_sorted
        ``argsort(xyz[:, 2])`` and ``xyz[z_order, 2]`` if already computed.

    Returns
    -------
    AtticSplit
        ``limit_z`` None and all points body when no attic is found.
    """
    from matplotlib.path import Path as MplPath
    from scipy.spatial import ConvexHull, QhullError

    params = params or AtticParams()
    p = np.asarray(xyz, dtype=np.float64)
    prof = slice_profile(p, params.slices(), z_order=z_order, z_sorted=z_sorted)
    none = AtticSplit(np.zeros(len(p), dtype=bool), None, prof)
    # empty slices (a gap in the data, an open storey) are skipped, not read as a change
    valid = np.flatnonzero((prof.counts >= 3) & (prof.areas > 0))
    notes: tuple[str, ...] = ()
    n_empty = int(np.count_nonzero(prof.counts < 3))
    if n_empty:
        notes = (f"{n_empty} of {len(prof.counts)} slices are empty (gaps in the data)",)
    if len(valid) < 3:
        return AtticSplit(none.attic, None, prof, (*notes, "too few slices for an attic search"))
    a = prof.areas[valid]
    hts = prof.heights[valid]

    def changed(k: int, ref: float) -> bool:
        return abs(a[k] - ref) / max(a[k], ref, 1e-12) > params.area_change

    # Going up, the body is a run of slices whose area stays within the tolerance of the
    # run's median; the attic starts at the first slice that leaves it and whose next
    # slice also does (a single noisy slice is not an attic).
    start, brk = 0, None
    for i in range(len(a) - 1):  # loop over slices
        ref = float(np.median(a[start : i + 1]))
        if changed(i + 1, ref) and (i + 2 >= len(a) or changed(i + 2, ref)):
            if hts[i] - hts[start] >= params.min_body_height_m:
                brk = i
                break
            start = i + 1
    if brk is None:
        return AtticSplit(none.attic, None, prof, notes)
    h0, h1 = hts[brk], hts[brk + 1]
    widening = a[brk + 1] > a[brk]
    half = params.thickness_m / 2
    z = p[:, 2]
    gap = np.flatnonzero((z >= h0 - half) & (z <= h1 + half))

    def hull_path(h: float) -> MplPath | None:
        sel = np.abs(z - h) <= half
        try:
            hull = ConvexHull(p[sel, :2])
        except (QhullError, ValueError):
            return None
        return MplPath(p[sel, :2][hull.vertices])

    limit = (h0 + h1) / 2
    if widening:
        path = hull_path(h0)
        if path is not None and len(gap):
            out = ~path.contains_points(p[gap, :2], radius=0.03)
            if out.sum() >= 10:
                limit = float(np.quantile(z[gap][out], 0.002))
    else:
        path = hull_path(h1)
        if path is not None and len(gap):
            out = ~path.contains_points(p[gap, :2], radius=0.03)
            if out.sum() >= 10:
                limit = float(np.quantile(z[gap][out], 0.998)) + 1e-6
    attic = z >= limit
    if attic.mean() < params.min_attic_fraction:
        above = f"{limit - float(z.min()):.2f} m above the lowest point"
        return AtticSplit(
            np.zeros(len(p), dtype=bool),
            None,
            prof,
            (*notes, f"the part from {above} is too small to be an attic"),
        )
    return AtticSplit(attic, float(limit), prof, notes)


# ------------------------------------------------------------------------------ segmentation
def _segmentation(
    n: int, attic: NDArray[np.bool_], sup: SupportResult | None, notes: tuple[str, ...]
) -> Segmentation:
    instance = np.zeros(n, dtype=np.int32)
    class_id = np.zeros(n, dtype=np.uint8)
    rows: list[dict] = []
    if sup is not None and len(sup.objects):
        has = sup.instance > 0
        instance[has] = sup.instance[has]
        codes = np.array([0] + [_CODE[c] for c in sup.objects["class"]], dtype=np.uint8)
        class_id[has] = codes[sup.instance[has]]
        rows.extend(sup.objects.to_dict("records"))
    for name, mask in (("attic", attic), ("body", ~attic & (instance == 0))):
        if mask.any():
            k = len(rows) + 1
            instance[mask] = k
            class_id[mask] = _CODE[name]
            rows.append({"instance": k, "class": name, "n_points": int(mask.sum())})
    objects = pd.DataFrame(rows)
    if len(objects):
        objects["instance"] = objects["instance"].astype(np.int32)
        objects["n_points"] = np.bincount(instance, minlength=len(rows) + 1)[
            objects["instance"].to_numpy()
        ]
    return Segmentation(instance, class_id, dict(CLASSES), objects, None, tuple(notes))


def segment_attic(
    xyz: Array,
    params: AtticParams | None = None,
    prep: BuildingParams | None = None,
    *,
    source: str | None = None,
) -> tuple[Segmentation, AtticSplit, PreparedCloud]:
    """Attic / body split of a building cloud as a :class:`Segmentation`.

    Objects: ``body`` and, when found, ``attic``.  Heights in the returned split are
    in the prepared (levelled, metre) frame.

    Raises
    ------
    InputError
        See :func:`prepare_building` (degenerate clouds name ``source``).
    """
    cloud = prepare_building(xyz, prep, source=source, step="attic splits")
    split = attic_split(cloud.xyz, params)
    seg = _segmentation(len(cloud.xyz), split.attic, None, (*cloud.notes, *split.notes))
    return seg, split, cloud


def segment_building(
    xyz: Array,
    supports: SupportParams | None = None,
    attic: AtticParams | None = None,
    prep: BuildingParams | None = None,
    *,
    split_attic: bool = True,
    source: str | None = None,
) -> tuple[Segmentation, SupportResult, AtticSplit, PreparedCloud]:
    """Attic / body split then structural supports of one building cloud.

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates (local frame of a :class:`~pyheracles.cloud.PointCloud`).
    supports, attic, prep
        Parameters of each stage (defaults from the thesis where it gives them).
    split_attic
        Remove the attic before searching supports (supports stand in the body).
    source
        File name for error messages.

    Returns
    -------
    seg
        Labels aligned with ``xyz``: supports, ``attic``, rest of the ``body``.
    found, split, cloud
        Intermediate results (support details, attic limit, levelling and units).
        Support positions in the objects table (``x``, ``y``, ``z_min``, ``z_max``,
        axis) are in the input frame and units; dimensions (``*_m``) in metres.
        ``found.section_height`` and ``split.limit_z`` are in the prepared (levelled,
        metre) frame: :func:`to_input_frame` maps them back; messages give heights
        above the lowest point, the same in both frames.

    Raises
    ------
    InputError
        See :func:`prepare_building`: empty, NaN, degenerate (fewer points than
        ``SupportParams.min_points``, no horizontal or vertical extent), units.

    Examples
    --------
    >>> from pyheracles.synthetic.buildings import building_scene
    >>> scene = building_scene("pavilion", spacing_m=0.06, rng=0)
    >>> seg, found, split, _ = segment_building(scene.xyz)
    >>> seg.objects["class"].value_counts().to_dict()
    {'pier': 10, 'column': 4, 'attic': 1, 'body': 1}
    """
    with one_blas_thread():
        return _segment_building(xyz, supports, attic, prep, split_attic, source)


def _segment_building(
    xyz: Array,
    supports: SupportParams | None,
    attic: AtticParams | None,
    prep: BuildingParams | None,
    split_attic: bool,
    source: str | None,
) -> tuple[Segmentation, SupportResult, AtticSplit, PreparedCloud]:
    need = max(MIN_BUILDING_POINTS, (supports or SupportParams()).min_points)
    cloud = prepare_building(xyz, prep, source=source, step="supports", min_points=need)
    order, z_sorted = sort_order(cloud.xyz[:, 2])  # one sort of N points for all steps
    # the attic split needs nothing of the supports: a forked child computes it meanwhile
    attic_call = (
        ForkedCall(lambda: attic_split(cloud.xyz, attic, z_order=order, z_sorted=z_sorted))
        if split_attic
        else None
    )
    # The section is searched in the whole cloud, and the supports are cut out of it, so
    # that each keeps its full height up to what it carries, whatever the attic split
    # said: eaves lower than the tops of the supports, a roofless ruin whose columns rise
    # above its broken walls (the hull shrinks there, as at an attic: searched in the
    # body below it, the section fell among the plinths).  A roof space holds few
    # persistent support islands and the height search does not choose it.
    found = detect_supports_checked(cloud.xyz, supports, None, order, z_sorted)
    split = (
        attic_call.result()
        if attic_call is not None
        else AtticSplit(
            np.zeros(len(cloud.xyz), dtype=bool),
            None,
            SliceProfile(*[np.zeros(0)] * 3, np.zeros(0, dtype=np.int64)),
        )
    )
    full = found.instance
    attic_mask = split.attic & (full == 0)
    if split.has_attic and (n_up := int(np.count_nonzero(split.attic & (full > 0)))):
        found = replace(
            found,
            notes=(
                *found.notes,
                f"{n_up:,} points above the attic limit belong to supports (up to what they "
                "carry): they are in the supports, not in the attic",
            ),
        )
        split = replace(split, attic=attic_mask)
    found = replace(found, instance=full, objects=_to_input_frame(found.objects, cloud))
    notes = (*cloud.notes, *split.notes, *found.notes)
    return _segmentation(len(cloud.xyz), split.attic, found, notes), found, split, cloud


def objects_in_world(objects: pd.DataFrame, cloud: PointCloud) -> pd.DataFrame:
    """Support table in world coordinates: ``x``, ``y``, ``z_min``, ``z_max`` plus the
    cloud's offset; a GeoDataFrame of axis points when the cloud has a CRS."""
    import geopandas as gpd

    out = objects.copy()
    for col, k in (("x", 0), ("y", 1), ("z_min", 2), ("z_max", 2)):
        if col in out.columns:
            out[col] = out[col].astype(float) + float(cloud.offset[k])
    if cloud.crs is None or "x" not in out.columns:
        return out
    has = out["x"].notna().to_numpy()
    geom = gpd.GeoSeries.from_xy(
        np.where(has, out["x"].fillna(0), np.nan), np.where(has, out["y"].fillna(0), np.nan)
    )
    geom[~has] = None
    return gpd.GeoDataFrame(out, geometry=geom, crs=cloud.crs)


def to_input_frame(points: Array, cloud: PreparedCloud) -> Array:
    """Map ``(M, 3)`` points of the prepared (levelled, metre) frame back to the input."""
    q = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return ((q - cloud.centre) @ cloud.rotation + cloud.centre) / cloud.scale_to_m


def _to_input_frame(objects: pd.DataFrame, cloud: PreparedCloud) -> pd.DataFrame:
    """Support positions (x, y, z_min, z_max, axis) in the input frame and units."""
    if not len(objects):
        return objects
    out = objects.copy()
    mid = (out["z_min"] + out["z_max"]).to_numpy() / 2
    centre = np.c_[out["x"].to_numpy(), out["y"].to_numpy(), mid]
    back = to_input_frame(centre, cloud)
    half = (out["z_max"] - out["z_min"]).to_numpy() / 2 / cloud.scale_to_m
    out["x"], out["y"] = back[:, 0], back[:, 1]
    out["z_min"], out["z_max"] = back[:, 2] - half, back[:, 2] + half
    axes = np.c_[out["axis_x"], out["axis_y"], out["axis_z"]] @ cloud.rotation
    out["axis_x"], out["axis_y"], out["axis_z"] = axes[:, 0], axes[:, 1], axes[:, 2]
    return out
