"""Roof planes of buildings from aerial or UAV clouds (M_HERACLES ``detectRoof``).

Region growing on normals (:func:`pyheracles.segment.regiongrow.region_growing`)
runs once over the roof points of every building; regions are split by
building, fitted with least-squares planes (:func:`pyheracles.geometry.fitting.fit_plane`),
steep ones (walls, vegetation) dropped, and coplanar regions of one building
merged.  :func:`roof_lines` gives the lines that cut a footprint into roof
faces: the intersection line of two neighbouring planes that meet (ridges,
hips, valleys), or the step line between two neighbouring planes at different
heights (a lower roof against a higher one).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.geometry.fitting import fit_line, fit_plane
from pyheracles.segment.regiongrow import RegionGrowingParams, region_growing

__all__ = ["RoofPlanes", "detect_planes", "roof_lines"]


@dataclass(frozen=True)
class RoofPlanes:
    """Roof planes of many buildings.

    Attributes
    ----------
    labels
        ``(N,)`` int32 plane id per input point (1..P), 0 = on no plane.
    building
        ``(P,)`` building index of each plane.
    abc
        ``(P, 3)`` planes as ``z = a x + b y + c`` (local frame, metres).
    rms_m
        ``(P,)`` RMS of the plane's points to the plane, metres.
    n_points
        ``(P,)`` points per plane.
    """

    labels: NDArray[np.int32]
    building: NDArray[np.int64]
    abc: NDArray[np.float64]
    rms_m: NDArray[np.float64]
    n_points: NDArray[np.int64]

    @property
    def slope_deg(self) -> NDArray[np.float64]:
        return np.degrees(np.arctan(np.hypot(self.abc[:, 0], self.abc[:, 1])))


def _abc(normal: NDArray[np.float64], centroid: NDArray[np.float64]) -> NDArray[np.float64]:
    n = normal if normal[2] > 0 else -normal
    a, b = -n[0] / n[2], -n[1] / n[2]
    return np.array([a, b, centroid[2] - a * centroid[0] - b * centroid[1]])


def _vertical_rms(p: NDArray[np.float64], abc: NDArray[np.float64]) -> float:
    r = (p[:, 2] - p[:, 0] * abc[0] - p[:, 1] * abc[1] - abc[2]) / np.sqrt(
        1 + abc[0] ** 2 + abc[1] ** 2
    )
    return float(np.sqrt(np.mean(r**2)))


def detect_planes(
    xyz: NDArray[np.float64],
    building: NDArray[np.int64],
    *,
    min_points: int,
    max_slope_deg: float,
    max_rms_m: float,
    merge_angle_deg: float,
    merge_distance_m: float,
    angle_deg: float | None = None,
    k: int = 12,
) -> RoofPlanes:
    """Roof planes of the points ``xyz`` (local frame, m), ``building`` index per point."""
    n = len(xyz)
    empty = RoofPlanes(
        np.zeros(n, np.int32), np.zeros(0, np.int64), np.zeros((0, 3)),
        np.zeros(0), np.zeros(0, np.int64),
    )  # fmt: skip
    if n < max(k, 4):
        return empty
    regions = region_growing(
        xyz, RegionGrowingParams(k=k, angle_deg=angle_deg, min_points=min(min_points, 3))
    )
    key = np.where(regions.labels > 0, building * (regions.n_regions + 1) + regions.labels, -1)
    valid = key >= 0
    uniq, inv = np.unique(key[valid], return_inverse=True)
    order = np.argsort(inv, kind="stable")
    starts = np.searchsorted(inv[order], np.arange(len(uniq)))
    sizes = np.bincount(inv, minlength=len(uniq))
    idx_valid = np.flatnonzero(valid)
    cos_max = np.cos(np.radians(max_slope_deg))
    groups: dict[int, list[tuple[NDArray[np.int64], NDArray[np.float64]]]] = {}
    for g in range(len(uniq)):
        if sizes[g] < min_points:
            continue
        members = idx_valid[order[starts[g] : starts[g] + sizes[g]]]
        fit = fit_plane(xyz[members])
        if not fit or abs(fit.normal[2]) < cos_max:
            continue
        abc = _abc(fit.normal, xyz[members].mean(axis=0))
        if _vertical_rms(xyz[members], abc) > max_rms_m:
            continue
        groups.setdefault(int(building[members[0]]), []).append((members, abc))
    labels = np.zeros(n, np.int32)
    out_b, out_abc, out_rms, out_n = [], [], [], []
    cos_merge = np.cos(np.radians(merge_angle_deg))
    for b in sorted(groups):
        planes = sorted(groups[b], key=lambda t: -len(t[0]))
        merged: list[tuple[NDArray[np.int64], NDArray[np.float64]]] = []
        for members, abc in planes:
            nrm = np.array([-abc[0], -abc[1], 1.0]) / np.sqrt(1 + abc[0] ** 2 + abc[1] ** 2)
            for j, (m2, abc2) in enumerate(merged):
                n2 = np.array([-abc2[0], -abc2[1], 1.0]) / np.sqrt(1 + abc2[0] ** 2 + abc2[1] ** 2)
                if float(nrm @ n2) < cos_merge:
                    continue
                if _vertical_rms(xyz[members], abc2) < merge_distance_m:
                    both = np.concatenate([m2, members])
                    fit = fit_plane(xyz[both])
                    if fit:
                        merged[j] = (both, _abc(fit.normal, xyz[both].mean(axis=0)))
                        break
            else:
                merged.append((members, abc))
        for members, abc in merged:
            out_b.append(b)
            out_abc.append(abc)
            out_rms.append(_vertical_rms(xyz[members], abc))
            out_n.append(len(members))
            labels[members] = len(out_b)
    return RoofPlanes(
        labels,
        np.asarray(out_b, np.int64),
        np.asarray(out_abc, np.float64).reshape(-1, 3),
        np.asarray(out_rms, np.float64),
        np.asarray(out_n, np.int64),
    )


def _long_line(p: NDArray[np.float64], d: NDArray[np.float64], half: float) -> shapely.LineString:
    return shapely.LineString([p - d * half, p + d * half])


def roof_lines(
    xy: NDArray[np.float64],
    plane: NDArray[np.int64],
    abc: NDArray[np.float64],
    *,
    adjacency_m: float,
    step_m: float,
    extent_m: float,
) -> list[shapely.LineString]:
    """Lines between neighbouring roof planes of one building.

    Parameters
    ----------
    xy
        ``(n, 2)`` points of the building on a plane, local frame, metres.
    plane
        ``(n,)`` index into ``abc`` of each point's plane.
    abc
        ``(P, 3)`` planes ``z = a x + b y + c``.
    adjacency_m
        Points of two planes closer than this (in plan) make them neighbours.
    step_m
        Where the two planes differ by more than this along their common
        border, the border is a step (a line fitted to it) and not their
        intersection line.
    extent_m
        Half-length of the lines (enough to cross the footprint).
    """
    if len(abc) < 2 or len(xy) < 2:
        return []
    tree = cKDTree(xy)
    pairs = tree.query_pairs(adjacency_m, output_type="ndarray")
    pairs = pairs[plane[pairs[:, 0]] != plane[pairs[:, 1]]]
    if not len(pairs):
        return []
    pa, pb = plane[pairs[:, 0]], plane[pairs[:, 1]]
    lo, hi = np.minimum(pa, pb), np.maximum(pa, pb)
    key = lo * len(abc) + hi
    lines = []
    for kk in np.unique(key):
        sel = key == kk
        i, j = int(kk // len(abc)), int(kk % len(abc))
        if np.count_nonzero(sel) < 2:
            continue
        mid = 0.5 * (xy[pairs[sel, 0]] + xy[pairs[sel, 1]])
        da, db = abc[i], abc[j]
        gap = np.abs((da[0] - db[0]) * mid[:, 0] + (da[1] - db[1]) * mid[:, 1] + da[2] - db[2])
        g = np.array([da[0] - db[0], da[1] - db[1]])
        if float(np.median(gap)) <= step_m and np.hypot(*g) > 1e-6:
            # intersection line: g . p + (ca - cb) = 0
            p0 = -g * (da[2] - db[2]) / float(g @ g)
            d = np.array([-g[1], g[0]]) / np.hypot(*g)
            # centre it on the common border
            p0 = p0 + d * float((mid.mean(axis=0) - p0) @ d)
            lines.append(_long_line(p0, d, extent_m))
        elif len(mid) >= 3:
            fit = fit_line(np.column_stack([mid, np.zeros(len(mid))]))
            if fit:
                d = np.asarray(fit.direction[:2], dtype=np.float64)
                if np.hypot(*d) > 1e-6:
                    lines.append(_long_line(mid.mean(axis=0), d / np.hypot(*d), extent_m))
    return lines
