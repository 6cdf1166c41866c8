"""A column's radius is measured at its section, not over the band of heights around it.

Draw 23 of the supports family (kiosk, shafts with taper and entasis, r 0.99 -> 0.77 m
over 10.3 m, photogrammetry: surface tolerance 8 cm) had every column's radius 1.7-4.4
cm too large: the points within the tolerance of the section circle are a band of the
tapered shaft several metres tall, cut by the capital above the section, so their
cylinder's radius was that of a lower, wider part of the shaft.  Draw 18 (tapered,
section low on the shaft) had them 1.4-2.6 cm too small, and draw 22 (fluted, tapered)
followed each section circle's own error: the band sits where the shaft is as wide as
the circle.  On draw 22 five columns were found in the low section, 0.2 m above the
base, about a shaft axis leaning by the taper angle (1.3 deg): the distances to it
taper the wrong way, and the window of the radius, cut by the base, moved the radius
by -1.5..-2.1 cm; the scorer compared them with the shaft 7 m higher (+15 cm).  The
fast tests build one column of draw 23's or draw 22's shaft (the generator's
:class:`ColumnShape`); the slow ones run the draws.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.geometry.fitting import fit_circle
from pyheracles.supports.primitives import column_shape, describe
from pyheracles.synthetic.families.supports_parts import ColumnShape

#: Draw 23's columns: radius at the bottom and top of the shaft, entasis, heights.
SHAFT = ColumnShape(0.992, 0.768, entasis_m=0.011)
SHAFT_Z = (0.03, 10.28)
CAPITAL_M = 0.5
NOISE = 0.004
TOL = 0.08  # the draw's surface tolerance (photogrammetry, 4 cm spacing)


def true_radius(z: float) -> float:
    """The shaft's radius at height ``z``."""
    return float(SHAFT.radius((z - SHAFT_Z[0]) / (SHAFT_Z[1] - SHAFT_Z[0])))


def column(seed: int = 0) -> np.ndarray:
    """Points of the column (4 mm noise), twice as dense on its +x side (one-sided
    views): the shaft, then a capital widening to 1.3 x the shaft's top radius."""
    rng = np.random.default_rng(seed)
    n = 40_000
    z = rng.uniform(*SHAFT_Z, n)
    a = rng.uniform(-np.pi, np.pi, n)
    keep = (np.cos(a) > 0) | (rng.random(n) < 0.5)
    z, a = z[keep], a[keep]
    r = np.array([true_radius(v) for v in z]) + rng.normal(0, NOISE, len(z))
    shaft = np.c_[r * np.cos(a), r * np.sin(a), z]
    m = 4000
    zc = rng.uniform(SHAFT_Z[1], SHAFT_Z[1] + CAPITAL_M, m)
    rc = SHAFT.radius_top_m * (1 + 0.3 * (zc - SHAFT_Z[1]) / CAPITAL_M)
    ac = rng.uniform(-np.pi, np.pi, m)
    capital = np.c_[rc * np.cos(ac), rc * np.sin(ac), zc]
    return np.vstack([shaft, capital])


def section(pts: np.ndarray, z: float, grow: float = 0.0) -> tuple[dict, np.ndarray]:
    """The section shape at ``z`` (circle of a 10 cm slab, ``grow`` added to its
    radius) and every point's offset from it."""
    slab = np.abs(pts[:, 2] - z) <= 0.05
    circle = fit_circle(pts[slab, :2])
    sh = {"class": "column", "centre": circle.center, "radius": circle.radius + grow}
    rho = np.hypot(*(pts[:, :2] - circle.center).T) - sh["radius"]
    return sh, rho


def test_radius_is_the_shafts_at_a_section_high_on_a_tapered_shaft() -> None:
    pts = column()
    z_sec = 0.85 * (SHAFT_Z[1] + CAPITAL_M)  # the section search's upper limit
    sh, rho = section(pts, z_sec)
    row = describe(pts, rho, sh, TOL, z_ref=z_sec)
    assert row["radius_height_m"] + row["z_min"] == pytest.approx(z_sec, abs=1e-9)
    assert abs(row["radius_m"] - true_radius(z_sec)) <= 0.003


def test_radius_is_the_shafts_at_a_section_low_on_a_tapered_shaft() -> None:
    pts = column(1)
    z_sec = 2.3
    sh, rho = section(pts, z_sec)
    row = describe(pts, rho, sh, TOL, z_ref=z_sec)
    assert abs(row["radius_m"] - true_radius(z_sec)) <= 0.003


def test_radius_does_not_follow_an_error_of_the_section_circle() -> None:
    pts = column(2)
    z_sec = 6.0
    for grow in (-0.015, 0.015):
        sh, rho = section(pts, z_sec, grow)
        row = describe(pts, rho, sh, 0.03, z_ref=z_sec)
        assert abs(row["radius_m"] - true_radius(z_sec)) <= 0.003, grow


#: Draw 22's columns: fluted (23 flutes 3.1 cm deep), tapered 1.243 -> 0.953 m.
FLUTED = ColumnShape(1.243, 0.953, flutes=23, flute_depth_m=0.0313)
FLUTED_Z = (0.0, 13.15)


