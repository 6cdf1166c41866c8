"""Step 2b on attics (issue 13): wide surfaces, side-by-side members, loose timber.

Each test rebuilds, small, the configuration of a ``roof`` family draw where
the mechanism failed (seed 26 at 300 k points: boarding strips between common
rafters taken for beam faces, rafters chained into one 1 m "beam" across the
gaps, timber stored on the floor found as members; seed 4: member faces lost
to thresholds set by the floor and walls).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from pyheracles.beams import BeamCuboid, StraightFacet, segment_beams
from pyheracles.beams.facets import wide_surface_points
from pyheracles.beams.grouping import inconsistent
from pyheracles.beams.surfaces import cuboid_contacts, resting_loose, wide_surface_bands
from pyheracles.errors import InputError
from pyheracles.geometry.neighbours import build_tree


def _grid(x: tuple[float, float], y: tuple[float, float], z: float, step: float, rng):
    xs = np.arange(x[0], x[1], step)
    ys = np.arange(y[0], y[1], step)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    p = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, z)])
    return p + rng.normal(scale=0.002, size=p.shape)


def _band(xyz: np.ndarray, index: np.ndarray, width: float) -> StraightFacet:
    """The strip ``index`` of ``xyz`` as a straight facet along y with normal z."""
    pts = xyz[index]
    return StraightFacet(
        index=index,
        normal=np.array([0.0, 0.0, 1.0]),
        axis=np.array([0.0, 1.0, 0.0]),
        centre=pts.mean(axis=0),
        width=width,
        length=float(np.ptp(pts[:, 1])),
        plane_rms=0.002,
        parent=1,
    )


def _strip_in(cloud: np.ndarray, half_width: float = 0.2):
    """Cloud, and the straight facet of its points within ``half_width`` of x = 0 on z = 0."""
    idx = np.flatnonzero((np.abs(cloud[:, 0]) <= half_width) & (np.abs(cloud[:, 2]) < 0.01))
    return cloud, _band(cloud, idx, 2 * half_width)


def test_strip_of_boarding_between_rafters_is_a_wide_surface():
    rng = np.random.default_rng(0)
    strip = _grid((-0.2, 0.2), (0.0, 3.0), 0.0, 0.015, rng)
    # the next board beyond a 15 cm rafter, its first 10 cm shadowed by the rafter
    beyond = _grid((0.45, 1.0), (0.0, 3.0), 0.0, 0.015, rng)
    xyz, band = _strip_in(np.vstack([strip, beyond]))
    assert wide_surface_bands(build_tree(xyz), xyz, [band])[0]
    # a floor around the strip on both sides
    floor = _grid((-1.0, 1.0), (0.0, 3.0), 0.0, 0.015, rng)
    xyz, band = _strip_in(floor)
    assert wide_surface_bands(build_tree(xyz), xyz, [band])[0]


def test_beam_face_with_crossing_members_and_a_surface_above_is_not_wide():
    rng = np.random.default_rng(1)
    face = _grid((-0.2, 0.2), (0.0, 3.0), 0.0, 0.015, rng)
    # alone
    xyz, band = _strip_in(face)
    assert not wide_surface_bands(build_tree(xyz), xyz, [band])[0]
    # coplanar members of a truss crossing it (posts every metre, 17 cm wide)
    posts = [_grid((0.2, 1.2), (y, y + 0.17), 0.0, 0.015, rng) for y in (0.4, 1.4, 2.4)]
    # a wide surface crossing its plane along a line parallel to it (boarding
    # above a rafter's side face meets the side face's plane there)
    slope = _grid((0.3, 0.6), (0.0, 3.0), 0.0, 0.015, rng)
    slope[:, 2] = (slope[:, 0] - 0.45) * 2.0  # steep: meets z = 0 along x = 0.45
    xyz, band = _strip_in(np.vstack([face, *posts, slope]))
    assert not wide_surface_bands(build_tree(xyz), xyz, [band])[0]


def _facet(centre, normal, axis, width, n=200) -> StraightFacet:
    return StraightFacet(
        index=np.arange(n),
        normal=np.asarray(normal, float),
        axis=np.asarray(axis, float),
        centre=np.asarray(centre, float),
        width=width,
        length=3.0,
        plane_rms=0.002,
        parent=1,
    )


def test_faces_of_two_rafters_side_by_side_are_not_one_beam():
    cos_par, tol, wmax = np.cos(np.radians(5.0)), 0.01, 0.6
    ax = [0.0, 1.0, 0.0]
    # undersides of two common rafters 0.6 m apart, each with a side face
    r1 = [_facet([0.0, 0, 0], [0, 0, 1], ax, 0.13), _facet([0.065, 0, 0.09], [1, 0, 0], ax, 0.18)]
    r2 = [_facet([0.6, 0, 0], [0, 0, 1], ax, 0.13), _facet([0.535, 0, 0.09], [1, 0, 0], ax, 0.18)]
    assert inconsistent(r1, r2, cos_par, tol, wmax)
    # a 0.42 m strip of boarding above a rafter's 0.13 m underside
    strip = [_facet([0.3, 0, 0.19], [0, 0, 1], ax, 0.42)]
    assert inconsistent(r1, strip, cos_par, tol, wmax)
    # the two opposite side faces of one beam, and pieces of one face: one beam
    left = [_facet([-0.065, 0, 0.09], [1, 0, 0], ax, 0.18)]
    assert not inconsistent(r1[1:], left, cos_par, tol, wmax)
    piece = [_facet([0.0, 3.2, 0], [0, 0, 1], ax, 0.13)]
    assert not inconsistent(r1, piece, cos_par, tol, wmax)


def _box(centre, axis, width, height, length) -> BeamCuboid:
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    up = np.array([0.0, 0.0, 1.0])
    side = np.cross(up, axis)
    if np.linalg.norm(side) < 1e-6:
        side = np.array([1.0, 0.0, 0.0])
    side /= np.linalg.norm(side)
    up = np.cross(axis, side)
    return BeamCuboid(
        centre=np.asarray(centre, float),
        axes=np.column_stack([axis, side, up]),
        length=length,
        width=width,
        height=height,
        rms=0.0,
        n_facets=3,
    )


def test_timber_stored_on_the_floor_is_not_a_member():
    rng = np.random.default_rng(2)
    floor = _grid((-2.0, 2.0), (-2.0, 2.0), 0.0, 0.02, rng)
    lying = _box([0.0, 0.0, 0.1], [0, 1, 0], 0.2, 0.2, 2.0)
    tree = build_tree(floor)
    assert resting_loose(tree, [lying], cuboid_contacts([lying], 0.02)).tolist() == [True]
    # the same timber with no floor around it (a single beam scanned alone) is kept
    tree = build_tree(_grid((5.0, 6.0), (5.0, 6.0), 0.0, 0.02, rng))
    assert resting_loose(tree, [lying], [set()]).tolist() == [False]
    # a tie on the floor that a rafter stands on is part of the frame
    rafter = _box([0.0, 0.0, 1.2], [0, 0.7, 0.7], 0.15, 0.2, 3.0)
    beams = [lying, rafter]
    contacts = cuboid_contacts(beams, 0.05)
    assert contacts[0] == {1}
    assert not resting_loose(build_tree(floor), beams, contacts).any()


def test_timber_stacked_on_stored_timber_is_not_a_member():
    # roof seed 13: a piece laid across a stored timber, whose underside is
    # 0.2 m above the floor with no surface beside it, was kept as a member
    rng = np.random.default_rng(4)
    floor = _grid((-2.0, 2.0), (-2.0, 2.0), 0.0, 0.02, rng)
    below = _box([0.0, 0.0, 0.1], [0, 1, 0], 0.2, 0.2, 2.0)
    above = _box([0.0, 0.3, 0.26], [1, 0, 0], 0.3, 0.12, 1.6)
    beams = [below, above]
    contacts = cuboid_contacts(beams, 0.05)
    assert contacts[0] == {1}
    tree = build_tree(floor)
    assert resting_loose(tree, beams, contacts).tolist() == [True, True]
    # a rafter standing on the pile makes it part of the frame again
    rafter = _box([0.0, 1.36, 1.45], [0, 0.7, 0.7], 0.15, 0.2, 3.0)
    beams = [below, above, rafter]
    contacts = cuboid_contacts(beams, 0.05)
    assert contacts[2]
    assert not resting_loose(tree, beams, contacts).any()


def test_wide_surface_points_keep_beam_bands_and_trusses():
    rng = np.random.default_rng(3)
    floor = _grid((-2.0, 2.0), (-2.0, 2.0), 0.0, 0.02, rng)
    # a truss in one plane: a 0.2 m tie and a 0.2 m post, one region
    tie = _grid((-2.0, 2.0), (-0.1, 0.1), 1.0, 0.02, rng)
    post = _grid((-0.1, 0.1), (-2.0, 2.0), 1.0, 0.02, rng)
    xyz = np.vstack([floor, tie, post])
    labels = np.concatenate([np.full(len(floor), 1), np.full(len(tie) + len(post), 2)]).astype(
        np.int32
    )
    wide = wide_surface_points(xyz, labels, build_tree(xyz), max_width_m=0.6)
    assert wide[: len(floor)].mean() > 0.95
    assert not wide[len(floor) :].any()


def test_cloud_of_floor_only_is_a_clear_error():
    rng = np.random.default_rng(4)
    floor = _grid((-2.0, 2.0), (-2.0, 2.0), 0.0, 0.02, rng)
    with pytest.raises(InputError, match=r"no beam faces|no planar facet"):
        segment_beams(floor)


@pytest.mark.xfail(
    strict=True,
    reason=(
        "on the per-ray simulator's noise draw (issue 12/13 open): three spurious "
        "boarding boxes, not at most two"
    ),
)
@pytest.mark.slow
def test_attic_draw_with_boarding_common_rafters_and_stored_timber():
    """The draw that showed boarding strips, chained rafters and stored timber as beams."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from bench_framework import member_scores
    from pyheracles.synthetic.families import simulate

    sim = simulate("roof", 26, n_points=300_000)
    result = segment_beams(sim.clouds["cloud"].xyz)
    s = member_scores(sim, result)
    # before issue 13: 19 of 59 members matched, median F1 0.23, 13 boarding "beams"
    assert s["n_matched_f1_05"] >= 0.6 * s["n_visible"]
    assert s["median_f1"] >= 0.85
    assert s["spurious"].get("boarding", 0) <= 2
    assert s["spurious"].get("loose_timber", 0) <= 2


