"""Tests of the frame as a structure: joints, graph, roles, deflection and twist."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from member_points import surface_points
from pyheracles.beams import BeamCuboid, BeamParams, BeamResult
from pyheracles.beams.deflection import ShapeParams, member_shape, member_shapes
from pyheracles.beams.frame import FrameParams, analyse_frame
from pyheracles.beams.joints import JointParams, closest_points, components, find_joints
from pyheracles.beams.roles import guess_roles, roof_directions
from pyheracles.errors import InputError
from pyheracles.synthetic.families.roof_frame import (
    Member,
    RoofLevels,
    build_frame,
    draw_sections,
    member_between,
)
from pyheracles.synthetic.families.roof_truth import find_joints as true_joints

Z = np.array([0.0, 0.0, 1.0])


def _cuboid(m: Member) -> BeamCuboid:
    """The straight cuboid of a member's chord (what a fit of a bent beam gives)."""
    axes = np.column_stack([m.axis, m.side, m.up])
    return BeamCuboid(m.centre, axes, m.length, m.width, m.height, 0.003, 2)


def _rafter(deflection: float = 0.0, twist: float = 0.0) -> Member:
    up = np.array([0.0, -0.5, 1.0]) / np.linalg.norm([0.0, -0.5, 1.0])
    m = member_between("r", "rafter", [0, 0, 0.0], [0, 3.0, 1.5], 0.12, 0.16, up)
    return replace(m, deflection_m=deflection, twist_deg=twist)


@pytest.mark.parametrize(("sag", "twist"), [(0.0, 0.0), (0.005, 0.0), (0.03, 0.0), (0.015, 3.0)])
def test_deflection_and_twist_of_a_bent_beam(sag, twist):
    rng = np.random.default_rng(1)
    m = _rafter(sag, twist)
    pts = surface_points(m, 20_000, 0.003, rng)
    cub = _cuboid(m)
    own = np.abs(cub.signed_distance(pts)) < 0.01  # the straight cuboid's labels
    if sag >= 0.02:
        assert own.mean() < 0.9  # the middle of the beam is not in the straight labels
    sh = member_shape(pts, cub, own)
    assert sh.deflection_m == pytest.approx(sag, abs=0.0015)
    # the truth turns the section about -axis (side towards up); ours is right-handed
    assert sh.twist_deg == pytest.approx(-twist, abs=0.6)
    assert sh.coverage > 0.95 and sh.centreline_rms_m < 0.002
    if sag > 0:
        # a rafter sags along -up
        assert sh.direction @ -m.up > 0.95
    assert sh.n_points > 0.95 * len(pts)


def test_deflection_of_a_partly_seen_beam_and_too_few_points():
    rng = np.random.default_rng(2)
    m = _rafter(0.02)
    pts = surface_points(m, 20_000, 0.003, rng)
    local = (pts - m.centre) @ m.side
    seen = local < 0.0  # the +side face and half the others hidden
    cub = _cuboid(m)
    sh = member_shape(pts[seen], cub, np.abs(cub.signed_distance(pts[seen])) < 0.01)
    assert sh.deflection_m == pytest.approx(0.02, abs=0.002)
    one_face = local < -0.5 * m.width + 0.005  # only the -side face: the sag runs in its plane
    sh1 = member_shape(pts[one_face], cub, np.ones(int(one_face.sum()), bool))
    assert np.isnan(sh1.deflection_m) and "one direction" in sh1.note
    few = member_shape(pts[:30], cub, np.ones(30, bool))
    assert np.isnan(few.deflection_m) and few.note
    none = member_shape(pts, cub, np.zeros(len(pts), bool))
    assert np.isnan(none.deflection_m) and none.note == "no points"
    with pytest.raises(InputError, match="slice_m"):
        ShapeParams(slice_m=0.0).validate()
    with pytest.raises(InputError, match="labels"):
        member_shapes(pts, np.zeros(3, int), [cub])


def _box(a, b, w, h, up=Z) -> BeamCuboid:
    return _cuboid(member_between("m", "x", a, b, w, h, np.asarray(up, float)))


