"""Objects-table columns of a support beyond its primitive: lean, end radii, parts."""

from __future__ import annotations

import math

import numpy as np

from pyheracles.supports.primitives import describe, lean, part_bands

SPACING = 0.012
NOISE = 0.005


def _rot(tilt_deg: float, azimuth_deg: float) -> np.ndarray:
    """Rotation tilting +z by ``tilt_deg`` towards ``azimuth_deg`` (clockwise from +y)."""
    az = math.radians(azimuth_deg)
    k = np.array([-math.cos(az), math.sin(az), 0.0])  # k x z: the lean's direction
    t = math.radians(tilt_deg)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(t) * kx + (1 - math.cos(t)) * kx @ kx


def _square_band(half: float, z0: float, z1: float, rng: np.random.Generator) -> np.ndarray:
    n = int(8 * half * (z1 - z0) / SPACING**2)
    s = rng.uniform(-half, half, n)
    side = rng.integers(0, 4, n)
    x = np.where(side == 0, half, np.where(side == 1, -half, s))
    y = np.where(side == 2, half, np.where(side == 3, -half, s))
    return np.c_[x, y, rng.uniform(z0, z1, n)]


def _ring_face(r0: float, r1: float, z: float, rng: np.random.Generator, square: bool):
    """Horizontal face at ``z`` between the shaft radius ``r0`` and ``r1`` (square)."""
    lim = r1
    n = int((2 * lim) ** 2 / SPACING**2)
    xy = rng.uniform(-lim, lim, (n, 2))
    keep = np.hypot(*xy.T) > r0
    if not square:
        keep &= np.hypot(*xy.T) <= r1
    return np.c_[xy[keep], np.full(keep.sum(), z)]


def leaning_column(
    seed: int = 0, tilt_deg: float = 3.0, azimuth_deg: float = 60.0
) -> tuple[np.ndarray, np.ndarray, dict]:
    """A leaning tapered column with a square plinth, an echinus and a square abacus.

    Returns the points (5 mm noise), their true part (0 plinth, 1 shaft, 2 capital)
    and the truth: radii of the shaft at its ends, heights of the parts.
    """
    rng = np.random.default_rng(seed)
    truth = {"r0": 0.30, "r1": 0.25, "plinth": 0.25, "shaft_top": 4.20, "top": 4.65}
    t = {"tilt": tilt_deg, "azimuth": azimuth_deg, **truth}
    parts = []
    plinth = _square_band(0.45, 0.0, 0.25, rng)
    parts += [(plinth, 0), (_ring_face(0.30, 0.45, 0.25, rng, True), 0)]
    n = int(2 * math.pi * 0.28 * (4.2 - 0.25) / SPACING**2)
    z = rng.uniform(0.25, 4.2, n)
    r = 0.30 + (0.25 - 0.30) * (z - 0.25) / (4.2 - 0.25)
    a = rng.uniform(0, 2 * math.pi, n)
    parts.append((np.c_[r * np.cos(a), r * np.sin(a), z], 1))
    n = int(2 * math.pi * 0.32 * 0.3 / SPACING**2)  # echinus: a cone 0.25 -> 0.38
    z = rng.uniform(4.2, 4.45, n)
    r = 0.25 + 0.13 * (z - 4.2) / 0.25
    a = rng.uniform(0, 2 * math.pi, n)
    parts.append((np.c_[r * np.cos(a), r * np.sin(a), z], 2))
    parts += [(_ring_face(0.38, 0.42, 4.45, rng, True), 2)]
    parts.append((_square_band(0.42, 4.45, 4.65, rng), 2))
    pts = np.vstack([p for p, _ in parts])
    part = np.concatenate([np.full(len(p), k) for p, k in parts])
    pts = pts @ _rot(tilt_deg, azimuth_deg).T + [10.0, 20.0, 100.0]
    pts += rng.normal(0, NOISE, pts.shape)
    return pts, part, t


