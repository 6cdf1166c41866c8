"""Roof planes and LoD1.2 / LoD2.2 building solids from aerial clouds and footprints.

M_HERACLES ``detectRoof`` / ``intersectMultPlanes`` turned into the 3D-GIS
building models the Netherlands makes with 3dfier (LoD1.2) and roofer
(LoD2.2, 3DBAG).  Per footprint:

1. ground level: median height of the ground points within ``ground_ring_m``
   of the footprint (3dfier takes a low percentile of the terrain around the
   building); roof points: the other points inside it, ``min_height_m`` above;
2. LoD1.2: the footprint extruded from the ground to the ``lod12_percentile``
   (70th, as 3dfier) of the roof points' heights;
3. roof planes by region growing on normals (:mod:`pyheracles.roofs.planes`);
4. LoD2.2: the footprint cut by the planes' intersection and step lines, each
   cell labelled with the plane most of its points lie on, extruded into a
   closed solid (:mod:`pyheracles.roofs.solid`), checked with
   :func:`pyheracles.export.validate_solid.validate_solid`.

A footprint with no points, or points but none above the ground, is skipped
and listed (``RoofsResult.skipped``); an invalid LoD2.2 solid is dropped and
listed, the building keeping its LoD1.2.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
import shapely
from numpy.typing import NDArray
from shapely.geometry.polygon import orient

from pyheracles.errors import InputError
from pyheracles.roofs.planes import RoofPlanes, detect_planes, roof_lines
from pyheracles.roofs.solid import (
    Solid,
    extrude_partition,
    flat_solid,
    partition_footprint,
)

__all__ = [
    "BuildingModel",
    "RoofParams",
    "RoofsResult",
    "Solid",
    "city_buildings",
    "model_roofs",
]

#: ASPRS classes never taken as roof points (ground, noise, water, high noise).
_NOT_ROOF = (2, 7, 9, 18)


@dataclass(frozen=True)
class RoofParams:
    """Parameters of roof modelling; lengths in metres, angles in degrees.

    Attributes
    ----------
    min_height_m
        Roof points are at least this high above the ground level.
    ground_ring_m
        Ground points within this distance of the footprint give its ground level.
    lod12_percentile
        Height percentile of the roof points for LoD1.2 (3dfier: 70).
    min_plane_area_m2
        Smallest roof plane, square metres (converted to points with the density).
    max_slope_deg
        Steeper planes are walls or vegetation, not roofs.
    max_plane_rms_m
        Regions farther than this (RMS) from their plane are not roofs (trees).
    merge_angle_deg, merge_distance_m
        Regions of one building whose normals agree within the angle and whose
        points are within the distance (RMS) of the other's plane are one plane.
    step_m
        Neighbouring planes that differ by more than this along their border
        meet in a vertical step wall, not along their intersection line.
    adjacency_m
        Plan distance making two planes neighbours; None: 2.5 x the point spacing.
    angle_deg
        Region growing normal angle; None: automatic (the normal noise).
    """

    min_height_m: float = 1.0
    ground_ring_m: float = 3.0
    lod12_percentile: float = 70.0
    min_plane_area_m2: float = 3.0
    max_slope_deg: float = 70.0
    max_plane_rms_m: float = 0.25
    merge_angle_deg: float = 6.0
    merge_distance_m: float = 0.15
    step_m: float = 0.5
    adjacency_m: float | None = None
    angle_deg: float | None = None

    def validate(self) -> RoofParams:
        if not 0 < self.lod12_percentile <= 100:
            raise InputError(f"lod12_percentile must be in (0, 100], got {self.lod12_percentile}")
        for name in ("ground_ring_m", "min_plane_area_m2", "max_plane_rms_m", "step_m"):
            if getattr(self, name) <= 0:
                raise InputError(f"{name} must be > 0, got {getattr(self, name)}")
        if not 0 < self.max_slope_deg < 90:
            raise InputError(f"max_slope_deg must be in (0, 90), got {self.max_slope_deg}")
        return self


@dataclass(frozen=True)
class BuildingModel:
    """The models of one footprint (local frame)."""

    instance: int
    ground_z: float
    lod12: Solid
    lod22: Solid | None
    lod22_errors: tuple[str, ...] = ()


@dataclass(frozen=True)
class RoofsResult:
    """Result of :func:`model_roofs`.

    Attributes
    ----------
    instance
        ``(N,)`` int32 building (1..B, the footprint's row + 1) per point, 0 = none.
    roof_plane
        ``(N,)`` int32 roof plane id per point (1..P, global), 0 = none.
    ground
        ``(N,)`` bool ground points.
    objects
        One row per modelled building: the footprint's attributes plus the
        modelling figures (GeoDataFrame, world coordinates).
    planes
        One row per roof plane: ``plane``, ``instance``, ``a``, ``b``, ``c``
        (``z = a x + b y + c`` in the local frame), slope, RMS, points.
    models
        Instance -> :class:`BuildingModel`.
    skipped
        One message per footprint that was not modelled.
    warnings
        Other messages (dropped invalid solids ...).
    """

    instance: NDArray[np.int32]
    roof_plane: NDArray[np.int32]
    ground: NDArray[np.bool_]
    objects: gpd.GeoDataFrame
    planes: pd.DataFrame
    models: dict[int, BuildingModel]
    skipped: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def _ground_levels(
    fps: NDArray[Any], gxyz: NDArray[np.float64], ring_m: float
) -> NDArray[np.float64]:
    """Median ground height near each footprint (a 5 times wider ring as a fallback)."""
    out = np.full(len(fps), np.nan)
    if not len(gxyz):
        return out
    for ring in (ring_m, 5 * ring_m):
        todo = np.flatnonzero(np.isnan(out))
        if not len(todo):
            break
        for f, idx in zip(todo, _points_in(shapely.buffer(fps[todo], ring), gxyz), strict=True):
            if len(idx):
                out[f] = float(np.median(gxyz[idx, 2]))
    return out


def _points_in(polys: NDArray[Any], xyz: NDArray[np.float64]) -> list[NDArray[np.int64]]:
    """Indices of the points inside each polygon (points sorted by x once; one
    vectorised point-in-polygon test per polygon on the points of its x range)."""
    order = np.argsort(xyz[:, 0], kind="stable")
    xs = xyz[order, 0]
    out = []
    for g in polys:
        if g is None or g.is_empty:
            out.append(np.zeros(0, np.int64))
            continue
        x0, y0, x1, y1 = g.bounds
        cand = order[np.searchsorted(xs, x0) : np.searchsorted(xs, x1, side="right")]
        cand = cand[(xyz[cand, 1] >= y0) & (xyz[cand, 1] <= y1)]
        out.append(np.sort(cand[shapely.contains_xy(g, xyz[cand, 0], xyz[cand, 1])]))
    return out


def _inside(fps: NDArray[Any], xyz: NDArray[np.float64]) -> NDArray[np.int64]:
    """Footprint index per point (-1 outside every footprint; the first when several)."""
    out = np.full(len(xyz), -1, np.int64)
    for f, idx in reversed(list(enumerate(_points_in(fps, xyz)))):
        out[idx] = f
    return out


def _label_cells(
    cells: list[Any],
    xy: NDArray[np.float64],
    plane: NDArray[np.int64],
    xyz: NDArray[np.float64],
    abc: NDArray[np.float64],
    inlier_m: float,
) -> list[int]:
    """The plane most of a cell's roof points ``xyz`` fit (within ``inlier_m``); for a
    cell without points, the plane of the nearest point on a plane (``xy``, ``plane``)."""
    from scipy.spatial import cKDTree

    tree = cKDTree(xy)
    labels = []
    resid = np.abs(xyz[:, 2, None] - xyz[:, 0, None] * abc[:, 0] - xyz[:, 1, None] * abc[:, 1]
                   - abc[:, 2]) / np.sqrt(1 + abc[:, 0] ** 2 + abc[:, 1] ** 2)  # fmt: skip
    fits = resid < inlier_m
    for c in cells:
        inside = shapely.contains_xy(c, xyz[:, 0], xyz[:, 1])
        votes = fits[inside].sum(axis=0)
        if inside.any() and votes.max() > 0:
            labels.append(int(votes.argmax()))
        else:
            p = c.representative_point()
            labels.append(int(plane[tree.query([p.x, p.y])[1]]))
    return labels


def _missing_lines(
    cells: list[Any],
    labels: list[int],
    xy: NDArray[np.float64],
    plane: NDArray[np.int64],
    abc: NDArray[np.float64],
    adjacency_m: float,
    step_m: float,
    extent_m: float,
    *,
    min_share: float = 0.15,
    min_points: int = 8,
) -> list[Any]:
    """Lines between the planes that share a cell (no line was found between them).

    A border is found only where points of two planes lie within ``adjacency_m``;
    ridges that region growing left bare, or sparse data, leave two planes in one
    cell, and one of them is then modelled at the other's height (metres off on
    AHN3).  For each cell where another plane holds at least ``min_share`` of the
    points (and ``min_points``), the line between the two planes' points of that
    cell is added: their intersection, or a step line fitted to the midpoints of
    the nearest cross pairs (see :func:`roof_lines`), with the adjacency widened to
    the gap between the two groups.
    """
    from scipy.spatial import cKDTree

    out: list[Any] = []
    for cell, lab in zip(cells, labels, strict=True):
        inside = shapely.contains_xy(cell, xy[:, 0], xy[:, 1])
        if inside.sum() < 2 * min_points:
            continue
        counts = np.bincount(plane[inside], minlength=len(abc))
        total = counts.sum()
        for q in np.flatnonzero((counts >= min_points) & (counts >= min_share * total)):
            if q == lab or counts[lab] < min_points:
                continue
            a = xy[inside & (plane == lab)]
            b = xy[inside & (plane == q)]
            gap = float(cKDTree(a).query(b)[0].min())
            sub = np.r_[np.zeros(len(a), np.int64), np.ones(len(b), np.int64)]
            found = roof_lines(np.vstack([a, b]), sub, abc[[lab, q]],
                               adjacency_m=max(adjacency_m, 1.5 * gap + 1e-3),
                               step_m=step_m, extent_m=extent_m)  # fmt: skip
            out.extend(found)
    return out


def _extend_planes(
    xyz: NDArray[np.float64],
    pts: NDArray[np.int64],
    roof_plane: NDArray[np.int32],
    abc: NDArray[np.float64],
    inlier_m: float,
    reach_m: float,
) -> None:
    """Give the building's points on no plane the plane of a nearby point that they fit
    within ``inlier_m`` (region growing leaves the points of ridges and edges out)."""
    from scipy.spatial import cKDTree

    lab = roof_plane[pts]
    on, off = pts[lab > 0], pts[lab == 0]
    if len(on) < 3 or not len(off):
        return
    k = min(8, len(on))
    dist, nn = cKDTree(xyz[on, :2]).query(xyz[off, :2], k=k, distance_upper_bound=reach_m)
    dist, nn = dist.reshape(len(off), k), nn.reshape(len(off), k)
    found = nn < len(on)
    cand = np.where(found, roof_plane[on][np.minimum(nn, len(on) - 1)], 0)
    a = abc[np.maximum(cand - 1, 0)]
    q = xyz[off][:, None, :]
    r = np.abs(q[..., 2] - a[..., 0] * q[..., 0] - a[..., 1] * q[..., 1] - a[..., 2])
    r = np.where(found, r / np.sqrt(1 + a[..., 0] ** 2 + a[..., 1] ** 2), np.inf)
    best = r.argmin(axis=1)
    ok = r[np.arange(len(off)), best] < inlier_m
    roof_plane[off[ok]] = cand[np.arange(len(off)), best][ok]


def _roof_rms(
    solid: Solid, abc: NDArray[np.float64], xyz: NDArray[np.float64]
) -> tuple[float, int]:
    """RMS orthogonal distance of points to the roof face above/below them, m; points used."""
    d2, used = 0.0, 0
    for face, sem, lab in zip(solid.faces, solid.semantics, solid.roof_plane, strict=True):
        if sem != "RoofSurface":
            continue
        rings = [solid.vertices[r, :2] for r in face]
        poly = shapely.Polygon(rings[0], rings[1:])
        m = shapely.contains_xy(poly, xyz[:, 0], xyz[:, 1])
        if not m.any():
            continue
        a, b, c = abc[lab]
        r = (xyz[m, 2] - a * xyz[m, 0] - b * xyz[m, 1] - c) / np.sqrt(1 + a * a + b * b)
        d2 += float(np.sum(r**2))
        used += int(m.sum())
    return (float(np.sqrt(d2 / used)) if used else float("nan")), used


def _main_polygon(geom: Any) -> Any:
    if geom is None or geom.is_empty:
        return None
    if geom.geom_type == "MultiPolygon":
        geom = max(geom.geoms, key=lambda g: g.area)
    if geom.geom_type != "Polygon":
        return None
    return orient(geom, 1.0)


def model_roofs(
    xyz: NDArray[np.float64],
    footprints: gpd.GeoDataFrame,
    *,
    offset: NDArray[np.float64] | None = None,
    classification: NDArray[np.integer] | None = None,
    ground: NDArray[np.bool_] | None = None,
    params: RoofParams | None = None,
    lod22: bool = True,
) -> RoofsResult:
    """Roof planes and LoD1.2 / LoD2.2 solids of every footprint.

    Parameters
    ----------
    xyz
        ``(N, 3)`` points in the local frame (world = local + ``offset``), metres.
    footprints
        Building polygons in world coordinates (the cloud's CRS), with attributes.
    offset
        ``(3,)`` the cloud's offset (world = local + offset).
    classification
        ASPRS classes per point; when it has ground (2), that is the ground.
    ground
        Ground mask per point (wins over ``classification``); None and no
        classified ground: the ground is extracted (:func:`pyheracles.ground.extract_ground`).
    params
        :class:`RoofParams`.
    lod22
        Detect roof planes and build LoD2.2 solids (False: LoD1.2 only).

    Returns
    -------
    RoofsResult
    """
    p = (params or RoofParams()).validate()
    xyz = np.asarray(xyz, dtype=np.float64)
    off = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64)
    n = len(xyz)
    if n == 0:
        raise InputError("the cloud has no points", hint="give a cloud with points")
    cls = None if classification is None else np.asarray(classification)
    if ground is None:
        if cls is not None and np.any(cls == 2):
            ground = cls == 2
        else:
            from pyheracles.ground import extract_ground

            ground = extract_ground(xyz, "auto").mask
    ground = np.asarray(ground, dtype=bool)
    candidate = ~ground if cls is None else ~ground & ~np.isin(cls, _NOT_ROOF)

    geoms = [_main_polygon(g) for g in footprints.geometry]
    fps = np.array(
        [
            shapely.transform(g, lambda c: c - off[:2]) if g is not None else shapely.Polygon()
            for g in geoms
        ],
        dtype=object,
    )
    ok = np.array([g is not None for g in geoms])
    zg = _ground_levels(fps, xyz[ground], p.ground_ring_m)
    where = _inside(fps, xyz)
    skipped: list[str] = []
    warnings: list[str] = []
    instance = np.zeros(n, np.int32)
    has_ground = np.isfinite(zg[np.maximum(where, 0)]) & (where >= 0)
    roof = candidate & has_ground
    roof[roof] &= xyz[roof, 2] > zg[where[roof]] + p.min_height_m
    instance[(where >= 0) & candidate] = (where[(where >= 0) & candidate] + 1).astype(np.int32)

    # point spacing of the roof points sets the plane size in points and the adjacency
    from pyheracles.geometry.neighbours import point_spacing

    ridx = np.flatnonzero(roof)
    spacing = point_spacing(xyz[ridx]) if len(ridx) > 10 else 1.0
    density = 1.0 / max(spacing, 1e-3) ** 2
    min_points = max(6, round(p.min_plane_area_m2 * density))
    adjacency = p.adjacency_m or 2.5 * spacing
    found: RoofPlanes = detect_planes(
        xyz[ridx] if lod22 else xyz[:0], where[ridx] if lod22 else where[:0],
        min_points=min_points, max_slope_deg=p.max_slope_deg,
        max_rms_m=p.max_plane_rms_m, merge_angle_deg=p.merge_angle_deg,
        merge_distance_m=p.merge_distance_m, angle_deg=p.angle_deg,
    )  # fmt: skip
    roof_plane = np.zeros(n, np.int32)
    if lod22:
        roof_plane[ridx] = found.labels

    by_building: dict[int, NDArray[np.int64]] = {}
    if len(ridx):
        order = np.argsort(where[ridx], kind="stable")
        srt = ridx[order]
        cuts = np.flatnonzero(np.diff(where[srt])) + 1
        for chunk in np.split(srt, cuts):
            by_building[int(where[chunk[0]])] = chunk
    n_inside = np.bincount(where[where >= 0], minlength=len(fps))

    rows: list[dict[str, Any]] = []
    models: dict[int, BuildingModel] = {}
    attrs = footprints.drop(columns=footprints.geometry.name)
    for f in range(len(fps)):
        name = f"footprint {f} (source_fid {attrs.iloc[f].get('source_fid', f)})"
        if not ok[f]:
            skipped.append(f"{name}: not a polygon")
            continue
        if n_inside[f] == 0:
            skipped.append(f"{name}: no points inside the footprint")
            continue
        if not np.isfinite(zg[f]):
            skipped.append(f"{name}: no ground points around the footprint")
            continue
        pts = by_building.get(f, np.zeros(0, np.int64))
        if len(pts) < 3:
            skipped.append(
                f"{name}: no roof points ({len(pts)} points more than "
                f"{p.min_height_m} m above the ground)"
            )
            continue
        z70 = float(np.percentile(xyz[pts, 2], p.lod12_percentile))
        lod12 = flat_solid(fps[f], zg[f], z70)
        lod22, errors, rms, n_planes, n_faces = None, (), float("nan"), 0, 0
        _extend_planes(xyz, pts, roof_plane, found.abc, 2 * p.merge_distance_m, 4 * spacing)
        on = pts[roof_plane[pts] > 0]
        if len(on) >= 3:
            ids = np.unique(roof_plane[on])
            local = np.searchsorted(ids, roof_plane[on])
            abc = found.abc[ids - 1]
            n_planes = len(ids)
            extent = float(np.hypot(*np.ptp(np.asarray(fps[f].exterior.coords), axis=0))) + 1
            lines = roof_lines(
                xyz[on, :2], local, abc, adjacency_m=adjacency, step_m=p.step_m, extent_m=extent
            )
            cells = partition_footprint(fps[f], lines)
            tries = []  # (cells, labels): refined first, the plain partition as fall-back
            for _ in range(3):  # cells that still hold two planes get the line between them
                if not cells:
                    break
                labels = _label_cells(
                    cells, xyz[on, :2], local, xyz[pts], abc, 2 * p.merge_distance_m
                )
                tries.insert(0, (cells, labels))
                extra = _missing_lines(cells, labels, xyz[on, :2], local, abc,
                                       adjacency, p.step_m, extent)  # fmt: skip
                if not extra:
                    break
                lines = [*lines, *extra]
                cells = partition_footprint(fps[f], lines)
            else:
                if cells:
                    tries.insert(
                        0,
                        (
                            cells,
                            _label_cells(
                                cells, xyz[on, :2], local, xyz[pts], abc, 2 * p.merge_distance_m
                            ),
                        ),
                    )
            if len(tries) > 2:
                tries = [tries[0], tries[-1]]
            from pyheracles.export.validate_solid import validate_solid

            for k, (cells_k, labels_k) in enumerate(tries):
                solid = extrude_partition(cells_k, labels_k, abc, zg[f])
                errors = tuple(validate_solid(solid.vertices, solid.faces))
                roof_z = solid.vertices[:, 2][np.unique(np.concatenate([
                    np.concatenate(fc) for fc, s in zip(solid.faces, solid.semantics, strict=True)
                    if s == "RoofSurface"]))]  # fmt: skip
                if np.any(roof_z < zg[f] + 0.01):
                    errors = (*errors, "a roof face lies below the ground")
                if not errors:
                    lod22 = solid
                    n_faces = sum(s == "RoofSurface" for s in solid.semantics)
                    rms, _ = _roof_rms(solid, abc, xyz[on])
                    if k:
                        warnings.append(
                            f"{name}: LoD2.2 without the lines added between "
                            "planes sharing a cell (that solid was invalid)"
                        )
                    break
            if tries and lod22 is None:
                warnings.append(f"{name}: LoD2.2 solid invalid, not written ({errors[0]})")
        elif lod22:
            warnings.append(f"{name}: no roof plane found, LoD1.2 only")
        inst = f + 1
        models[inst] = BuildingModel(inst, float(zg[f]), lod12, lod22, tuple(errors))
        row = {"instance": inst, "class": "building"}
        row.update(attrs.iloc[f].to_dict())
        row.update(
            n_points=int(np.count_nonzero(instance == inst)), n_roof_points=len(pts),
            n_planes=n_planes, n_roof_faces=n_faces, ground_z=float(zg[f] + off[2]),
            lod12_z=float(z70 + off[2]), lod12_height_m=float(z70 - zg[f]),
            lod22=lod22 is not None, lod22_rms_m=rms, geometry=geoms[f],
        )  # fmt: skip
        rows.append(row)
    if rows:
        objects = gpd.GeoDataFrame(rows, geometry="geometry", crs=footprints.crs)
    else:
        objects = gpd.GeoDataFrame(
            {"instance": pd.Series([], dtype="int64"), "class": pd.Series([], dtype=str)},
            geometry=gpd.GeoSeries([], crs=footprints.crs),
        )
    # points of skipped footprints go back to the pool (label 0)
    kept = np.zeros(len(fps) + 1, bool)
    kept[list(models)] = True
    instance[~kept[instance]] = 0
    roof_plane[instance == 0] = 0
    planes = pd.DataFrame(
        {
            "plane": np.arange(1, len(found.abc) + 1),
            "instance": found.building + 1,
            "a": found.abc[:, 0], "b": found.abc[:, 1], "c": found.abc[:, 2],
            "slope_deg": found.slope_deg, "rms_m": found.rms_m, "n_points": found.n_points,
        }
    )  # fmt: skip
    planes = planes[kept[planes["instance"].to_numpy()]].reset_index(drop=True)
    return RoofsResult(instance, roof_plane, ground, objects, planes, models, skipped, warnings)


def city_buildings(result: RoofsResult, offset: NDArray[np.float64] | None = None) -> list[Any]:
    """The modelled buildings as :class:`pyheracles.export.cityjson.CityBuilding` (world)."""
    from pyheracles.export.cityjson import CityBuilding

    off = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64)
    out = []
    table = result.objects.drop(columns=result.objects.geometry.name)
    for _, row in table.iterrows():
        m = result.models[int(row["instance"])]
        solids = {"1.2": (m.lod12.vertices + off, m.lod12.faces, m.lod12.semantics)}
        if m.lod22 is not None:
            solids["2.2"] = (m.lod22.vertices + off, m.lod22.faces, m.lod22.semantics)
        out.append(CityBuilding(f"building_{int(row['instance'])}", row.to_dict(), solids))
    return out