def test_joint_types_and_components():
    tie = _box([0, -3, 0.1], [0, 3, 0.1], 0.2, 0.2)
    post = _box([0, 0, 0.18], [0, 0, 2.5], 0.18, 0.18, [1, 0, 0])
    raf_l = _box([0, -2.8, 0.25], [0, 0, 2.6], 0.16, 0.18, np.cross([1, 0, 0], [0, 2.8, 2.35]))
    raf_r = _box([0, 2.8, 0.25], [0, 0, 2.6], 0.16, 0.18, np.cross([1, 0, 0], [0, -2.8, 2.35]))
    # a purlin lying on the left rafter's back, along x
    mid = 0.5 * (np.array([0, -2.8, 0.25]) + np.array([0, 0, 2.6]))
    n = np.cross([1.0, 0, 0], [0, 2.8, 2.35])
    n /= np.linalg.norm(n)
    c = mid + n * (0.09 + 0.08)
    purlin = _box(c - [2, 0, 0], c + [2, 0, 0], 0.14, 0.16, n)
    loose = _box([5, -1, 0.05], [5, 1, 0.05], 0.1, 0.1)
    beams = [tie, post, raf_l, raf_r, purlin, loose]
    joints = find_joints(beams)
    types = {jt.members: jt.type for jt in joints}
    assert types[(1, 2)] == "T"  # post on the tie
    assert types[(1, 3)] == "foot" and types[(1, 4)] == "foot"
    assert types[(3, 4)] == "L"  # rafter heads at the apex
    assert types[(3, 5)] == "X"  # purlin over the rafter
    assert all(6 not in jt.members for jt in joints)
    comp = components(len(beams), joints)
    assert comp[5] != comp[0] and len(set(comp[:5].tolist())) == 1 and comp[0] == 1
    # the joint point: where the centre lines are closest
    jt = next(j for j in joints if j.members == (1, 2))
    assert jt.point == pytest.approx([0, 0, 0.14], abs=0.05)
    s, t = closest_points(
        *(np.array(v, float) for v in ([0, 0, 0], [1, 0, 0], [0.5, -1, 1], [0.5, 1, 1]))
    )
    assert (s, t) == pytest.approx((0.5, 0.5))
    with pytest.raises(InputError, match="contact_m"):
        JointParams(contact_m=-1.0).validate()
    assert find_joints(beams[:1]) == []


def _frame(frame_type: str, seed: int = 0) -> list[Member]:
    rng = np.random.default_rng(seed)
    sections = draw_sections(rng, 1.0, frame_type)
    lv = RoofLevels(
        frame_type=frame_type,
        half=4.0,
        wall_t=0.6,
        z_w=0.8,
        length=8.0,
        pitch_deg=45.0,
        sections=sections,
        plate_inset=0.02,
        overhang=0.3,
        boarding_t=0.025,
        has_ridge=True,
        has_commons=True,
    )
    members, _ = build_frame(lv, rng, truss_spacing=3.0, rafter_spacing=0.7, n_purlins=1,
                             brace_share=1.0)  # fmt: skip
    return members


@pytest.mark.parametrize("frame_type", ["king_post", "queen_post", "collar"])
def test_joints_and_roles_from_true_cuboids(frame_type):
    """On exact cuboids every true joint is found and most roles are right."""
    members = _frame(frame_type)
    beams = [_cuboid(m) for m in members]
    truth = {tuple(j["members"]) for j in true_joints(members)}
    found = {jt.members for jt in find_joints(beams)}
    assert len(truth & found) / len(truth) >= 0.97
    assert len(found - truth) / len(found) <= 0.15
    joints = find_joints(beams)
    roles = guess_roles(beams, joints, np.ones(len(beams), bool))
    right = np.mean([r == m.role for r, m in zip(roles, members, strict=True)])
    assert right >= 0.9, {(m.role, r) for r, m in zip(roles, members, strict=True) if r != m.role}
    along, across = roof_directions(beams)
    assert abs(along[0]) > 0.99 and abs(across[1]) > 0.99  # the ridge runs along x


