"""Parameters and results of :func:`pyheracles.walls.segment_walls`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from pyheracles.labels import Segmentation

__all__ = [
    "WALL_CLASS",
    "WALL_CLASS_ID",
    "Array",
    "Opening",
    "Wall",
    "WallFace",
    "WallParams",
    "WallResult",
]

Array = NDArray[np.float64]

WALL_CLASS = "wall"
WALL_CLASS_ID = 1


@dataclass(frozen=True)
class WallParams:
    """Parameters of :func:`segment_walls` (metres, degrees).

    Attributes
    ----------
    voxel_m
        Detection sample: one point per cube of this size (0.06 m; None = from the
        point spacing, at least 2 cm).
    distance_m
        Largest distance of a face point from its plane (0.03 m).  A face whose
        points' RMS distance from their plane exceeds a third of it is spread across
        the band (panes and cames, a curved or stepped surface), not a wall face, and
        is dropped: raise it for rough masonry.
    normal_angle_deg
        Largest angle between a point's normal and its face's (20 deg).
    max_tilt_deg
        Largest tilt of a wall from the vertical (10 deg).
    normal_neighbours
        Points of the detection sample whose plane gives a point's normal (16).  A
        face's length is measured up to its corners over its plane's points, past the
        neighbourhood (about ``sqrt(k / pi)`` spacings) where the normals turn.
    min_length_m, min_height_m, min_area_m2
        Smallest face kept (1 m long, 1.5 m high, 2 m2): pews, gravestones and
        window reveals are smaller.
    parallel_deg
        Largest angle between the two faces of one wall (3 deg).
    min_thickness_m, max_thickness_m
        Range of wall thickness for pairing faces (0.08 to 2.0 m).
    cell_m
        Grid of the outline on the wall plane (0.05 m).
    min_opening_m, min_opening_area_m2
        Smallest opening: 0.25 m wide and high, 0.1 m2.
    door_step_m
        An opening whose foot is within this height of the foot of one of the wall's
        faces (the floor inside, the ground outside) is a door (0.2 m: a threshold or
        a step; a window's sill is higher).
    max_floor_rise_m
        A face whose foot under an opening stands more than this above the wall's
        foot there (its lowest face's) stands on no floor or ground but on a roof (a
        clerestory over an aisle's lean-to roof, 3.5 m and more above the floor): an
        opening from its foot is a window, whose sill is measured (1.5 m; a door's
        threshold above the ground outside is lower).
    max_mullion_m
        Lights of one window side by side (or one above the other) separated by
        mullions or transoms up to this width are one opening (the wall's void that
        a window with its tracery fills in a BIM model); 0 (the default) keeps each
        light an opening of its own, as the stone between them is wall.
    run_gap_spacings
        A thin run of a face's points across an opening (a mullion's column, a
        transom's row) is followed across gaps of up to this many of the face's point
        spacings (4: three returns in a row lost to mixed pixels at the strip's
        edges, or scanned off it).
    snap_m
        Largest move of a wall end to a plane intersection (1.0 m).
    assumed_thickness_m
        Thickness given to a wall seen on one face where a solid is needed
        (IFC export; 0.3 m); never reported as measured.
    """

    voxel_m: float | None = 0.06
    distance_m: float = 0.03
    normal_angle_deg: float = 20.0
    max_tilt_deg: float = 10.0
    normal_neighbours: int = 16
    min_length_m: float = 1.0
    min_height_m: float = 1.5
    min_area_m2: float = 2.0
    parallel_deg: float = 3.0
    min_thickness_m: float = 0.08
    max_thickness_m: float = 2.0
    cell_m: float = 0.05
    min_opening_m: float = 0.25
    min_opening_area_m2: float = 0.1
    door_step_m: float = 0.2
    max_floor_rise_m: float = 1.5
    max_mullion_m: float = 0.0
    run_gap_spacings: float = 4.0
    snap_m: float = 1.0
    assumed_thickness_m: float = 0.3

    def __post_init__(self) -> None:
        positive = ("distance_m", "min_length_m", "min_height_m", "min_area_m2", "cell_m",
                    "min_opening_m", "min_opening_area_m2", "max_thickness_m",
                    "assumed_thickness_m", "max_floor_rise_m")  # fmt: skip
        for name in positive:
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number of metres, got {v!r}")
        if self.voxel_m is not None and not (math.isfinite(self.voxel_m) and self.voxel_m > 0):
            raise ValueError(f"voxel_m must be positive or None, got {self.voxel_m!r}")
        for name in ("normal_angle_deg", "max_tilt_deg", "parallel_deg"):
            v = getattr(self, name)
            if not (0 < v < 90):
                raise ValueError(f"{name} must be between 0 and 90 degrees, got {v!r}")
        if not (isinstance(self.normal_neighbours, int) and self.normal_neighbours >= 3):
            raise ValueError(f"normal_neighbours must be an integer >= 3, got "
                             f"{self.normal_neighbours!r}")  # fmt: skip
        if not 0 <= self.min_thickness_m < self.max_thickness_m:
            raise ValueError("min_thickness_m must be >= 0 and below max_thickness_m")
        if self.snap_m < 0:
            raise ValueError(f"snap_m must be >= 0, got {self.snap_m!r}")
        if not (math.isfinite(self.door_step_m) and self.door_step_m >= 0):
            raise ValueError(f"door_step_m must be >= 0, got {self.door_step_m!r}")
        if not (math.isfinite(self.max_mullion_m) and self.max_mullion_m >= 0):
            raise ValueError(f"max_mullion_m must be >= 0, got {self.max_mullion_m!r}")
        if not (math.isfinite(self.run_gap_spacings) and self.run_gap_spacings >= 0):
            raise ValueError(f"run_gap_spacings must be >= 0, got {self.run_gap_spacings!r}")


@dataclass(frozen=True)
class WallFace:
    """One fitted face: unit ``normal`` (horizontal-ish), offset ``d`` (n . x = d, local
    frame), its points (indices into the input), RMS distance (m)."""

    normal: Array
    d: float
    indices: NDArray[np.int64]
    rms_m: float


@dataclass(frozen=True)
class Opening:
    """An opening of a wall, in the wall's ``(u, z)`` plane coordinates (metres).

    ``kind`` is ``"door"`` (reaches the wall's foot) or ``"window"``; ``polygon`` is
    its outline ``(K, 2)``; ``width_m``/``height_m`` its bounding box; ``n_lights``
    the lights it was merged from (see :func:`merge_lights`).
    """

    kind: str
    u_min: float
    u_max: float
    z_min: float
    z_max: float
    polygon: Array
    n_lights: int = 1

    @property
    def width_m(self) -> float:
        return self.u_max - self.u_min

    @property
    def height_m(self) -> float:
        return self.z_max - self.z_min


@dataclass(frozen=True)
class Wall:
    """A wall: its plane, faces, thickness, outline and openings.

    The plane (``normal``, ``d``; local frame) is the mid-plane of two faces or
    the face itself; ``origin`` + ``u_axis`` span it with z up; ``outline`` is the
    envelope ``(K, 2)`` in ``(u, z)``; ``thickness_m`` is NaN when one face was seen,
    and ``material_side`` (+1 / -1 along ``normal``) says on which side of a lone
    face the wall lies (0 unknown).
    """

    instance: int
    normal: Array
    d: float
    origin: Array
    u_axis: Array
    faces: tuple[WallFace, ...]
    thickness_m: float
    outline: Array
    openings: tuple[Opening, ...]
    u_range: tuple[float, float]
    z_range: tuple[float, float]
    rms_m: float
    n_points: int
    material_side: int = 0
    joined: tuple[str, ...] = ()

    @property
    def length_m(self) -> float:
        return self.u_range[1] - self.u_range[0]

    @property
    def height_m(self) -> float:
        return self.z_range[1] - self.z_range[0]

    def to_3d(self, uz: ArrayLike, depth: float = 0.0) -> Array:
        """Points ``(K, 2)`` of the plane's ``(u, z)`` in 3D (local frame), ``depth``
        along ``normal``."""
        q = np.asarray(uz, dtype=np.float64).reshape(-1, 2)
        return (self.origin + q[:, :1] * self.u_axis + q[:, 1:] * np.array([0.0, 0.0, 1.0])
                + depth * self.normal)  # fmt: skip


@dataclass(frozen=True)
class WallResult:
    """Result of :func:`segment_walls`: per-point ``labels`` (wall instance, 0 = none),
    the walls, notes (bad input said in words) and the parameters used."""

    labels: NDArray[np.int32]
    walls: tuple[Wall, ...]
    params: WallParams
    notes: tuple[str, ...] = ()
    timings: dict[str, float] = field(default_factory=dict)

    def objects_table(self, offset: ArrayLike | None = None) -> pd.DataFrame:
        """One row per wall (world frame with ``offset``): plane, thickness, size, openings."""
        off = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64)
        rows = []
        for w in self.walls:
            centre = w.to_3d([[0.5 * sum(w.u_range), 0.5 * sum(w.z_range)]])[0] + off
            rows.append({
                "instance": w.instance, "class": WALL_CLASS, "n_points": w.n_points,
                "n_faces": len(w.faces),
                "normal_x": w.normal[0], "normal_y": w.normal[1], "normal_z": w.normal[2],
                "d": w.d + float(w.normal @ off),
                "thickness_m": w.thickness_m, "length_m": w.length_m, "height_m": w.height_m,
                "n_openings": len(w.openings),
                "n_windows": sum(o.kind == "window" for o in w.openings),
                "n_doors": sum(o.kind == "door" for o in w.openings),
                "fit_rms_m": w.rms_m,
                "x": centre[0], "y": centre[1], "z_min": w.z_range[0] + off[2],
                "z_max": w.z_range[1] + off[2],
            })  # fmt: skip
        cols = ["instance", "class", "n_points", "n_faces", "normal_x", "normal_y", "normal_z",
                "d", "thickness_m", "length_m", "height_m", "n_openings", "n_windows",
                "n_doors", "fit_rms_m", "x", "y", "z_min", "z_max"]  # fmt: skip
        return pd.DataFrame(rows, columns=cols)

    def to_segmentation(self, offset: ArrayLike | None = None) -> Segmentation:
        """The result as a :class:`~pyheracles.labels.Segmentation` (class ``wall``)."""
        return Segmentation(
            instance=self.labels,
            class_id=np.where(self.labels > 0, WALL_CLASS_ID, 0).astype(np.uint8),
            classes={WALL_CLASS_ID: WALL_CLASS},
            objects=self.objects_table(offset),
            warnings=self.notes,
        )

    def to_json(self, offset: ArrayLike | None = None) -> dict[str, Any]:
        """Walls with faces, frames, outlines and openings, world frame (``walls.json``)."""
        off = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64)
        walls = []
        for w in self.walls:
            walls.append({
                "instance": w.instance,
                "normal": w.normal.tolist(), "d": w.d + float(w.normal @ off),
                "origin": (w.origin + off).tolist(), "u_axis": w.u_axis.tolist(),
                "thickness_m": None if math.isnan(w.thickness_m) else w.thickness_m,
                "thickness_measured": not math.isnan(w.thickness_m),
                "material_side": w.material_side,
                "assumed_thickness_m": self.params.assumed_thickness_m,
                "length_m": w.length_m, "height_m": w.height_m,
                "u_range": list(w.u_range), "z_range": [w.z_range[0] + off[2],
                                                        w.z_range[1] + off[2]],
                "fit_rms_m": w.rms_m, "n_points": w.n_points,
                "faces": [{"normal": f.normal.tolist(), "d": f.d + float(f.normal @ off),
                           "n_points": len(f.indices), "rms_m": f.rms_m} for f in w.faces],
                "outline_uz": (w.outline + [0.0, off[2]]).tolist(),
                "outline_xyz": (w.to_3d(w.outline) + off).tolist(),
                "openings": [{"kind": o.kind, "u_min": o.u_min, "u_max": o.u_max,
                              "z_min": o.z_min + off[2], "z_max": o.z_max + off[2],
                              "width_m": o.width_m, "height_m": o.height_m,
                              "n_lights": o.n_lights,
                              "polygon_uz": (o.polygon + [0.0, off[2]]).tolist()}
                             for o in w.openings],
                "joined": list(w.joined),
            })  # fmt: skip
        return {"walls": walls, "notes": list(self.notes)}
