"""Airborne acquisition of the ``terrain`` family and its gross errors.

:func:`survey_plan` lays 2-4 overlapping strips over the square so that the pulse
density over the area (all strips together) is the drawn one and the scan pattern is
about as dense along track as across (the scan rate follows the speed and density).
:func:`add_low_outliers` adds what the scanner's :class:`~pyheracles.synthetic.scanner.Outliers`
does not: clusters of points several metres under the terrain (multipath: a 6 x 7 m
patch 6 m down) and isolated points just under the local terrain, inserted in the
acquisition stream and flagged as outliers.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pyheracles.synthetic.families.terrain_relief import Relief
from pyheracles.synthetic.scanner import AirborneSurvey, ScanResult
from pyheracles.synthetic.scene import Scene

__all__ = ["add_low_outliers", "crop", "insert_points", "survey_plan"]

Array = NDArray[np.float64]


def survey_plan(
    side_m: float,
    density_per_m2: float,
    n_strips: int,
    overlap: float,
    half_fov_deg: float,
    heading_deg: float,
    speed_mps: float,
    noise_m: float,
    mean_z: float,
) -> AirborneSurvey:
    """Strips covering ``[0, side_m]^2``: exactly ``n_strips``, ``density_per_m2`` pulses overall.

    The swath is chosen so that ``n_strips`` strips with the side overlap span the area
    (as the scanner lays them); the flying height follows from the swath and the half
    field of view; one strip's density is the overall one divided by the mean number of
    strips seeing a spot.
    """
    h = np.deg2rad(heading_deg)
    extent = side_m * (abs(np.sin(h)) + abs(np.cos(h)))  # across-track extent of the square
    swath = extent / ((1 - overlap) * n_strips - 0.2) * (1 + 1e-9)
    coverage = n_strips * swath / (extent + 0.2 * swath)
    strip_density = density_per_m2 / coverage
    height = swath / (2 * np.tan(np.deg2rad(half_fov_deg)))
    return AirborneSurvey(
        bounds=(0.0, 0.0, side_m, side_m),
        altitude_m=float(mean_z + height),
        density_per_m2=float(strip_density),
        half_fov_deg=half_fov_deg,
        overlap=overlap,
        heading_deg=heading_deg,
        noise_m=noise_m,
        max_returns=5,
        min_separation_m=1.0,
        scan_rate_hz=float(speed_mps * np.sqrt(strip_density)),
        speed_mps=speed_mps,
    )


def crop(res: ScanResult, side_m: float) -> ScanResult:
    """The points over ``[0, side_m]^2`` (the relief runs on past the survey's edge)."""
    xy = res.xyz[:, :2]
    return res.subset(((xy >= 0) & (xy <= side_m)).all(1))


def insert_points(
    res: ScanResult, xyz: Array, part: int | NDArray[np.int32], rng: np.random.Generator
) -> ScanResult:
    """Outlier points spread through the acquisition stream (flagged, no instance or class).

    ``part`` is one part code for all of them or one per point.
    """
    m = len(xyz)
    n = len(res)
    if m == 0 or n == 0:
        return res
    order = rng.permutation(m)  # kinds mixed through the stream
    xyz = xyz[order]
    part_arr = np.broadcast_to(np.asarray(part, np.int32), (m,))[order]
    pos = np.sort(rng.integers(0, n + 1, m))
    near = np.minimum(pos, n - 1)
    ins = {
        "xyz": xyz,
        "intensity": np.full(m, 150, np.uint16),
        "point_source_id": res.point_source_id[near],
        "return_number": np.ones(m, np.uint8),
        "number_of_returns": np.ones(m, np.uint8),
        "scan_angle_deg": res.scan_angle_deg[near],
        "gps_time": res.gps_time[near],
        "scan_direction_flag": res.scan_direction_flag[near],
        "edge_of_flight_line": res.edge_of_flight_line[near],
        "instance": np.zeros(m, np.int32),
        "class_id": np.zeros(m, np.int32),
        "part": part_arr,
        "outlier": np.ones(m, bool),
    }
    kw = {k: np.insert(getattr(res, k), pos, v, axis=0) for k, v in ins.items()}
    return ScanResult(**kw, acquisitions=res.acquisitions)


def add_low_outliers(
    res: ScanResult,
    scene: Scene,
    relief: Relief,
    rng: np.random.Generator,
    *,
    side_m: float,
    n_clusters: int,
    cluster_depth_m: float,
    isolated_share: float,
) -> tuple[ScanResult, list[dict[str, object]]]:
    """Low outlier clusters (multipath) and isolated points under the local terrain.

    A cluster is a rectangle of 3-10 m sides (a 6 x 7 m patch is typical), as dense as
    the ground, ``cluster_depth_m`` (+-30 %) under the terrain; isolated points lie
    0.3-10 m under the terrain.  Returns the scan and one record per cluster.
    """
    area = side_m**2
    ground = res.class_id == scene.class_code("ground")
    density = max(float(ground.sum()) / area, 0.05)
    records: list[dict[str, object]] = []
    chunks: list[Array] = []
    parts: list[NDArray[np.int32]] = []
    for _ in range(n_clusters):
        sx, sy = rng.uniform(3.0, 10.0, 2)
        c = rng.uniform(0.1 * side_m, 0.9 * side_m, 2)
        depth = cluster_depth_m * rng.uniform(0.7, 1.3)
        m = max(6, int(rng.poisson(density * sx * sy)))
        xy = c + (rng.random((m, 2)) - 0.5) * [sx, sy]
        z = relief.height(xy) - depth + rng.normal(0, 0.15, m)
        chunks.append(np.column_stack([xy, z]))
        parts.append(np.full(m, scene.part_code("outlier_low_cluster"), np.int32))
        records.append(
            {
                "center": c.tolist(),
                "size_m": [float(sx), float(sy)],
                "depth_m": float(depth),
                "points": m,
            }
        )
    k = round(isolated_share * len(res))
    if k:
        xy = rng.uniform(0, side_m, (k, 2))
        z = relief.height(xy) - rng.uniform(0.3, 10.0, k)
        chunks.append(np.column_stack([xy, z]))
        parts.append(np.full(k, scene.part_code("outlier_low"), np.int32))
    if chunks:
        res = insert_points(res, np.concatenate(chunks), np.concatenate(parts), rng)
    return res, records
