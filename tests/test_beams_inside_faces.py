"""Step 2b (issue 13): members inside the room seen on one face, their body's side undecided.

A band seen on one face away from the hull (neither side of its plane holds
more of the cloud) was placed by its side points alone, and dropped when they
did not say which side the body lies on:

- roof draw 3: a king post (0.183 x 0.242 m) seen on one face, its own side
  going back behind one edge over the whole length, a rafter's points 0.22-0.58 m
  in front of the other edge over a quarter of it: both sides had points, the
  post was lost to the remainder;
- roof draw 14: a tie (0.20 x 0.274 m) seen on its side in a 3.9 m and a 2.5 m
  piece, three points leaving its edges: neither side had any, the tie was lost.

A side running along ``room_ratio`` times more of the length than the other
decides; a band with nothing leaving its edges is a member whose sides were not
seen (a thin slab, depth not measured).
"""

from __future__ import annotations

import numpy as np

from grid_planes import grid_plane
from pyheracles.beams.cuboids import fit_one_face_cuboid
from pyheracles.beams.model import StraightFacet
from pyheracles.geometry.neighbours import build_tree

X, Y, Z = np.eye(3)
FACE_W, DEPTH, LENGTH = 0.19, 0.24, 3.2


def _facet(xyz: np.ndarray, index: np.ndarray, normal, axis) -> StraightFacet:
    return StraightFacet(
        index=index,
        normal=np.asarray(normal, float),
        axis=np.asarray(axis, float),
        centre=xyz[index].mean(axis=0),
        width=FACE_W,
        length=LENGTH,
        plane_rms=0.002,
        parent=1,
    )


def _post(rng, crossing: bool):
    """A post along z seen on its face y = 0 (x 0-0.19), its side x = 0.19 going back to +y;
    with ``crossing``, a rafter's points 0.22-0.58 m in front (-y) of the edge x = 0 over
    z 1.0-1.8."""
    face = grid_plane(np.zeros(3), X, Z, FACE_W, LENGTH, 0.01, rng)
    side = grid_plane(np.array([FACE_W, 0.0, 0.0]), Y, Z, DEPTH, LENGTH, 0.01, rng)
    parts = [face, side]
    if crossing:
        y = np.arange(-0.58, -0.22, 0.01)
        z = np.arange(1.0, 1.8, 0.01)
        gy, gz = np.meshgrid(y, z)
        parts.append(np.column_stack([np.full(gy.size, 0.005), gy.ravel(), gz.ravel()]))
    xyz = np.vstack(parts)
    return xyz, np.arange(len(face))


def test_draw3_post_with_a_rafter_in_front_of_one_edge_is_a_member():
    xyz, face = _post(np.random.default_rng(3), crossing=True)
    tree = build_tree(xyz)
    cub = fit_one_face_cuboid(xyz, tree, [_facet(xyz, face, Y, Z)], xyz[::10], bin_m=0.01,
                              max_depth_m=0.6)  # fmt: skip
    assert cub is not None
    assert cub.centre[1] > 0.0  # the body behind the face, where its side goes back
    assert cub.height_measured


def test_draw14_tie_seen_on_its_side_alone_is_a_slab():
    rng = np.random.default_rng(14)
    tie_h = 0.274
    xyz = grid_plane(np.zeros(3), Y, Z, 3.9, tie_h, 0.01, rng)
    tree = build_tree(xyz)
    facet = _facet(xyz, np.arange(len(xyz)), X, Y)
    cub = fit_one_face_cuboid(xyz, tree, [facet], xyz[::10], bin_m=0.01, max_depth_m=0.6)
    assert cub is not None
    assert not cub.height_measured  # its depth behind the face is not known
    sizes = {round(cub.width, 3), round(cub.height, 3)}
    assert any(abs(s - tie_h) < 0.01 for s in sizes)  # the face's size, as seen
