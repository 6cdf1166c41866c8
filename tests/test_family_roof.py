"""The ``roof`` scene family: draws, parameter ranges, reference, issue properties, CLI."""

from __future__ import annotations

import json
from collections import Counter

import numpy as np
import pytest

from pyheracles.errors import InputError
from pyheracles.synthetic.families import simulate
from pyheracles.synthetic.families.roof import NAMED_LAYOUTS, draw, resolve_params
from pyheracles.synthetic.families.roof_frame import (
    FRAME_TYPES,
    ROLES,
    SECTION_MAX_M,
    SECTION_MIN_M,
    Member,
)

#: A small attic, one station, a small cloud: about a second per draw.
SMALL = {"span_m": 5.0, "length_m": 5.0, "n_stations": 1, "n_points": 120_000}
NON_MEMBERS = {"floor", "wall", "boarding", "chimney", "loose_timber", "ladder"}


@pytest.fixture(scope="module")
def king():
    """A king-post roof with everything: commons, chimney, stored timber, ladder, 2 stations."""
    return draw(
        4,
        frame_type="king_post",
        span_m=6.0,
        length_m=8.0,
        n_stations=2,
        n_points=300_000,
        has_common_rafters=True,
        has_chimney=True,
        has_ladder=True,
        n_loose_timber=3,
        n_plank_stacks=1,
        bent_share=0.3,
        twisted_share=0.15,
        tie_bottom_m=0.8,
    )


def _members(sim) -> list[dict]:
    return [o for o in sim.scene.objects if o["class"] == "beam"]


def test_same_seed_same_points() -> None:
    a, b = draw(3, **SMALL), draw(3, **SMALL)
    np.testing.assert_array_equal(a.clouds["cloud"].xyz, b.clouds["cloud"].xyz)
    np.testing.assert_array_equal(a.clouds["cloud"].instance, b.clouds["cloud"].instance)
    assert a.params["joints"] == b.params["joints"]
    c = draw(4, **SMALL)
    assert len(c.clouds["cloud"]) != len(a.clouds["cloud"]) or not np.array_equal(
        c.clouds["cloud"].xyz, a.clouds["cloud"].xyz
    )


def test_drawn_parameters_stay_in_their_ranges() -> None:
    seen = Counter()
    for seed in range(300):
        p = resolve_params(seed)
        seen[p.frame_type] += 1
        assert 4 <= p.span_m <= 12 and 4 <= p.length_m <= 16
        assert 30 <= p.pitch_deg <= 60
        assert 1 <= p.n_stations <= 4 and 1.2 <= p.tripod_height_m <= 1.8
        assert p.n_points is None and 2500 <= p.surface_density_per_m2 <= 8000
        assert 0.002 <= p.noise_m <= 0.005 and 0.001 <= p.outlier_share <= 0.01
        assert -0.2 <= p.tie_bottom_m <= 1.6 and not -0.0 < p.tie_bottom_m < 0.3
        assert 0 <= p.bent_share <= 0.3 and 0 <= p.twisted_share <= 0.15
        assert p.spacing_10m_m is None and p.layout == "random"
    assert set(seen) == set(FRAME_TYPES)
    assert min(seen.values()) > 30


def test_overrides_fix_fields_and_unknown_names_are_refused() -> None:
    p = resolve_params(5, n_stations=2, frame_type="collar")
    q = resolve_params(5)
    assert p.n_stations == 2 and p.frame_type == "collar"
    assert p.span_m == q.span_m  # the other draws do not move
    with pytest.raises(InputError, match="n_station") as err:
        resolve_params(0, n_station=2)
    assert "n_stations" in str(err.value)
    with pytest.raises(InputError, match="frame_type"):
        resolve_params(0, frame_type="hammer_beam")
    with pytest.raises(InputError, match="span_m"):
        resolve_params(0, span_m=-3.0)
    with pytest.raises(InputError, match="layout"):
        resolve_params(0, layout="cathedral")
    with pytest.raises(InputError):
        simulate("roof", -1)


