"""Tests of step 2b: beams of timber frameworks with fitted cuboids."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest

from pyheracles.beams import (
    BeamCuboid,
    BeamParams,
    StraightFacet,
    fit_beam_cuboid,
    segment_beams,
    split_facet,
)
from pyheracles.beams.cuboids import collinear
from pyheracles.errors import InputError
from pyheracles.synthetic.truss import Beam, TrussParams, make_truss_roof, scan_boxes


def _match(pred: np.ndarray, truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For every reference beam: best predicted beam and its F1."""
    m = np.zeros((pred.max() + 1, truth.max() + 1), dtype=np.int64)
    np.add.at(m, (pred, truth), 1)
    best = m[1:, 1:].argmax(axis=0) + 1
    tp = m[best, np.arange(1, truth.max() + 1)]
    prec = tp / np.maximum(m[best].sum(axis=1), 1)
    rec = tp / m[:, 1:].sum(axis=0)
    f1 = np.where(tp > 0, 2 * prec * rec / np.maximum(prec + rec, 1e-12), 0.0)
    return best, f1


@pytest.fixture(scope="module")
def roof():
    return make_truss_roof(TrussParams(n_points=100_000), rng=3)


@pytest.fixture(scope="module")
def roof_result(roof):
    return segment_beams(roof.xyz)


def test_generator_has_ground_truth(roof):
    assert len(roof.beams) == 15
    assert roof.xyz.shape == (len(roof.labels), 3)
    assert set(np.unique(roof.labels)) == set(range(1, 16))  # every beam is seen
    names = {re.sub(r"\d*[lr]?$", "", b.name) for b in roof.beams}
    assert names == {"tie", "rafter", "king_post", "strut", "ridge", "purlin"}
    # oblique members: rafters at the pitch, struts neither vertical nor horizontal
    incl = [np.degrees(np.arcsin(abs(b.axis[2]))) for b in roof.beams]
    assert sum(10 < a < 80 for a in incl) >= 8
    # noise: points lie within a few sigma of their beam's surface
    b = roof.beams[0]
    local = (roof.xyz[roof.labels == 1] - b.centre) @ b.rotation
    d = np.min(np.abs(np.abs(local) - b.half_extents), axis=1)
    assert np.sqrt(np.mean(d**2)) < 0.006


def test_truss_beams_count_f1_and_cuboids(roof, roof_result):
    res = roof_result
    assert len(res.beams) == len(roof.beams)
    best, f1 = _match(res.labels, roof.labels)
    assert len(np.unique(best)) == len(roof.beams)  # one-to-one
    assert np.median(f1) >= 0.95
    assert f1.min() >= 0.8
    for j, tb in enumerate(roof.beams):
        cub = res.beams[best[j] - 1]
        ang = np.degrees(np.arccos(min(1.0, abs(cub.axis @ tb.axis))))
        assert ang < 1.0, tb.name
        dims = {}
        for vec, val in ((cub.axes[:, 1], cub.width), (cub.axes[:, 2], cub.height)):
            key = "w" if abs(vec @ tb.side) > abs(vec @ tb.up) else "h"
            dims[key] = val
        assert abs(dims["w"] - tb.width) < 0.01, tb.name
        assert abs(dims["h"] - tb.height) < 0.01, tb.name
        assert cub.rms < 0.02


def test_result_is_a_balanced_segmentation(roof, roof_result):
    seg = roof_result.to_segmentation(offset=[1000.0, 2000.0, 10.0])
    counts = seg.check_balance()
    assert counts["total"] == len(roof.xyz)
    assert counts["objects"] + counts["remainder"] == counts["total"]
    table = seg.objects
    assert (table["class"] == "beam").all()
    for col in ("axis_x", "axis_y", "axis_z", "length_m", "width_m", "height_m", "rms_m"):
        assert col in table.columns
    assert table["centre_x"].min() > 999.0  # offset applied


def _l_facet(width1: float, width2: float, noise: float, rng: np.random.Generator):
    """An L-shaped planar facet: two bands meeting at a corner, in the plane z = 0."""
    a = rng.uniform([0, 0], [2.0, width1], size=(8000, 2))
    b = rng.uniform([0, 0], [width2, 1.5], size=(6000, 2))
    pts = np.vstack([a, b])
    xyz = np.column_stack([pts, rng.normal(scale=noise, size=len(pts))])
    truth = np.concatenate([np.ones(len(a), int), np.full(len(b), 2)])
    return xyz, truth


