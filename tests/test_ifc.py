"""IFC export: one element per support / beam / wall, dimensions and surfaces match, valid."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("ifcopenshell")

import ifcopenshell
import ifcopenshell.geom
import ifcopenshell.util.element
import ifcopenshell.validate

from ifc_surface import surface_rms
from pyheracles.cloud import PointCloud
from pyheracles.export.ifc import export_ifc
from pyheracles.io.results import write_segmentation
from pyheracles.labels import Segmentation

OFFSET = np.array([651000.0, 6862000.0, 30.0])


def _cylinder(c, r, z0, z1, n=4000, rng=None):
    t = rng.uniform(0, 2 * np.pi, n)
    z = rng.uniform(z0, z1, n)
    return np.c_[c[0] + r * np.cos(t), c[1] + r * np.sin(t), z]


def _box_sides(c, a, b, ang, z0, z1, n=4000, rng=None):
    s = rng.uniform(-1, 1, n)
    side = rng.integers(0, 4, n)
    u = np.where(side < 2, s * a / 2, np.where(side == 2, a / 2, -a / 2))
    v = np.where(side >= 2, s * b / 2, np.where(side == 0, b / 2, -b / 2))
    R = np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
    xy = np.c_[u, v] @ R.T + c
    return np.c_[xy, rng.uniform(z0, z1, n)]


def _folder(tmp_path, step, xyz, inst, objects):
    cloud = PointCloud(xyz - OFFSET, offset=OFFSET, crs="EPSG:2154")
    seg = Segmentation(instance=inst, class_id=(inst > 0).astype(np.uint8),
                       classes={1: objects["class"].iloc[0]}, objects=objects)  # fmt: skip
    out = tmp_path / step
    write_segmentation(cloud, seg, out, step=step)
    return out


def _check(path, n_expected):
    ifc = ifcopenshell.open(str(path))
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(ifc, logger)
    errors = [s for s in logger.statements if s.get("level", "error") == "error"]
    assert not errors, errors[:3]
    assert len(ifc.by_type("IfcMapConversion")) == 1
    assert ifc.by_type("IfcProjectedCRS")[0].Name == "EPSG:2154"
    return ifc


def test_supports_to_ifc(tmp_path) -> None:
    rng = np.random.default_rng(0)
    col = _cylinder(OFFSET[:2] + [2.0, 3.0], 0.25, OFFSET[2], OFFSET[2] + 4.0, rng=rng)
    pier = _box_sides(OFFSET[:2] + [6.0, 3.0], 0.8, 0.5, 0.3, OFFSET[2], OFFSET[2] + 4.0,
                      rng=rng)  # fmt: skip
    xyz = np.vstack([col, pier])
    inst = np.r_[np.full(len(col), 1), np.full(len(pier), 2)].astype(np.int32)
    nan = np.nan
    objects = pd.DataFrame([
        {"instance": 1, "class": "column", "n_points": len(col), "x": OFFSET[0] + 2.0,
         "y": OFFSET[1] + 3.0, "z_min": OFFSET[2], "z_max": OFFSET[2] + 4.0, "height_m": 4.0,
         "radius_m": 0.25, "axis_x": 0.0, "axis_y": 0.0, "axis_z": 1.0, "box_length_m": nan,
         "box_width_m": nan, "box_height_m": nan, "fit_rms_m": 0.002, "circularity": 1.0},
        {"instance": 2, "class": "pier", "n_points": len(pier), "x": OFFSET[0] + 6.0,
         "y": OFFSET[1] + 3.0, "z_min": OFFSET[2], "z_max": OFFSET[2] + 4.0, "height_m": 4.0,
         "radius_m": nan, "axis_x": nan, "axis_y": nan, "axis_z": nan, "box_length_m": 0.8,
         "box_width_m": 0.5, "box_height_m": 4.0, "fit_rms_m": 0.003, "circularity": 1.3},
    ])  # fmt: skip
    folder = _folder(tmp_path, "supports", xyz, inst, objects)
    rep = export_ifc(folder, tmp_path / "model.ifc")
    assert rep.elements == {"IfcColumn": 2}
    ifc = _check(tmp_path / "model.ifc", 2)
    for i, pts in ((1, col), (2, pier)):
        el = ifc.by_guid(rep.guids[i])
        props = ifcopenshell.util.element.get_psets(el)["Heracles_Provenance"]
        assert props["instance"] == i and props["n_points"] == len(pts)
        assert surface_rms(ifc, rep.guids[i], pts, 200_000) < 0.01
    solid = ifc.by_guid(rep.guids[1]).Representation.Representations[0].Items[0]
    assert abs(solid.SweptArea.Radius - 0.25) < 1e-3 and abs(solid.Depth - 4.0) < 1e-3
    solid = ifc.by_guid(rep.guids[2]).Representation.Representations[0].Items[0]
    assert abs(solid.SweptArea.XDim - 0.8) < 1e-3 and abs(solid.SweptArea.YDim - 0.5) < 1e-3


def test_beam_to_ifc(tmp_path) -> None:
    rng = np.random.default_rng(0)
    axis = np.array([np.cos(0.4), np.sin(0.4), 0.0])
    e1 = np.array([-np.sin(0.4), np.cos(0.4), 0.0])
    e2 = np.array([0.0, 0.0, 1.0])
    c = OFFSET + [3.0, 2.0, 5.0]
    n = 6000
    t = rng.uniform(-2.0, 2.0, n)
    side = rng.integers(0, 4, n)
    s = rng.uniform(-1, 1, n)
    a, b = 0.12 / 2, 0.2 / 2  # width, height
    p1 = np.where(side < 2, s * a, np.where(side == 2, a, -a))
    p2 = np.where(side >= 2, s * b, np.where(side == 0, b, -b))
    pts = c + t[:, None] * axis + p1[:, None] * e1 + p2[:, None] * e2
    objects = pd.DataFrame([{
        "instance": 1, "class": "beam", "n_points": n, "n_facets": 4, "centre_x": c[0],
        "centre_y": c[1], "centre_z": c[2], "axis_x": axis[0], "axis_y": axis[1],
        "axis_z": 0.0, "inclination_deg": 0.0, "length_m": 4.0, "width_m": 0.12,
        "height_m": 0.2, "rms_m": 0.002}])  # fmt: skip
    folder = _folder(tmp_path, "beams", pts, np.ones(n, dtype=np.int32), objects)
    rep = export_ifc(folder, tmp_path / "beam.ifc")
    assert rep.elements == {"IfcBeam": 1}
    ifc = _check(tmp_path / "beam.ifc", 1)
    solid = ifc.by_guid(rep.guids[1]).Representation.Representations[0].Items[0]
    assert abs(solid.Depth - 4.0) < 1e-3
    assert abs(solid.SweptArea.XDim - 0.12) < 1e-3 and abs(solid.SweptArea.YDim - 0.2) < 1e-3
    assert surface_rms(ifc, rep.guids[1], pts, 200_000) < 0.01


def test_tapered_column_is_a_solid_of_revolution(tmp_path) -> None:
    """A column tapering from 0.30 m to 0.22 m with entasis: revolved, within 1 cm."""
    rng = np.random.default_rng(4)
    n, h = 12000, 4.5
    z = rng.uniform(0, h, n)
    s = z / h
    r = 0.30 - 0.08 * s + 0.012 * np.sin(np.pi * s)  # taper with a slight swelling
    t = rng.uniform(0, 2 * np.pi, n)
    c = OFFSET[:2] + [3.0, 1.0]
    col = np.c_[c[0] + r * np.cos(t), c[1] + r * np.sin(t), OFFSET[2] + z]
    col += rng.normal(0, 0.001, col.shape)
    objects = pd.DataFrame([
        {"instance": 1, "class": "column", "n_points": n, "x": c[0], "y": c[1],
         "z_min": OFFSET[2], "z_max": OFFSET[2] + h, "height_m": h, "radius_m": 0.265,
         "axis_x": 0.0, "axis_y": 0.0, "axis_z": 1.0, "box_length_m": np.nan,
         "box_width_m": np.nan, "box_height_m": np.nan, "fit_rms_m": 0.02, "circularity": 1.0},
    ])  # fmt: skip
    folder = _folder(tmp_path, "supports", col, np.ones(n, np.int32), objects)
    rep = export_ifc(folder, tmp_path / "model.ifc")
    ifc = _check(tmp_path / "model.ifc", 1)
    el = ifc.by_guid(rep.guids[1])
    assert el.Representation.Representations[0].Items[0].is_a("IfcRevolvedAreaSolid")
    props = ifcopenshell.util.element.get_psets(el)["Heracles_Provenance"]
    assert abs(props["radius_base_m"] - 0.30) < 0.006 and abs(props["radius_top_m"] - 0.22) < 0.006
    assert surface_rms(ifc, rep.guids[1], col, 200_000) < 0.005
    # the straight column of test_supports_to_ifc stays an extruded circle (covered there)
