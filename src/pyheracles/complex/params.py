"""Parameters and result of step 1 (GIS-aided segmentation), thesis chapter 5."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from pyheracles.errors import InputError
from pyheracles.labels import Segmentation

__all__ = ["CLUSTERING", "GROUND_METHODS", "ComplexParams", "ComplexResult", "resolve_params"]

#: Ground options of step 1 (``class`` keeps an existing ASPRS classification).
GROUND_METHODS = ("auto", "csf", "smrf", "none", "class")
CLUSTERING = ("auto", "exact", "voxel")
#: Above this many candidate points, ``clustering="auto"`` uses voxels.
EXACT_LIMIT = 20_000
#: Automatic buffer of the cookie-cutter, metres (see ``ComplexParams.buffer_m``).
AUTO_BUFFER_M = 1.0
#: Floor of the automatic ``min_cluster_points``.
MIN_OBJECT_POINTS = 5
#: Points used at most for a polygon's ground level or height percentile.
LEVEL_SAMPLE = 20_000


@dataclass(frozen=True)
class ComplexParams:
    """Parameters of the GIS-aided segmentation (step 1).

    ``None`` means automatic, derived from the median point spacing ``s``
    (the thesis set these by hand for each data set; a multiple of the
    spacing travels between a drone survey and aerial LiDAR).

    Attributes
    ----------
    buffer_m
        Buffer around each polygon for the 2.5D cookie-cutter, metres.  It
        absorbs digitising errors and catches facade points outside the
        footprint.  Automatic: 1 m at any density (digitising errors do not
        grow with the spacing; 3 spacings, 5-7 m at 0.1-0.2 points/m^2, took
        the crowns and clutter around small buildings and walls).
    cluster_distance_m
        Largest gap inside one object for the Euclidean clustering, metres.
        Automatic: ``max(0.3, 3 s)``.
    min_cluster_points
        Clusters with fewer points are noise and go back to the pool.
        Automatic: the number of points on about 1 m^2, at least 5 (a small
        building at 0.15 points/m^2 has 10-15 points).
    keep_fraction
        A cluster other than the main one is kept when at least this fraction
        of its points lies inside the (unbuffered) polygon.
    scatter_max
        Surface variation (smallest eigenvalue / sum, k = 12 neighbours) above
        which a point counts as scattered, like foliage.  Objects are grown
        from the other points only; scattered points join an object only when
        they lie near its footprint and below its top and are linked to it
        (roof edges, thin walls), so a tree crown touching a roof does not
        become part of it.  ``None``
        turns this off (the thesis's plain clustering).  Roofs and walls have
        a median near 0.007, foliage near 0.11 (measured on AHN3 tile 1).
    multi_echo_scatter_max
        Lower surface-variation threshold for points of multi-echo pulses
        (LAS ``number_of_returns > 1``; used only when the cloud has it):
        the laser went partly through, as in foliage.  ``None`` ignores echoes.
    porous_echoes
        Use the echoes (LAS ``return_number`` and ``number_of_returns``, when
        the cloud has both): a point amid pass-through points (returns that
        are not the last of their pulse: the laser went on beyond them) lies
        on a porous surface, foliage, and counts as scattered, at any density
        (the surface variation needs a dozen neighbours on one surface, more
        than a sparse roof has).  Such points join an object only up to
        ``scatter_rise_m`` above its surface beside them.
    porous_share
        A point is porous when at least this share of it and its 16 nearest
        candidates (3D) within 3 m are pass-through (on a sparse survey the 16
        span a building and the crown over it): a crown's last returns lie amid its
        pass-through returns; a roof's eave line (pass-through returns on an
        edge) and a roof under a crown amid the roof's last returns (see
        :func:`pyheracles.complex.clusters.porous_points`).  ``None``: every
        pass-through point and no other.
    attach_distance_m
        Scattered points are linked to an object by steps of up to twice
        this distance, and may rise this much above its top.  Automatic: the
        clustering distance.
    scatter_above_top_m
        Scattered points join an object at most this much above its top (the
        99th percentile of its points' heights) and at most
        ``attach_distance_m``: the edges of a roof do not rise higher on a
        sparse survey (3 spacings let crowns 3-7 m above small roofs in at
        0.1-1 points/m^2).  Metres; ``None``: ``attach_distance_m`` alone.
    scatter_rise_m
        Porous points (with ``porous_echoes``) join an object only up to this
        height above the highest of its 4 kept points nearest in XY: a crown
        over a roof rises above the roof beside it.  Rough solid parts (a
        dormer's edges) are held to the object-wide limit only (its top plus
        ``attach_distance_m``).  Metres; ``None`` holds porous points to that
        limit too.
    scatter_vote_neighbours
        A smooth candidate point whose this many nearest candidates of the same
        polygon (3D) are at least ``scatter_vote_share`` scattered, and which
        stands more than ``scatter_rise_m`` above the other smooth points
        beside it, counts as scattered (see
        :func:`pyheracles.complex.clusters.vote_scattered`): the flat-looking
        patches of a crown no longer chain it to the roof under it, and its
        scattered points are held to the roof's top.  ``None`` turns the vote
        off.
    scatter_vote_share
        Share of scattered neighbours that makes a smooth point scattered.
    scatter_vote_keep
        The vote is dropped for a polygon when fewer than this share of the
        smooth points inside it would stay smooth (on sparse surveys the surface
        variation flags roofs, and thin towers are mostly edges).
    outside_above_top_m
        Points of an object outside its polygon (in the buffer ring) may stand
        at most this much above the top of its points inside the polygon (99th
        percentile): eaves and facades stand lower, the crown of a tree beside
        a wall or a small building higher (complex family, 0.1-0.4 points/m^2:
        such crown points chained to walls at a clustering distance of 3-7 m).
        A cluster apart from the object's main one, running on off the
        polygon and standing this much over the main one's top and over its
        points beside it, is a crown's too (see
        :func:`pyheracles.complex.clusters.floating_clusters`).
        Metres; ``None`` turns both tests off.
    scatter_offset_m
        Scattered points join an object only within this XY distance of its
        polygon (inside counts as 0): roof edges and eaves, not the hedge or
        the crown beside a shed.  Automatic: a quarter of the buffer.  On
        AHN3 tile 1 (buffer 1 m) any value from 0.15 to 0.3 m gives the same
        quality; half the buffer let hedges beside small sheds in.
    eave_tolerance_m
        Scattered points of the buffer ring beyond ``scatter_offset_m`` join an
        object where they run on its own roof outward, an eave: within this
        height of the plane fitted to the object's top surface beside them (a
        tight fit, one roof face), no higher than the roof's edge beside them,
        with nothing rough over them, and linked to the object (see
        :func:`pyheracles.complex.eaves.eave_points`).  A neighbour's roof lies
        off that plane, a hedge or a crown pokes over it.  AHN3 tile 1: 152 more
        reference building points 0.25-1 m beyond the outlines, 49 unclassified
        ones.  Metres; ``None`` turns this off.
    clutter_height_m
        A group of an object's points beyond ``scatter_offset_m`` outside its polygon
        (single linkage at the clustering distance), reaching beyond half the buffer,
        whose top stands less than this over the terrain and at least 1 m under the
        object beside it (itself at least this tall), and which holds no ground
        released as the object's platform, is clutter standing beside it (parked cars
        and bicycles, bins, hedges, terrain the ground filter left out): it goes back
        to the pool (see :func:`pyheracles.complex.clutter.clutter_points`).  About a
        person's height: a canopy or an annex roof one walks under stands higher.
        AHN3 tile 1: of the 360 points the objects took more than 0.25 m out and under
        2 m, 35 are building in the reference; the rule gives back 198 of them, 8 of
        those building.  Metres; ``None`` turns this off.
    low_outlier_m
        An object's point standing more than this under the terrain under it (the
        median of the 8 nearest ground points) is a low outlier (a multipath return),
        never the feature's: it goes back to the pool (see
        :func:`pyheracles.complex.clutter.under_terrain`).  Complex family draws 0-29:
        347 object points more than 0.5 m under the terrain, none of them the
        feature's.  Metres; ``None`` turns this off.
    crown_rise_m
        A point of an object standing more than this above the median of its
        8 nearest points of the object in XY (within the clustering distance),
        where at least ``crown_share`` of the points around it (3D, within the
        clustering distance) lie outside every polygon, untaken, at its height
        or higher, is a tree crown's over the object: the crown runs on beyond
        the footprint, a dormer or a chimney does not (see
        :func:`pyheracles.complex.crowns.crown_points`).  Metres; ``None``
        turns the test off.
    crown_share
        Least share of such points beside a raised point that makes it a crown's.
    ground
        One of ``auto``, ``csf``, ``smrf`` (see :mod:`pyheracles.ground`),
        ``class`` (keep ASPRS class 2 of the input) or ``none``.
    raised_ground_m
        Ground points within a polygon's buffer that stand more than this
        above the terrain around the polygon (the ground beyond every buffer,
        its holes filled with a membrane) are its platform, plinth,
        steps or the top of a low wall, not terrain: they go back to the pool
        (see :func:`pyheracles.groundfilters.footprints.raised_in_footprints`).
        Metres; ``None`` keeps the ground filter's answer.  A classification
        given with the input (``ground="class"``) is kept as it is.
    platform_tops
        Ground points inside the polygons that continue a released platform top
        (nearer its level, the median of the released points within the clustering
        distance, than the terrain under them) are released too (see
        :func:`pyheracles.complex.platforms.platform_tops`): a platform's noise or the
        slope under it left a quarter to a half of some low platforms under the
        release threshold (complex family draw 24).  ``False`` turns this off.
    layer_order
        Names of the layers in processing order; ``None`` orders them
        automatically, lowest objects first (thesis section 5.2).
    clustering
        ``exact`` (KD-tree single linkage), ``voxel`` (touching voxels of
        ``cluster_distance_m / 2``) or ``auto`` (exact below 50 000
        candidate points).
    seed
        Seed for the random sample used to measure the spacing.
    """

    buffer_m: float | None = None
    cluster_distance_m: float | None = None
    min_cluster_points: int | None = None
    keep_fraction: float = 0.25
    scatter_max: float | None = 0.1
    multi_echo_scatter_max: float | None = 0.02
    porous_echoes: bool = True
    porous_share: float | None = 0.5
    attach_distance_m: float | None = None
    scatter_offset_m: float | None = None
    scatter_above_top_m: float | None = 1.0
    scatter_rise_m: float | None = 0.5
    scatter_vote_neighbours: int | None = 8
    scatter_vote_share: float = 0.5
    scatter_vote_keep: float = 0.8
    outside_above_top_m: float | None = 1.0
    eave_tolerance_m: float | None = 0.15
    clutter_height_m: float | None = 2.0
    low_outlier_m: float | None = 0.5
    crown_rise_m: float | None = 1.0
    crown_share: float = 0.2
    ground: str = "auto"
    raised_ground_m: float | None = 0.2
    platform_tops: bool = True
    layer_order: tuple[str, ...] | None = None
    clustering: str = "auto"
    seed: int = 0

    def __post_init__(self) -> None:
        if self.ground not in GROUND_METHODS:
            raise InputError(
                f"unknown ground method {self.ground!r}; choose one of {', '.join(GROUND_METHODS)}"
            )
        if self.clustering not in CLUSTERING:
            raise InputError(
                f"unknown clustering {self.clustering!r}; choose one of {', '.join(CLUSTERING)}"
            )
        for name in ("buffer_m", "cluster_distance_m", "attach_distance_m", "raised_ground_m"):
            value = getattr(self, name)
            if value is not None and not value > 0:
                raise InputError(f"{name} must be > 0, got {value}")
        if self.scatter_above_top_m is not None and not self.scatter_above_top_m >= 0:
            raise InputError(f"scatter_above_top_m must be >= 0, got {self.scatter_above_top_m}")
        if self.scatter_rise_m is not None and not self.scatter_rise_m >= 0:
            raise InputError(f"scatter_rise_m must be >= 0, got {self.scatter_rise_m}")
        if self.eave_tolerance_m is not None and not self.eave_tolerance_m > 0:
            raise InputError(f"eave_tolerance_m must be > 0, got {self.eave_tolerance_m}")
        if self.clutter_height_m is not None and not self.clutter_height_m > 0:
            raise InputError(f"clutter_height_m must be > 0, got {self.clutter_height_m}")
        if self.low_outlier_m is not None and not self.low_outlier_m >= 0:
            raise InputError(f"low_outlier_m must be >= 0, got {self.low_outlier_m}")
        if self.crown_rise_m is not None and not self.crown_rise_m >= 0:
            raise InputError(f"crown_rise_m must be >= 0, got {self.crown_rise_m}")
        if self.outside_above_top_m is not None and not self.outside_above_top_m >= 0:
            raise InputError(f"outside_above_top_m must be >= 0, got {self.outside_above_top_m}")
        if self.scatter_offset_m is not None and not self.scatter_offset_m >= 0:
            raise InputError(f"scatter_offset_m must be >= 0, got {self.scatter_offset_m}")
        if self.min_cluster_points is not None and self.min_cluster_points < 1:
            raise InputError(f"min_cluster_points must be >= 1, got {self.min_cluster_points}")
        if self.porous_share is not None and not 0.0 < self.porous_share <= 1.0:
            raise InputError(f"porous_share must be in (0, 1], got {self.porous_share}")
        if self.scatter_vote_neighbours is not None and self.scatter_vote_neighbours < 1:
            raise InputError(
                f"scatter_vote_neighbours must be >= 1, got {self.scatter_vote_neighbours}"
            )
        for name in ("scatter_vote_share", "scatter_vote_keep", "crown_share"):
            if not 0.0 < getattr(self, name) <= 1.0:
                raise InputError(f"{name} must be in (0, 1], got {getattr(self, name)}")
        if not 0.0 <= self.keep_fraction <= 1.0:
            raise InputError(f"keep_fraction must be in [0, 1], got {self.keep_fraction}")


def resolve_params(params: ComplexParams, spacing_m: float) -> ComplexParams:
    """Fill every automatic parameter from the point spacing (metres)."""
    s = float(spacing_m)
    return replace(
        params,
        buffer_m=params.buffer_m if params.buffer_m is not None else AUTO_BUFFER_M,
        cluster_distance_m=(
            params.cluster_distance_m
            if params.cluster_distance_m is not None
            else max(0.3, 3.0 * s)
        ),
        attach_distance_m=(
            params.attach_distance_m if params.attach_distance_m is not None else max(0.3, 3.0 * s)
        ),
        scatter_offset_m=(
            params.scatter_offset_m
            if params.scatter_offset_m is not None
            else 0.25 * (params.buffer_m if params.buffer_m is not None else AUTO_BUFFER_M)
        ),
        min_cluster_points=(
            params.min_cluster_points
            if params.min_cluster_points is not None
            else max(MIN_OBJECT_POINTS, round(0.25 / max(s, 1e-3) ** 2))
        ),
    )


@dataclass(frozen=True, eq=False)
class ComplexResult:
    """Result of :func:`segment_complex`.

    Attributes
    ----------
    segmentation
        Per-point labels (``instance``, ``class_id``, ``ground``) and the
        objects table (a GeoDataFrame: one row per object with its feature's
        attributes and geometry).
    params
        The parameters actually used (automatic values filled in).
    spacing_m
        Measured median point spacing.
    layer_order
        Layers in the order they were processed.
    timings
        Seconds per stage.
    """

    segmentation: Segmentation
    params: ComplexParams
    spacing_m: float
    layer_order: tuple[str, ...]
    timings: dict[str, float] = field(default_factory=dict)