def table_row(pts: np.ndarray) -> dict:
    """The objects-table row :func:`describe` gives the column (section at 1.5 m)."""
    sec = np.abs(pts[:, 2] - pts[:, 2].min() - 1.5) < 0.05  # the section at 1.5 m
    c = pts[sec, :2].mean(axis=0)
    r = float(np.median(np.hypot(*(pts[sec, :2] - c).T)))
    rho = np.hypot(*(pts[:, :2] - c).T) - r
    sh = {"class": "column", "centre": c, "radius": r, "half": np.array([r, r])}
    return describe(pts, rho, sh, 0.03)


def test_lean_radii_and_parts_of_a_leaning_tapered_column() -> None:
    for seed, (tilt, az) in enumerate([(3.0, 60.0), (1.0, 200.0), (6.0, 315.0)]):
        pts, _, t = leaning_column(seed, tilt, az)
        row = table_row(pts)
        assert abs(row["tilt_deg"] - tilt) <= 0.3, (seed, row["tilt_deg"])
        height = float(np.ptp(pts[:, 2]))
        assert abs(row["lean_m"] - height * math.tan(math.radians(row["tilt_deg"]))) < 1e-9
        assert abs((row["lean_azimuth_deg"] - az + 180) % 360 - 180) <= 5.0, row
        assert abs(row["radius_bottom_m"] - t["r0"]) <= 0.01, (seed, row["radius_bottom_m"])
        assert abs(row["radius_top_m"] - t["r1"]) <= 0.01, (seed, row["radius_top_m"])
        # radius_m: the tapered shaft's radius at the section's height (1.5 m up)
        h = row["radius_height_m"] + float(pts[:, 2].min()) - 100.0
        r_sec = t["r0"] + (t["r1"] - t["r0"]) * (h - t["plinth"]) / (t["shaft_top"] - t["plinth"])
        assert abs(row["radius_m"] - r_sec) <= 0.005, (seed, row["radius_m"], r_sec)
        # parts: heights above z_min of the axis where the plinth ends, the capital starts
        # (an echinus flares gradually: it shows once wider than the shaft by 3 sigma)
        cos, z_min = math.cos(math.radians(tilt)), float(pts[:, 2].min())
        base_top = 100.0 + t["plinth"] * cos - z_min
        capital_bottom = 100.0 + t["shaft_top"] * cos - z_min
        assert abs(row["base_top_m"] - base_top) <= 0.05, (seed, row["base_top_m"], base_top)
        assert abs(row["capital_bottom_m"] - capital_bottom) <= 0.08, (seed, row, capital_bottom)


def test_plain_column_has_no_parts() -> None:
    rng = np.random.default_rng(3)
    n = 40_000
    z = rng.uniform(0, 4, n)
    a = rng.uniform(0, 2 * math.pi, n)
    pts = np.c_[0.3 * np.cos(a), 0.3 * np.sin(a), z] + rng.normal(0, NOISE, (n, 3))
    row = table_row(pts + [0, 0, 100.0])
    assert math.isnan(row["base_top_m"]) and math.isnan(row["capital_bottom_m"]), row
    assert row["tilt_deg"] < 0.3 and abs(row["radius_bottom_m"] - 0.3) < 0.01


def test_lean_azimuth_is_clockwise_from_north() -> None:
    east = lean(np.array([math.sin(0.1), 0.0, math.cos(0.1)]), 2.0)
    assert abs(east["lean_azimuth_deg"] - 90.0) < 1e-9
    assert abs(east["lean_m"] - 2.0 * math.tan(0.1)) < 1e-12
    south = lean(np.array([0.0, -0.1, -1.0]), 1.0)  # axis sign does not matter
    assert (
        abs(south["lean_azimuth_deg"] - 0.0) < 1e-9 or abs(south["lean_azimuth_deg"] - 180) < 1e-9
    )
    assert lean(np.array([0.0, 0.0, 1.0]), 3.0)["lean_m"] == 0.0


def test_part_bands_need_a_wider_run_at_an_end() -> None:
    h = np.linspace(0, 3, 3001)
    reach = np.full_like(h, 0.3)
    assert all(math.isnan(v) for v in part_bands(h, reach, np.full_like(h, 0.3), 0.003))
    reach[h < 0.3] = 0.45  # a plinth
    base, cap = part_bands(h, reach, np.full_like(h, 0.3), 0.003)
    assert abs(base - 0.3) <= 0.02 and math.isnan(cap)
