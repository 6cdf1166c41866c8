"""IFC export of what the supports and roof families showed (benchmarks/bench_ifc.py).

Each test rebuilds, with synthetic points, one failure seen on a family draw: a column
whose fitted axis is tilted (the table's axis point is at the fit's mid-height), a
tapered column with a plinth and a capital, a member seen on two faces only, a pier
seen on its short face only.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("ifcopenshell")

import ifcopenshell
import ifcopenshell.geom

from ifc_surface import surface_rms
from pyheracles.cloud import PointCloud
from pyheracles.export.element_shapes import section_roll, surface_radius
from pyheracles.export.ifc import export_ifc
from pyheracles.io.results import write_segmentation
from pyheracles.labels import Segmentation

OFFSET = np.array([651000.0, 6862000.0, 30.0])
NAN = np.nan


def _export(tmp_path, step, xyz, objects):
    inst = np.ones(len(xyz), dtype=np.int32)
    cloud = PointCloud(xyz - OFFSET, offset=OFFSET, crs="EPSG:2154")
    seg = Segmentation(instance=inst, class_id=inst.astype(np.uint8),
                       classes={1: objects["class"].iloc[0]}, objects=objects)  # fmt: skip
    write_segmentation(cloud, seg, tmp_path / step, step=step)
    rep = export_ifc(tmp_path / step, tmp_path / "m.ifc")
    return ifcopenshell.open(str(tmp_path / "m.ifc")), rep


def _column_row(x, y, z0, h, r, axis, n):
    return {"instance": 1, "class": "column", "n_points": n, "x": x, "y": y, "z_min": z0,
            "z_max": z0 + h, "height_m": h, "radius_m": r, "axis_x": axis[0],
            "axis_y": axis[1], "axis_z": axis[2], "box_length_m": NAN, "box_width_m": NAN,
            "box_height_m": NAN, "fit_rms_m": 0.002, "circularity": 1.0}  # fmt: skip


def test_tilted_column_axis_through_its_points(tmp_path) -> None:
    """supports seed 0: a 2-degree axis whose table point is at mid-height, not at z_min."""
    rng = np.random.default_rng(3)
    n, h, r = 8000, 4.0, 0.2
    axis = np.array([np.sin(np.radians(2.0)), 0.0, np.cos(np.radians(2.0))])
    u, v = np.array([0.0, 1.0, 0.0]), np.cross(axis, [0.0, 1.0, 0.0])
    t = rng.uniform(0, 2 * np.pi, n)
    s = rng.uniform(0, h / axis[2], n)
    foot = OFFSET + [2.0, 3.0, 0.0]
    pts = foot + np.outer(s, axis) + r * (np.outer(np.cos(t), u) + np.outer(np.sin(t), v))
    pts += rng.normal(0, 0.001, pts.shape)
    mid = foot + 0.5 * h / axis[2] * axis  # the fit's axis point (x, y), at mid-height
    z0 = float(pts[:, 2].min())
    row = _column_row(mid[0], mid[1], z0, float(np.ptp(pts[:, 2])), r, axis, n)
    ifc, rep = _export(tmp_path, "supports", pts, pd.DataFrame([row]))
    # 5 cm when placed through (x, y) at z_min
    assert surface_rms(ifc, rep.guids[1], pts, 300_000) < 0.004


def test_tapered_column_with_plinth_and_capital(tmp_path) -> None:
    """supports seeds 0 and 7: plinth and capital points made the revolved profile a cone
    (a slice's median) or a drum (its densest ring: the abacus's sides)."""
    rng = np.random.default_rng(5)
    h, c = 3.9, OFFSET[:2] + [3.0, 1.0]
    z = rng.uniform(0.17, 3.76, 20000)
    r = 0.20 - 0.05 * (z - 0.17) / 3.59  # 0.20 m at the foot of the shaft, 0.15 at the top
    t = rng.uniform(0, 2 * np.pi, len(z))
    shaft = np.c_[c[0] + r * np.cos(t), c[1] + r * np.sin(t), OFFSET[2] + z]
    plinth = np.c_[c + rng.uniform(-0.45, 0.45, (12000, 2)), OFFSET[2] + np.full(12000, 0.11)]
    capital = np.c_[c + rng.uniform(-0.28, 0.28, (4000, 2)), OFFSET[2] + np.full(4000, 3.76)]
    # the abacus's sides, seen more densely than the shaft (a peak of distances at 0.28 m)
    side = rng.uniform(-0.28, 0.28, 12000)
    sq = np.where(rng.random(12000)[:, None] < 0.5, np.c_[side, np.full(12000, 0.28)],
                  np.c_[np.full(12000, 0.28), side]) * rng.choice([-1, 1], (12000, 1))  # fmt: skip
    abacus = np.c_[c + sq, OFFSET[2] + rng.uniform(3.76, 3.9, 12000)]
    pts = np.vstack([shaft, plinth, capital, abacus]) + rng.normal(0, 0.001, (48000, 3))
    row = _column_row(c[0], c[1], OFFSET[2] + 0.11, h - 0.11, 0.175, (0, 0, 1), len(pts))
    ifc, rep = _export(tmp_path, "supports", pts, pd.DataFrame([row]))
    item = ifc.by_guid(rep.guids[1]).Representation.Representations[0].Items[0]
    assert item.is_a("IfcRevolvedAreaSolid")
    ring = np.array([p.Coordinates for p in item.SweptArea.OuterCurve.Points])[1:-2]
    assert abs(ring[1:-1, 0].mean() - 0.175) < 1e-3  # agrees with the table's radius
    # the plinth made a cone of its lowest slice
    assert surface_rms(ifc, rep.guids[1], shaft, 300_000) < 0.004


def test_surface_radius_ignores_a_moulding() -> None:
    rng = np.random.default_rng(0)
    d = np.r_[0.2 + rng.normal(0, 0.002, 3000), rng.uniform(0.2, 0.6, 6000)]
    r, sd = surface_radius(d, 0.01)
    assert abs(r - 0.2) < 0.002 and sd < 0.004
    assert float(np.median(d)) > 0.29  # what the median of the slice said


def _member(axis, e1, e2, w, hgt, length, faces, n, rng):
    t = rng.uniform(-length / 2, length / 2, n)
    side = rng.choice(faces, n)
    s = rng.uniform(-1, 1, n)
    a, b = w / 2, hgt / 2
    p1 = np.where(side < 2, s * a, np.where(side == 2, a, -a))
    p2 = np.where(side >= 2, s * b, np.where(side == 0, b, -b))
    return np.outer(t, axis) + np.outer(p1, e1) + np.outer(p2, e2)


def test_member_seen_on_two_faces(tmp_path) -> None:
    """roof seed 0: rafters seen on their top and one side were turned by the points'
    bounding rectangle (2.7 cm RMS); the rectangle's own fit places them."""
    rng = np.random.default_rng(2)
    pitch = np.radians(38.0)
    axis = np.array([0.0, np.cos(pitch), np.sin(pitch)])
    e1 = np.array([1.0, 0.0, 0.0])  # horizontal across the rafter
    e2 = np.cross(axis, e1)
    c = OFFSET + [1.0, 2.0, 3.0]
    pts = c + _member(axis, e1, e2, 0.21, 0.30, 3.2, [0, 2], 6000, rng)  # top + one side
    pts += rng.normal(0, 0.002, pts.shape)
    row = {"instance": 1, "class": "beam", "n_points": len(pts), "n_facets": 2,
           "centre_x": c[0], "centre_y": c[1], "centre_z": c[2], "axis_x": axis[0],
           "axis_y": axis[1], "axis_z": axis[2], "inclination_deg": 38.0, "length_m": 3.2,
           "width_m": 0.21, "height_m": 0.30, "rms_m": 0.002, "faces_seen": 2,
           "height_measured": True, "role": "rafter"}  # fmt: skip
    ifc, rep = _export(tmp_path, "beams", pts, pd.DataFrame([row]))
    assert surface_rms(ifc, rep.guids[1], pts, 300_000) < 0.004