def test_split_facet_cuts_l_shape_and_measures_widths():
    rng = np.random.default_rng(0)
    xyz, truth = _l_facet(0.16, 0.22, 0.002, rng)
    facets = split_facet(xyz, np.arange(len(xyz)), BeamParams(), spacing_m=0.01, rng=rng)
    assert len(facets) == 2
    widths = sorted(f.width for f in facets)
    assert widths[0] == pytest.approx(0.16, abs=0.01)
    assert widths[1] == pytest.approx(0.22, abs=0.01)
    for f in facets:
        purity = np.bincount(truth[f.index]).max() / len(f.index)
        assert purity > 0.9
        assert abs(f.normal[2]) > 0.999


def test_cuboid_from_two_faces_only():
    """A beam seen on two adjacent faces: the cross-section still comes out right."""
    rng = np.random.default_rng(1)
    length, w, h = 3.0, 0.14, 0.2
    side = rng.uniform([0, 0], [length, h], size=(6000, 2))
    bottom = rng.uniform([0, 0], [length, w], size=(5000, 2))
    p_side = np.column_stack([side[:, 0], np.zeros(6000), side[:, 1]])
    p_bot = np.column_stack([bottom[:, 0], bottom[:, 1], np.zeros(5000)])
    xyz = np.vstack([p_side, p_bot]) + rng.normal(scale=0.003, size=(11000, 3))
    rot = np.array([[0.8, -0.6, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])
    xyz = xyz @ rot.T
    facets = [
        StraightFacet(np.arange(6000), rot @ [0, 1.0, 0], rot @ [1.0, 0, 0],
                      xyz[:6000].mean(0), h, length, 0.003, 1),
        StraightFacet(np.arange(6000, 11000), np.array([0, 0, 1.0]), rot @ [1.0, 0, 0],
                      xyz[6000:].mean(0), w, length, 0.003, 2),
    ]  # fmt: skip
    cub = fit_beam_cuboid(xyz, facets, bin_m=0.005)
    assert np.degrees(np.arccos(min(1.0, abs(cub.axis @ (rot @ [1.0, 0, 0]))))) < 0.5
    assert cub.width == pytest.approx(w, abs=0.01)
    assert cub.height == pytest.approx(h, abs=0.01)
    assert cub.length == pytest.approx(length, abs=0.05)


def test_cuboid_side_without_facet_is_located_by_its_few_points():
    """A side seen by too few points for a facet: its points fix it, not the scan
    lines of the adjacent faces (whose last line can be a line spacing inside)."""
    rng = np.random.default_rng(5)
    length, w, h = 3.0, 0.14, 0.2
    lines_z = np.arange(-h / 2 + 0.012, h / 2, 0.008)  # scan lines across the side faces
    xs = rng.uniform(0, length, size=(2, len(lines_z), 300))
    sides = [
        np.column_stack([xs[i].ravel(), np.full(xs[i].size, y),
                         np.repeat(lines_z, 300)])
        for i, y in enumerate((-w / 2, w / 2))
    ]  # fmt: skip
    top = np.column_stack(
        [rng.uniform(0, length, 4000), rng.uniform(-w / 2, w / 2, 4000), np.full(4000, h / 2)]
    )
    xyz = np.vstack(sides + [top])
    xyz += rng.normal(scale=0.002, size=xyz.shape)
    n1, n2 = len(sides[0]), len(sides[1])
    ax = np.array([1.0, 0, 0])
    facets = [
        StraightFacet(np.arange(n1), np.array([0, -1.0, 0]), ax, xyz[:n1].mean(0), h, length,
                      0.002, 1),
        StraightFacet(np.arange(n1, n1 + n2), np.array([0, 1.0, 0]), ax,
                      xyz[n1:n1 + n2].mean(0), h, length, 0.002, 2),
        StraightFacet(np.arange(n1 + n2, len(xyz)), np.array([0, 0, 1.0]), ax,
                      xyz[n1 + n2:].mean(0), w, length, 0.002, 3),
    ]  # fmt: skip
    bottom = np.column_stack(
        [rng.uniform(0, length, 40), rng.uniform(-w / 2, w / 2, 40), np.full(40, -h / 2)]
    ) + rng.normal(scale=0.002, size=(40, 3))
    # a crossing beam's vertical face below the bottom fills the search window evenly
    crossing = np.column_stack(
        [
            np.full(200, 1.5),
            rng.uniform(-w / 2, w / 2, 200),
            rng.uniform(-h / 2 - 0.04, -h / 2, 200),
        ]
    )
    # the ends of three beams resting on this one: thin layers 1 cm below, in
    # three spots along the beam (24 points on one plane, as in a truss's tie beam
    # under its rafter feet and king post)
    ends = np.vstack(
        [
            np.column_stack(
                [
                    rng.uniform(x, x + 0.05, 8),
                    rng.uniform(-w / 2 + 0.02, w / 2 - 0.02, 8),
                    np.full(8, -h / 2 - 0.01),
                ]
            )
            for x in (0.1, 1.5, 2.9)
        ]
    ) + rng.normal(scale=0.001, size=(24, 3))
    without = fit_beam_cuboid(xyz, facets, bin_m=0.005, free=np.empty((0, 3)))
    with_face = fit_beam_cuboid(xyz, facets, bin_m=0.005, free=bottom)
    with_crossing = fit_beam_cuboid(xyz, facets, bin_m=0.005, free=crossing)
    with_ends = fit_beam_cuboid(xyz, facets, bin_m=0.005, free=ends)
    dims = {"plain": without, "face": with_face, "crossing": with_crossing, "ends": with_ends}
    heights = {k: c.height if abs(c.axes[2, 2]) > 0.9 else c.width for k, c in dims.items()}
    assert abs(heights["plain"] - h) > 0.006  # the last scan line is 1.2 cm inside
    assert heights["face"] == pytest.approx(h, abs=0.003)
    assert heights["crossing"] == pytest.approx(heights["plain"], abs=0.001)
    assert heights["ends"] == pytest.approx(heights["plain"], abs=0.001)


def _cuboid(centre, width, length=2.0, height=0.18):
    axes = np.column_stack([[0.0, 0.6, 0.8], [1.0, 0, 0], [0.0, 0.8, -0.6]])
    return BeamCuboid(np.asarray(centre, float), axes, length, width, height, 0.003, 2)


def test_collinear_pieces_merge_when_one_side_was_not_seen():
    """A piece whose far side was shadowed has a short width but lies inside the
    other piece's section: one beam.  A parallel beam beside it is another."""
    ax = np.array([0.0, 0.6, 0.8])
    full = _cuboid([0.0, 0, 0], 0.16)
    # shares the +x face, 7.6 cm wide instead of 16, 30 cm further along the axis
    partial = _cuboid([0.08 - 0.038, 0, 0] + 2.3 * ax, 0.076)
    beside = _cuboid([0.25, 0, 0] + 2.3 * ax, 0.16)
    thin_beside = _cuboid([0.16, 0, 0] + 2.3 * ax, 0.076)
    cos_par = np.cos(np.radians(5.0))
    assert collinear(full, partial, cos_par, 1.0)
    assert collinear(partial, full, cos_par, 1.0)
    assert not collinear(full, beside, cos_par, 1.0)
    assert not collinear(full, thin_beside, cos_par, 1.0)
    far = replace(partial, centre=partial.centre + 1.0 * ax)
    assert not collinear(full, far, cos_par, 1.0)  # 1.3 m gap


def test_strut_face_behind_post_does_not_bite_the_post():
    """Three-truss roof, noise seed 5: a strut's face 3 cm behind the king post's
    face (one region) once took a diagonal strip of the post's points, so the post
    came out of 2 facets, 7.6 cm wide (F1 0.70)."""
    roof = make_truss_roof(TrussParams(n_trusses=3, n_scanners=3, n_points=300_000), rng=5)
    res = segment_beams(roof.xyz)
    assert len(res.beams) == len(roof.beams)
    best, f1 = _match(res.labels, roof.labels)
    assert len(np.unique(best)) == len(roof.beams)
    for j, tb in enumerate(roof.beams):
        cub = res.beams[best[j] - 1]
        assert f1[j] >= 0.9, tb.name
        sizes = sorted([cub.width, cub.height])
        assert sizes == pytest.approx(sorted([tb.width, tb.height]), abs=0.01), tb.name


def _single_beam_scan(rng):
    beam = Beam("one", np.array([0.0, 0.0, 3.0]), np.array([1.0, 0, 0]),
                np.array([0, 0, 1.0]), 4.0, 0.16, 0.2)  # fmt: skip
    parts = [scan_boxes([beam], np.array(s), np.radians(0.12))[0]
             for s in ([-1.0, -2.0, 1.5], [1.5, 2.0, 1.5])]  # fmt: skip
    xyz = np.vstack(parts)
    return beam, xyz + rng.normal(scale=0.003, size=xyz.shape)


def test_single_beam_and_duplicated_points():
    rng = np.random.default_rng(2)
    beam, xyz = _single_beam_scan(rng)
    res = segment_beams(xyz)
    assert len(res.beams) == 1
    cub = res.beams[0]
    assert abs(cub.axis @ beam.axis) > np.cos(np.radians(1.0))
    assert sorted([cub.width, cub.height]) == pytest.approx([0.16, 0.2], abs=0.01)
    assert (res.labels == 1).mean() > 0.95
    # every point given twice: same beam, duplicates labelled like their originals
    dup = np.vstack([xyz, xyz])
    res2 = segment_beams(dup)
    assert len(res2.beams) == 1
    n = len(xyz)
    assert np.array_equal(res2.labels[:n], res2.labels[n:])
    assert res2.beams[0].width == pytest.approx(cub.width, abs=0.005)


def test_unoriented_normals_do_not_matter():
    """Region growing compares |cos|: flipping normals changes nothing."""
    from pyheracles.geometry.neighbours import estimate_normals, knn
    from pyheracles.segment.regiongrow import grow_on_graph

    rng = np.random.default_rng(4)
    _, xyz = _single_beam_scan(rng)
    normals, curv = estimate_normals(xyz, k=24)
    _, idx = knn(xyz, 16)
    src = np.repeat(np.arange(len(xyz)), 15)
    dst = idx[:, 1:].ravel()
    kw = dict(angle_deg=12.0, curvature_max=0.05, residual_m=0.012, min_size=50)
    a = grow_on_graph(src, dst, xyz, normals, curv, **kw)
    flip = np.where(rng.random(len(xyz)) < 0.5, -1.0, 1.0)[:, None]
    b = grow_on_graph(src, dst, xyz, normals * flip, curv, **kw)
    assert np.array_equal(a, b)
    assert a.max() >= 3  # the visible faces


def test_no_planar_facets_gives_clear_error_or_no_beams():
    rng = np.random.default_rng(5)
    blob = rng.normal(size=(5000, 3))  # volumetric noise: no surface at all
    with pytest.raises(InputError, match="no planar facet"):
        segment_beams(blob)
    # a smooth sphere: one curved region, no straight facet -> zero beams, all remainder
    v = rng.normal(size=(20000, 3))
    sphere = v / np.linalg.norm(v, axis=1, keepdims=True)
    res = segment_beams(sphere)
    assert len(res.beams) == 0
    assert np.all(res.labels == 0)
    assert res.to_segmentation().check_balance()["remainder"] == 20000


def test_bad_input():
    with pytest.raises(InputError, match="NaN"):
        segment_beams(np.full((1000, 3), np.nan))
    with pytest.raises(InputError, match="at least"):
        segment_beams(np.zeros((10, 3)))
    with pytest.raises(InputError, match="min_beam_width_m"):
        BeamParams(min_beam_width_m=0.5, max_beam_width_m=0.1).validate()


def test_cli_beams_writes_outputs(tmp_path, roof):
    import laspy
    import pandas as pd

    from pyheracles.cli import main
    from pyheracles.cloud import PointCloud
    from pyheracles.io import write_cloud

    sub = np.random.default_rng(0).random(len(roof.xyz)) < 0.6
    cloud = PointCloud.from_world(roof.xyz[sub] + [500000.0, 5400000.0, 120.0])
    src = tmp_path / "roof.laz"
    write_cloud(cloud, src)
    out = tmp_path / "beams"
    assert main(["beams", str(src), "-o", str(out), "--ifc"]) == 0
    import ifcopenshell

    ifc = ifcopenshell.open(str(out / "model.ifc"))
    assert len(ifc.by_type("IfcBeam")) + len(ifc.by_type("IfcMember")) == 15
    # the frame analysis's roles choose the IFC class and type (rafters are IfcMember RAFTER)
    from pyheracles.export.ifc import ROLE_TO_IFC

    roles = pd.read_csv(out / "objects.csv").set_index("instance")["role"]
    for el in ifc.by_type("IfcBeam") + ifc.by_type("IfcMember"):
        role = roles.loc[int(el.Name.split()[-1])]
        assert (el.is_a(), el.PredefinedType) == ROLE_TO_IFC[role]
    las = laspy.read(out / "segmented.laz")
    assert len(las.points) == int(sub.sum())
    table = pd.read_csv(out / "objects.csv")
    assert len(table) == 15 and set(table["class"]) == {"beam"}
    assert np.bincount(np.asarray(las["instance"]))[1:].sum() == table["n_points"].sum()
    assert (out / "beams.png").stat().st_size > 10_000
    assert (out / "run.json").exists()
    # bad input: a missing file is exit code 2, not a traceback
    assert main(["beams", str(tmp_path / "missing.laz"), "-o", str(tmp_path / "x")]) == 2