def test_reference_is_consistent(king) -> None:
    res = king.clouds["cloud"]
    names = king.scene.class_names
    objs = _members(king)
    by_inst = {o["instance"]: o for o in objs}
    # every member is one instance of class beam with a role; the rest is instance 0
    assert (
        sorted(by_inst)
        == list(range(1, len(objs) + 1))
        == list(range(1, king.params["n_members"] + 1))
    )
    assert {o["role"] for o in objs} <= set(ROLES)
    beam = res.instance > 0
    assert set(np.unique(res.instance[beam])) <= set(by_inst)
    assert {names[c] for c in np.unique(res.class_id[beam])} == {"beam"}
    other = {names[c] for c in np.unique(res.class_id[~beam & ~res.outlier])}
    assert other <= NON_MEMBERS and {"floor", "wall", "boarding"} <= other
    assert other <= {o["class"] for o in king.scene.objects}
    # outliers: flagged, no reference, the share drawn
    assert not res.instance[res.outlier].any() and not res.class_id[res.outlier].any()
    share = float(res.outlier.mean())
    assert 0.5 * king.params["outlier_share"] < share < 3 * king.params["outlier_share"] + 0.01
    # the non-beam surfaces make most of the cloud
    assert beam.mean() < 0.5
    # the cloud size aimed at
    assert abs(len(res) / king.params["n_points"] - 1) < 0.1


def test_cloud_size_follows_the_surface_density() -> None:
    sim = draw(3, **{k: v for k, v in SMALL.items() if k != "n_points"})
    p = sim.params
    want = np.clip(p["surface_density_per_m2"] * p["surface_area_m2"], 300_000, 1_500_000)
    assert p["n_points"] == int(want)
    assert abs(p["n_points_obtained"] / p["n_points"] - 1) < 0.1
    with pytest.raises(InputError, match="whole number"):
        resolve_params(0, n_stations=1.5)
    with pytest.raises(InputError, match="true or false"):
        resolve_params(0, has_chimney="yes")


def test_member_cuboids_are_true(king) -> None:
    res = king.clouds["cloud"]
    good = ~res.outlier
    for o in _members(king):
        c = o["cuboid"]
        ax, up, side = (np.asarray(c[k]) for k in ("axis", "up", "side"))
        assert abs(np.linalg.norm(ax) - 1) < 1e-9 and abs(ax @ up) < 1e-9
        np.testing.assert_allclose(np.cross(ax, up), side, atol=1e-9)
        assert SECTION_MIN_M <= c["width"] <= SECTION_MAX_M
        assert SECTION_MIN_M <= c["height"] <= SECTION_MAX_M
        assert 0.0 <= o["deflection_m"] <= 0.03 and abs(o["twist_deg"]) <= 4.0
        if o["deflection_m"] or o["twist_deg"] or o["n_points"] < 20:
            continue
        # points of a straight member lie on its cuboid's surface (range noise only)
        pts = res.xyz[good & (res.instance == o["instance"])]
        local = (pts - np.asarray(c["centre"])) @ np.vstack([ax, side, up]).T
        half = 0.5 * np.array([c["length"], c["width"], c["height"]])
        d = np.abs(np.min(np.abs(np.abs(local) - half), axis=1))
        assert np.quantile(d, 0.9) < 4 * king.params["noise_m"] + 0.003, o["name"]


def test_issue_properties(king) -> None:
    objs = _members(king)
    roles = Counter(o["role"] for o in objs)
    for role in (
        "tie",
        "rafter",
        "post",
        "strut",
        "purlin",
        "ridge",
        "plate",
        "brace",
        "common_rafter",
    ):
        assert roles[role] >= 1, role
    # members seen on one face only, and on three
    faces = Counter(o["faces_seen"] for o in objs)
    assert faces[1] >= 1 and faces[3] >= 1
    # bent (5-30 mm) and twisted members are recorded
    bent = [o["deflection_m"] for o in objs if o["deflection_m"] > 0]
    assert bent and all(0.005 <= d <= 0.03 for d in bent)
    assert any(o["twist_deg"] != 0 for o in objs)
    # joints of every type, between existing members
    joints = king.params["joints"]
    assert {j["type"] for j in joints} == {"L", "T", "X", "foot"}
    assert all(
        1 <= a <= len(objs) and 1 <= b <= len(objs) for a, b in (j["members"] for j in joints)
    )
    kinds = {(j["type"], tuple(sorted(j["roles"]))) for j in joints}
    assert ("X", ("brace", "brace")) in kinds  # braces crossing in X
    assert ("T", ("post", "tie")) in kinds
    assert any(t == "foot" and "rafter" in r for t, r in kinds)
    # the scanners stand inside the frame, under the boarding, clear of the members
    lv = king.extras["levels"]
    for s in king.params["stations"]:
        assert 0 < s[0] < lv.length and abs(s[1]) < lv.half
        assert s[2] < float(lv.underside(abs(s[1])))
    # clutter
    classes = {o["class"] for o in king.scene.objects}
    assert {"chimney", "loose_timber", "ladder"} <= classes
    assert king.params["ladder_on"].startswith("king_post")
    # far ends are sparse: the points of long members thin out away from the stations
    res = king.clouds["cloud"]
    st = np.array(king.params["stations"])
    longest = max(
        (o for o in objs if o["role"] in ("purlin", "plate")), key=lambda o: o["n_points"]
    )
    pts = res.xyz[res.instance == longest["instance"]]
    r = np.min(np.linalg.norm(pts[:, None] - st[None], axis=2), axis=1)
    near, far = r < np.quantile(r, 0.25), r > np.quantile(r, 0.75)
    from scipy.spatial import cKDTree

    d, _ = cKDTree(pts).query(pts, k=2)
    assert np.median(d[far, 1]) > 1.5 * np.median(d[near, 1])