def test_strip_of_a_gable_wall_shadowed_at_a_slant_is_a_wide_surface():
    """Roof seeds 27 and 5: the band of a gable wall under the boarding, between the
    wall and the first common rafter, came out as a member (with the boarding strip
    beside it as its second face).  The wall goes on below the band, but the common
    rafters standing in front of it cast their shadows across it at a slant, so no
    line along the band was covered over half its length; every row is, beside the
    shadows."""
    rng = np.random.default_rng(2)
    length = 2.4
    band = _grid((-0.2, 0.2), (0.0, length), 0.0, 0.015, rng)
    wall = _grid((0.2, 1.4), (0.0, length), 0.0, 0.015, rng)
    # two slanted shadows 1.2 m apart, 24 cm wide along the band
    out, along = wall[:, 0] - 0.2, wall[:, 1]
    lit = np.ones(len(wall), dtype=bool)
    for start in (0.0, 1.2):
        lit &= np.abs((along - start) % length - 0.9 * out) > 0.12
    xyz, band_facet = _strip_in(np.vstack([band, wall[lit]]))
    assert wide_surface_bands(build_tree(xyz), xyz, [band_facet])[0]
    # a beam face with the same members crossing its plane, and no wall beyond
    face = _grid((-0.2, 0.2), (0.0, length), 0.0, 0.015, rng)
    members = [_grid((0.2, 1.4), (y, y + 0.15), 0.0, 0.015, rng) for y in (0.6, 1.8)]
    xyz, band_facet = _strip_in(np.vstack([face, *members]))
    assert not wide_surface_bands(build_tree(xyz), xyz, [band_facet])[0]


