"""Parameters and results of step 2b (beams): :class:`BeamParams`, facets, cuboids."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from pyheracles.errors import InputError
from pyheracles.labels import Segmentation
from pyheracles.segment.regiongrow import RegionGrowingParams

__all__ = [
    "BEAM_CLASS",
    "BEAM_CLASS_ID",
    "BeamCuboid",
    "BeamParams",
    "BeamResult",
    "StraightFacet",
    "box_distance",
]

BEAM_CLASS = "beam"
BEAM_CLASS_ID = 1

#: Signs of the 8 corners of a cuboid in its own frame (axis, width, height).
_CORNER_SIGNS = np.array(
    [[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)], dtype=np.float64
)
_CORNER_SIGNS.setflags(write=False)


@dataclass(frozen=True)
class BeamParams:
    """Parameters of beam segmentation.

    Attributes
    ----------
    region
        Region growing of the facets (:class:`RegionGrowingParams`).  Default:
        point level, ``k = 24`` (noisy TLS data), automatic thresholds.
    min_facet_points
        Facets and straight facets with fewer points are noise (back to the pool).
    min_beam_width_m, max_beam_width_m
        Accepted range of a straight facet's width, metres (timber sections of
        historic roofs are 5-60 cm).
    min_elongation
        A straight facet is at least this many times as long as it is wide.
    angle_step_deg
        Direction step of the band (Hough) search, degrees; refined 10 times finer.
    parallel_deg
        Largest angle between the axes of two facets of one beam, degrees.
    contact_m
        Largest boundary-to-boundary distance of two adjacent facets, metres;
        ``None``: twice the median k-neighbourhood radius (the band along an
        edge where normals are blended and points may stay unassigned), at
        least 4 times the point spacing and 2 cm.
    max_gap_m
        Largest gap along the axis between two pieces of one beam face (cut by a
        crossing beam in an X joint, or by an occlusion shadow), metres.
    max_shadow_m
        Largest gap along the axis between two pieces of one beam that share
        one located section (each seen on at least two faces, sizes within
        10 % or 1 cm, on one line; no farther apart than the longer piece is
        long), metres: a stretch of a member in the shadow of a member nearer
        the scanner (:func:`~pyheracles.beams.cuboids.same_section`).
    min_contact_fraction
        Two facets of a beam touch along at least this fraction of the shorter one.
    surface_tolerance_m
        Points closer than this to a fitted cuboid's surface join that beam,
        metres; ``None``: 3 times the median facet plane RMS, at least 1 cm.
    thin_spacing_m
        Clouds denser than this median point spacing (metres) are randomly
        thinned to it for the facets, bands and cuboids (``None``: never),
        each part by its own spacing: the parts already sparser (faces far
        from the stations) are kept whole
        (:func:`~pyheracles.beams.thinning.thin_to_spacing`); the
        labels are then given to every input point from the cuboids.  8 mm
        keeps at least 5 points across the narrowest face and lets 24
        neighbours span about 2.5 cm, well above the 2-5 mm noise of
        terrestrial scans (denser neighbourhoods give noisy normals and
        curvature).  Random thinning, unlike a voxel grid, leaves no layering
        of noisy surfaces.
    one_face
        Keep beams seen on one face only (their sides too sparse or hidden for
        a facet): a convex straight band at least twice ``min_elongation``
        times as long as wide, with the depth behind it read from its side
        points when there are any (:func:`~pyheracles.beams.one_face.fit_one_face_cuboid`).
    sparse_faces
        Grow regions again, with fewer neighbours, on the sparse parts of the
        cloud that no facet took (a far slope's narrow faces scanned at 1.5-3 cm,
        where ``region.k`` neighbours reach round the faces' edges:
        :mod:`pyheracles.beams.sparse_faces`).
    join_faces
        Join two pieces seen on one face that show one face (the same plane,
        width and centre line) up to ``max_shadow_m`` apart, as pieces of one
        member across a shadow (:mod:`pyheracles.beams.piece_joins`).
    frame_only
        Keep only the beams that are members of the frame
        (:func:`~pyheracles.beams.frame.frame_members` with the default
        :class:`~pyheracles.beams.frame.FrameParams`): timber lying loose on
        the floor, a ladder leaning on a post and detections joined to no
        frame are not members, and their points go to the remainder (label 0).
        When no two beams meet there is no frame to judge by and every beam is
        kept.
    """

    region: RegionGrowingParams = field(
        default_factory=lambda: RegionGrowingParams(k=24, min_points=100)
    )
    min_facet_points: int = 100
    min_beam_width_m: float = 0.04
    max_beam_width_m: float = 0.6
    min_elongation: float = 3.0
    angle_step_deg: float = 1.0
    parallel_deg: float = 5.0
    contact_m: float | None = None
    max_gap_m: float = 1.0
    max_shadow_m: float = 3.0
    min_contact_fraction: float = 0.4
    surface_tolerance_m: float | None = None
    thin_spacing_m: float | None = 0.008
    one_face: bool = True
    sparse_faces: bool = True
    join_faces: bool = True
    frame_only: bool = True

    def validate(self) -> BeamParams:
        if self.thin_spacing_m is not None and not 0 < self.thin_spacing_m < self.min_beam_width_m:
            raise InputError(
                f"thin_spacing_m must be in (0, min_beam_width_m), got {self.thin_spacing_m}",
                hint="in Python: BeamParams.thin_spacing_m below --min-width, or None: no thinning",
            )
        if not 0 < self.min_beam_width_m < self.max_beam_width_m:
            raise InputError(
                "need 0 < min_beam_width_m < max_beam_width_m, got "
                f"{self.min_beam_width_m} and {self.max_beam_width_m}"
            )
        if self.min_facet_points < 10:
            raise InputError(f"min_facet_points must be >= 10, got {self.min_facet_points}")
        if not 0 < self.parallel_deg < 45:
            raise InputError(f"parallel_deg must be in (0, 45), got {self.parallel_deg}")
        if self.max_shadow_m < 0:
            raise InputError(f"max_shadow_m must be >= 0 metres, got {self.max_shadow_m}")
        if not 0 < self.min_contact_fraction <= 1:
            raise InputError(
                f"min_contact_fraction must be in (0, 1], got {self.min_contact_fraction}"
            )
        if not 0.05 <= self.angle_step_deg <= 10:
            raise InputError(f"angle_step_deg must be in [0.05, 10], got {self.angle_step_deg}")
        self.region.validate()
        return self


@dataclass(frozen=True)
class StraightFacet:
    """A band of constant width inside a planar facet (one face of one beam).

    Attributes
    ----------
    index
        ``(m,)`` indices of its points in the input cloud.
    normal
        ``(3,)`` unit plane normal.
    axis
        ``(3,)`` unit direction of the band (the beam axis candidate).
    centre
        ``(3,)`` centroid, metres.
    width, length
        Band width (half-density edges) and length, metres.
    plane_rms
        RMS distance of its points to their plane, metres.
    parent
        Region (facet) it was cut from.
    """

    index: NDArray[np.int64]
    normal: NDArray[np.float64]
    axis: NDArray[np.float64]
    centre: NDArray[np.float64]
    width: float
    length: float
    plane_rms: float
    parent: int


def box_distance(
    local: NDArray[np.float64], half: NDArray[np.float64], *, overwrite: bool = False
) -> NDArray[np.float64]:
    """Signed distance (negative inside) of points given in a box's own frame to the
    box of half extents ``half``: ``|max(q, 0)| + min(max_k q_k, 0)``, ``q = |local| -
    half``, column by column (a reduction over rows of three values is slow in numpy),
    the squares summed in the order ``np.linalg.norm`` uses (the same numbers to the
    last bit).  ``overwrite``: ``local`` may be used as scratch."""
    q = np.abs(local, out=local) if overwrite else np.abs(local)
    q -= half
    q0, q1, q2 = q[:, 0], q[:, 1], q[:, 2]
    inside = np.maximum(np.maximum(q0, q1), q2)
    np.minimum(inside, 0.0, out=inside)
    np.maximum(q, 0.0, out=q)
    q *= q
    dist = q0 + q1
    dist += q2
    np.sqrt(dist, out=dist)
    dist += inside
    return dist


@dataclass(frozen=True)
class BeamCuboid:
    """Oriented cuboid of one beam.

    Attributes
    ----------
    centre
        ``(3,)`` centre, metres (local frame).
    axes
        ``(3, 3)`` columns: beam axis, width direction, height direction.
    length, width, height
        Edge lengths, metres; width is measured along the cross-section
        direction closer to horizontal.
    rms
        RMS distance of the beam's facet points to the cuboid surface, metres.
    n_facets
        Straight facets used.
    faces_seen
        Sides of the cross-section located by a face of their own (1-4; 0:
        not counted).  A beam seen on one face only has one.
    height_measured
        False when the depth behind a beam's only seen face was not measured
        (no points on its sides): the cuboid is then a thin slab on that face
        and its size across the face (``width`` or ``height``, whichever is
        the depth) is not known.
    """

    centre: NDArray[np.float64]
    axes: NDArray[np.float64]
    length: float
    width: float
    height: float
    rms: float
    n_facets: int
    faces_seen: int = 0
    height_measured: bool = True

    @property
    def axis(self) -> NDArray[np.float64]:
        return self.axes[:, 0]

    @property
    def inclination_deg(self) -> float:
        """Angle of the axis above the horizontal, degrees (0 flat, 90 plumb)."""
        return float(np.degrees(np.arcsin(min(1.0, abs(float(self.axis[2]))))))

    @property
    def half_extents(self) -> NDArray[np.float64]:
        return 0.5 * np.array([self.length, self.width, self.height])

    def signed_distance(self, points: ArrayLike) -> NDArray[np.float64]:
        """Signed distance to the cuboid surface (negative inside), metres.

        ``|max(q, 0)| + min(max_k q_k, 0)`` with ``q = |local| - half extents``,
        computed in place column by column (a reduction over rows of three
        values is slow in numpy); the sum of squares is added in the order
        ``np.linalg.norm`` uses, so the values are the same to the last bit.
        """
        local = (np.asarray(points, dtype=np.float64) - self.centre) @ self.axes
        return box_distance(local, self.half_extents, overwrite=True)

    def corners(self) -> NDArray[np.float64]:
        """``(8, 3)`` corners (for drawing)."""
        return self.centre + (_CORNER_SIGNS * self.half_extents) @ self.axes.T


@dataclass(frozen=True)
class BeamResult:
    """Result of :func:`segment_beams`.

    Attributes
    ----------
    labels
        ``(N,)`` int32 beam id per point (1..B), 0 = remainder.
    beams
        Cuboid of each beam (``beams[i]`` is label ``i + 1``).
    facet_labels
        ``(N,)`` int32 region-growing facet per point (0 = none).
    straight_labels
        ``(N,)`` int32 straight facet per point (0 = none).
    facet_beam
        Beam (1-based, 0 = none) of each straight facet.
    params
        Parameters with the automatic values resolved.
    timings
        Seconds per stage.
    """

    labels: NDArray[np.int32]
    beams: tuple[BeamCuboid, ...]
    facet_labels: NDArray[np.int32]
    straight_labels: NDArray[np.int32]
    facet_beam: NDArray[np.int32]
    params: BeamParams
    timings: dict[str, float] = field(default_factory=dict)

    def objects_table(self, offset: ArrayLike | None = None) -> pd.DataFrame:
        """One row per beam: ``instance``, ``class``, ``n_points``, axis, sizes, RMS."""
        off = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64)
        counts = np.bincount(self.labels, minlength=len(self.beams) + 1)
        rows: list[dict[str, Any]] = []
        for i, b in enumerate(self.beams):
            c = b.centre + off
            rows.append(
                {
                    "instance": i + 1,
                    "class": BEAM_CLASS,
                    "n_points": int(counts[i + 1]),
                    "n_facets": b.n_facets,
                    "centre_x": c[0],
                    "centre_y": c[1],
                    "centre_z": c[2],
                    "axis_x": b.axis[0],
                    "axis_y": b.axis[1],
                    "axis_z": b.axis[2],
                    "inclination_deg": b.inclination_deg,
                    "length_m": b.length,
                    "width_m": b.width,
                    "height_m": b.height,
                    "rms_m": b.rms,
                    "faces_seen": b.faces_seen,
                    "height_measured": b.height_measured,
                }
            )
        columns = [
            "instance",
            "class",
            "n_points",
            "n_facets",
            "centre_x",
            "centre_y",
            "centre_z",
            "axis_x",
            "axis_y",
            "axis_z",
            "inclination_deg",
            "length_m",
            "width_m",
            "height_m",
            "rms_m",
            "faces_seen",
            "height_measured",
        ]
        return pd.DataFrame(rows, columns=columns)

    def to_segmentation(self, offset: ArrayLike | None = None) -> Segmentation:
        """The result as a :class:`~pyheracles.labels.Segmentation` (class ``beam``)."""
        class_id = np.where(self.labels > 0, BEAM_CLASS_ID, 0).astype(np.uint8)
        return Segmentation(
            instance=self.labels,
            class_id=class_id,
            classes={BEAM_CLASS_ID: BEAM_CLASS},
            objects=self.objects_table(offset),
        )