@pytest.mark.parametrize("frame", FRAME_TYPES)
def test_every_frame_type_builds(frame: str) -> None:
    sim = draw(11, frame_type=frame, **{**SMALL, "n_points": 60_000})
    roles = Counter(o["role"] for o in _members(sim))
    assert roles["rafter"] >= 4 and roles["tie"] >= 2 and roles["plate"] == 2
    if frame in ("king_post", "queen_post"):
        assert roles["post"] >= 2 * (1 + (frame == "queen_post")) and roles["purlin"] >= 2
    if frame == "collar":
        assert roles["collar"] >= roles["tie"]
    if frame == "queen_post":
        names = {o["name"] for o in _members(sim)}
        assert any(n.startswith("straining_beam") for n in names)
    if frame in ("collar", "simple_rafter"):
        assert roles["common_rafter"] >= 2 and roles["brace"] >= 2


def test_boarding_on_purlins_and_ties_in_the_floor() -> None:
    sim = draw(6, frame_type="queen_post", has_common_rafters=False, tie_bottom_m=-0.1, **SMALL)
    roles = Counter(o["role"] for o in _members(sim))
    assert roles["common_rafter"] == 0 and roles["purlin"] == 4
    lv = sim.extras["levels"]
    assert lv.z_w < 0 < lv.z_tt  # the ties rise from the floor boards
    purlin = next(m for m in sim.extras["members"] if m.role == "purlin")
    top = purlin.centre + purlin.up * purlin.height / 2
    eta = abs(top[1])
    assert abs(float(lv.underside(eta)) - top[2]) < 0.002  # boarding lies on the purlins


def test_member_mesh_follows_the_bend() -> None:
    m = Member(
        "t",
        "tie",
        np.zeros(3),
        np.array([1.0, 0, 0]),
        np.array([0, 0, 1.0]),
        4.0,
        0.2,
        0.3,
        deflection_m=0.02,
    )
    tris = m.triangles(rings=16).reshape(-1, 3)
    mid = tris[np.abs(tris[:, 0]) < 1e-9]
    assert abs(mid[:, 2].max() - (0.15 - 0.02)) < 1e-9  # top face sags 2 cm at mid-span


def test_named_benchmark_roof() -> None:
    sim = draw(0, layout="truss2_2scan_150k")
    objs = _members(sim)
    assert len(objs) == 15
    assert {o["role"] for o in objs} == {"tie", "rafter", "post", "strut", "ridge", "purlin"}
    res = sim.clouds["cloud"]
    assert abs(len(res) / NAMED_LAYOUTS["truss2_2scan_150k"]["n_points"] - 1) < 0.1
    assert (res.instance > 0).all()


def test_cli_writes_the_draw(tmp_path) -> None:
    import laspy

    from pyheracles.cli import main

    out = tmp_path / "r0"
    code = main(
        ["simulate", "--family", "roof", "--seed", "0", "-o", str(out), "--set", "n_points=150000"]
    )
    assert code in (0, None)
    for name in ("cloud.laz", "truth.npz", "scene.json", "preview.png"):
        assert (out / name).is_file(), name
    las = laspy.read(out / "cloud.laz")
    truth = np.load(out / "truth.npz")
    assert len(las.points) == len(truth["instance"]) == len(truth["outlier"])
    sim = draw(0, n_points=150_000)
    res = sim.clouds["cloud"]
    np.testing.assert_array_equal(truth["instance"], res.instance)
    xyz = np.column_stack([las.x, las.y, las.z])
    np.testing.assert_allclose(xyz, res.xyz, atol=2e-4)
    desc = json.loads((out / "scene.json").read_text())
    assert desc["params"]["joints"] and desc["params"]["n_members"] == len(_members(sim))
    assert {o["class"] for o in desc["objects"]} >= {"beam", "floor", "wall", "boarding"}