def test_section_roll_of_a_rolled_section() -> None:
    rng = np.random.default_rng(4)
    roll = np.radians(12.0)
    q = _member(np.zeros(3), np.array([np.cos(roll), np.sin(roll), 0.0]),
                np.array([-np.sin(roll), np.cos(roll), 0.0]), 0.16, 0.24, 1.0, [0, 1, 2],
                3000, rng)[:, :2]  # fmt: skip
    a = section_roll(q + rng.normal(0, 0.002, q.shape), 0.16, 0.24)
    assert abs(np.degrees(a) - 12.0) < 0.5


def test_pier_seen_on_its_short_face(tmp_path) -> None:
    """A pier 0.8 x 0.5 m seen on one 0.5 m face: its length is across that face."""
    rng = np.random.default_rng(6)
    yaw = 0.3
    length_dir = np.array([np.cos(yaw), np.sin(yaw)])
    across = np.array([-np.sin(yaw), np.cos(yaw)])
    c = OFFSET[:2] + [5.0, 4.0]
    s = rng.uniform(-0.25, 0.25, 5000)
    xy = c + 0.4 * length_dir + np.outer(s, across)  # the short face, 0.4 m from the centre
    pts = np.c_[xy, OFFSET[2] + rng.uniform(0, 3.0, 5000)] + rng.normal(0, 0.001, (5000, 3))
    row = {"instance": 1, "class": "pier", "n_points": 5000, "x": c[0], "y": c[1],
           "z_min": OFFSET[2], "z_max": OFFSET[2] + 3.0, "height_m": 3.0, "radius_m": NAN,
           "axis_x": NAN, "axis_y": NAN, "axis_z": NAN, "box_length_m": 0.8,
           "box_width_m": 0.5, "box_height_m": 3.0, "fit_rms_m": 0.002,
           "circularity": 1.3}  # fmt: skip
    ifc, rep = _export(tmp_path, "supports", pts, pd.DataFrame([row]))
    # 15 cm when its length ran along the face
    assert surface_rms(ifc, rep.guids[1], pts, 300_000) < 0.004