def _strips_along_x(xyz: np.ndarray, y_edges: np.ndarray) -> list[StraightFacet]:
    """Straight facets of the points on z = 0 with x > 0.25, one per strip of y, along x."""
    out = []
    for y0, y1 in itertools.pairwise(y_edges):
        idx = np.flatnonzero((xyz[:, 0] > 0.25) & (xyz[:, 1] >= y0) & (xyz[:, 1] < y1))
        pts = xyz[idx]
        out.append(
            StraightFacet(
                index=idx,
                normal=np.array([0.0, 0.0, 1.0]),
                axis=np.array([1.0, 0.0, 0.0]),
                centre=pts.mean(axis=0),
                width=float(y1 - y0),
                length=float(np.ptp(pts[:, 0])),
                plane_rms=0.002,
                parent=2,
            )
        )
    return out


def test_band_beside_a_surface_cut_into_strips_across_it_is_a_wide_surface():
    """Roof seed 27: the gable wall beside its band under the boarding had been cut into
    straight facets along other directions (strips between the shadows of the common
    rafters); their points did not count beside the band, as a crossing member's
    would not, and the band stayed a member's face.  Strips that are themselves
    pieces of a wider surface count; members crossing the plane still do not."""
    rng = np.random.default_rng(3)
    band = _grid((-0.2, 0.2), (0.0, 2.4), 0.0, 0.015, rng)
    wall = _grid((0.25, 1.4), (0.0, 2.4), 0.0, 0.015, rng)
    xyz, band_facet = _strip_in(np.vstack([band, wall]))
    strips = _strips_along_x(xyz, np.linspace(0.0, 2.4, 13))
    wide = wide_surface_bands(build_tree(xyz), xyz, [band_facet, *strips])
    assert wide.all()
    # members crossing the band's plane, a metre apart: no surface beside the band
    posts = [_grid((0.25, 1.4), (y, y + 0.17), 0.0, 0.015, rng) for y in (0.4, 1.4)]
    xyz, band_facet = _strip_in(np.vstack([band, *posts]))
    members = _strips_along_x(xyz, np.array([0.4, 0.57, 1.4, 1.57]))[::2]
    assert not wide_surface_bands(build_tree(xyz), xyz, [band_facet, *members])[0]