def test_analyse_frame_and_json():
    rng = np.random.default_rng(3)
    bent = replace(
        member_between("tie", "tie", [0, -2.5, 0.9], [0, 2.5, 0.9], 0.2, 0.22, Z),
        deflection_m=0.012,
    )
    post = member_between(
        "post", "post", [0, 0, 1.0], [0, 0, 3.0], 0.16, 0.16, np.array([1.0, 0, 0])
    )
    brace = member_between("b", "brace", [-0.08, 0, 2.7], [-1.2, 0, 1.8], 0.1, 0.1,
                           np.array([0, 1.0, 0]))  # fmt: skip
    # on the floor, below the tie beam on its wall head
    loose = member_between("l", "tie", [3, -1, 0.05], [3, 1, 0.05], 0.1, 0.1, Z)
    ladder = member_between("ladder", "x", [0.6, 1.2, 0.2], [0.12, 0.0, 2.4], 0.06, 0.05, Z)
    members = [bent, post, brace, loose, ladder]
    pts = [surface_points(m, 8000, 0.002, rng) for m in members]
    xyz = np.vstack(pts)
    labels = np.repeat(np.arange(1, 6), [len(p) for p in pts]).astype(np.int32)
    cubs = tuple(_cuboid(m) for m in members)
    far = (labels == 1) & (np.abs(cubs[0].signed_distance(xyz)) > 0.01)
    labels[far] = 0  # the straight tie's labels miss its sagging middle
    result = BeamResult(
        labels=labels,
        beams=cubs,
        facet_labels=np.zeros(len(xyz), np.int32),
        straight_labels=np.zeros(len(xyz), np.int32),
        facet_beam=np.zeros(0, np.int32),
        params=BeamParams(),
    )
    frame = analyse_frame(xyz, result)
    assert any(4 in jt.members and 1 in jt.members for jt in frame.joints) is False
    assert any(jt.members == (2, 5) for jt in frame.joints)  # the ladder touches the post
    assert frame.in_frame.tolist() == [True, True, True, False, False]  # loose, leaning
    assert frame.roles[3] == frame.roles[4] == "loose" and frame.roles[1] == "post"
    assert frame.shapes[0].deflection_m == pytest.approx(0.012, abs=0.0015)
    doc = frame.to_json(result, offset=[1000.0, 2000.0, 0.0], n_points=len(xyz))
    text = json.dumps(doc, allow_nan=False)  # no NaN in the file
    back = json.loads(text)
    assert back["n_members"] == 5 and back["n_in_frame"] == 3
    assert back["members"][0]["centre"][0] == pytest.approx(1000.0, abs=1e-6)
    assert back["members"][0]["deflection_mm"] == pytest.approx(12.0, abs=1.5)
    assert {j["type"] for j in back["joints"]} <= {"foot", "L", "T", "X", "lap"}
    assert any(c["in_frame"] is False for c in back["components"])
    cols = frame.member_columns()
    assert cols["role"][3] == "loose" and cols["n_joints"][3] == 0
    with pytest.raises(InputError, match="segmented on"):
        analyse_frame(xyz[:10], result)
    # no beams at all: an empty frame, not an error
    empty = replace(result, labels=np.zeros(len(xyz), np.int32), beams=())
    nothing = analyse_frame(xyz, empty)
    assert nothing.joints == () and nothing.roles == ()
    assert json.loads(json.dumps(nothing.to_json(empty)))["n_members"] == 0
    with pytest.raises(InputError, match="min_frame_members"):
        FrameParams(min_frame_members=1).validate()


def test_cli_beams_writes_frame_json(tmp_path):
    import pandas as pd

    from pyheracles.cli import main
    from pyheracles.cloud import PointCloud
    from pyheracles.io import write_cloud
    from pyheracles.synthetic.truss import TrussParams, make_truss_roof

    roof = make_truss_roof(TrussParams(n_points=60_000), rng=4)
    cloud = PointCloud.from_world(roof.xyz + [500000.0, 5400000.0, 120.0])
    src = tmp_path / "roof.laz"
    write_cloud(cloud, src)
    out = tmp_path / "beams"
    assert main(["beams", str(src), "-o", str(out), "--no-picture"]) == 0
    doc = json.loads((out / "frame.json").read_text())
    table = pd.read_csv(out / "objects.csv")
    assert doc["n_members"] == len(table) >= 10
    assert doc["n_joints"] >= doc["n_members"] - 1  # a truss holds together
    assert doc["components"][0]["in_frame"] and doc["n_in_frame"] == doc["n_members"]
    assert {"role", "in_frame", "deflection_mm", "twist_deg"} <= set(table.columns)
    assert doc["members"][0]["centre"][0] > 400000.0  # world coordinates
    assert {"post", "rafter", "tie"} <= set(table["role"])