def test_radius_low_on_a_fluted_shaft_about_an_axis_leaning_by_the_taper() -> None:
    rng = np.random.default_rng(22)
    n = 60_000
    z = rng.uniform(*FLUTED_Z, n)
    a = rng.uniform(-np.pi, np.pi, n)
    t = (z - FLUTED_Z[0]) / (FLUTED_Z[1] - FLUTED_Z[0])
    depth = FLUTED.flute_depth_m * np.sin(a * FLUTED.flutes / 2) ** 2
    r = FLUTED.radius(t) - depth + rng.normal(0, 0.003, n)
    pts = np.c_[r * np.cos(a), r * np.sin(a), z]

    def mean_radius(zz: float) -> float:  # flutes averaged
        return float(FLUTED.radius(zz / FLUTED_Z[1])) - FLUTED.flute_depth_m / 2

    slope = (FLUTED.radius_top_m - FLUTED.radius_bottom_m) / FLUTED_Z[1]
    lean = np.array([-slope, 0.0, 1.0]) / np.hypot(slope, 1.0)  # a cylinder's axis
    centre = np.array([0.0, 0.0, 3.0])  # draw 22: 5-7.5 cm off the shaft at its foot
    z_ref = 0.24
    out = column_shape(pts, centre, lean, mean_radius(6.5), 0.03, z_ref=z_ref)
    assert abs(out["radius_m"] - mean_radius(z_ref)) <= 0.003


#: Draw 0's aisle columns: r 0.197 -> 0.155 m over 3.6 m, entasis 1.6 mm.
AISLE = ColumnShape(0.197, 0.155, entasis_m=0.0016)
AISLE_Z = (0.17, 3.76)


def test_radius_of_a_column_seen_on_one_side_with_a_chair_touching_it() -> None:
    """Draw 0, column 20: 161 points in the window of its section (1.16 m), half of the
    shaft seen, and a pew's points 8 cm off its surface on the other side: a circle
    through them all moved its centre 3.6 cm towards the pew and gave +2.6 cm."""
    rng = np.random.default_rng(0)
    n = 1400
    z = rng.uniform(*AISLE_Z, n)
    a = np.deg2rad(rng.uniform(60.0, 240.0, n))
    t = (z - AISLE_Z[0]) / (AISLE_Z[1] - AISLE_Z[0])
    r = AISLE.radius(t) + rng.normal(0, 0.0035, n)
    shaft = np.c_[r * np.cos(a), r * np.sin(a), z]
    m = 40
    ap = np.deg2rad(rng.uniform(-60.0, 30.0, m))
    zp = rng.uniform(0.9, 1.4, m)
    rp = 0.27 + rng.normal(0, 0.0035, m)
    pew = np.c_[rp * np.cos(ap), rp * np.sin(ap), zp]
    pts = np.vstack([shaft, pew])
    z_ref = 1.16
    true = float(AISLE.radius((z_ref - AISLE_Z[0]) / (AISLE_Z[1] - AISLE_Z[0])))
    out = column_shape(pts, np.array([0.0, 0.0, 2.0]), np.array([0.0, 0.0, 1.0]), 0.18, 0.03,
                       z_ref=z_ref)  # fmt: skip
    assert abs(out["radius_m"] - true) <= 0.003


@pytest.mark.slow
def test_column_radii_within_1_cm_on_draw_22() -> None:
    """Draw 22 (nave, fluted and tapered shafts): the columns found in the low section
    too, their radii compared at that section."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate
    from pyheracles.synthetic.families.supports_score import score_supports

    sim = simulate("supports", 22)
    _, found, _, _ = segment_building(sim.clouds["cloud"].xyz)
    m = score_supports(sim, found.instance, found.objects, section_height=found.section_height)
    low = found.objects["z_min"] + found.objects["radius_height_m"] < found.section_height - 1
    assert low.sum() >= 3  # columns found in the low section
    assert len(m["radius_err_m"]) >= 25
    assert m["radius_err_max_m"] <= 0.01, m["radius_err_m"]


@pytest.mark.xfail(
    strict=True,
    reason=(
        "on the per-ray simulator's noise draw (issue 12/13 open): radii of 17 columns "
        "measured, not 20"
    ),
)
@pytest.mark.slow
def test_column_radii_within_1_cm_on_draw_33() -> None:
    """Draw 33 (tapered shafts, twins): column 12, a twin seen over about 90 deg with
    85 points in the window of its section and its axis 2.4 cm off, gave +4.5 cm when
    the cone started from the circle of the points near that axis (+12.8 cm before
    the radius was measured at the section)."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate
    from pyheracles.synthetic.families.supports_score import score_supports

    sim = simulate("supports", 33)
    _, found, _, _ = segment_building(sim.clouds["cloud"].xyz)
    m = score_supports(sim, found.instance, found.objects, section_height=found.section_height)
    assert len(m["radius_err_m"]) >= 20
    assert m["radius_err_max_m"] <= 0.01, m["radius_err_m"]


@pytest.mark.slow
def test_column_radii_within_1_cm_on_draw_23() -> None:
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate
    from pyheracles.synthetic.families.supports_score import score_supports

    sim = simulate("supports", 23)
    _, found, _, _ = segment_building(sim.clouds["cloud"].xyz)
    m = score_supports(sim, found.instance, found.objects, section_height=found.section_height)
    assert len(m["radius_err_m"]) >= 15
    assert m["radius_err_max_m"] <= 0.01, m["radius_err_m"]
    # the candidates are still checked with their section's cylinder: a 325-point
    # piece beside column 24 (0.31 m circle) is no column (it split column 24)
    assert "ring_split" not in m["failure_modes"]


@pytest.mark.slow
def test_thin_columns_judged_by_their_cylinders_on_draw_32() -> None:
    """Draw 32: an engaged column carrying nothing, 0.157 m as the cylinder of its
    section's shaft points and 0.148 m at its section, beside columns of 0.51 m: the
    rule for posts (0.3 x the carrying columns' radius) was set on the cylinders."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate

    sim = simulate("supports", 32)
    _, found, _, _ = segment_building(sim.clouds["cloud"].xyz)
    assert not any("thinner than" in n for n in found.notes), found.notes
