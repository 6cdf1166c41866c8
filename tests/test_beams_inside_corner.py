"""An inside corner of the room's hull is no member (issue 13, cause 2).

Roof seed 5: where the gable wall meets the boarding, the strip of the wall
along its top and the strip of the boarding along the wall made a box 7.6 m
long, seen on two faces: the air in the corner, seen from behind
(:func:`~pyheracles.beams.surfaces.seen_from_behind`).
"""

from __future__ import annotations

import numpy as np

from pyheracles.beams.model import BeamCuboid, StraightFacet
from pyheracles.beams.surfaces import seen_from_behind
from pyheracles.geometry.neighbours import build_tree


def _plane(origin, u, v, nu: float, nv: float, step: float, rng) -> np.ndarray:
    a = np.arange(0.0, nu, step)
    b = np.arange(0.0, nv, step)
    ga, gb = np.meshgrid(a, b, indexing="ij")
    p = (
        np.asarray(origin)
        + ga.ravel()[:, None] * np.asarray(u)
        + gb.ravel()[:, None] * np.asarray(v)
    )
    return p + rng.normal(scale=0.002, size=p.shape)


def _facet(xyz: np.ndarray, index: np.ndarray, normal, axis) -> StraightFacet:
    pts = xyz[index]
    axis = np.asarray(axis, float)
    across = np.cross(normal, axis)
    return StraightFacet(
        index=index,
        normal=np.asarray(normal, float),
        axis=axis,
        centre=pts.mean(axis=0),
        width=float(np.ptp(pts @ across)),
        length=float(np.ptp(pts @ axis)),
        plane_rms=0.002,
        parent=1,
    )


def _room(rng, behind_wall: bool) -> tuple[np.ndarray, list[StraightFacet], BeamCuboid]:
    """A room 3 m wide and 2 m high, y along the corner of the wall x = 0 and the
    ceiling z = 2; the box fitted to the strips along the corner (6 cm by 14 cm)."""
    floor = _plane([0.0, 0.0, 0.0], [1, 0, 0], [0, 1, 0], 3.0, 3.0, 0.05, rng)
    far = _plane([3.0, 0.0, 0.0], [0, 0, 1], [0, 1, 0], 2.0, 3.0, 0.05, rng)
    wall = _plane([0.0, 0.0, 0.0], [0, 0, 1], [0, 1, 0], 2.0, 3.0, 0.01, rng)
    ceiling = _plane([0.0, 0.0, 2.0], [1, 0, 0], [0, 1, 0], 3.0, 3.0, 0.01, rng)
    parts = [floor, far, wall, ceiling]
    if behind_wall:  # the top of what the strip is the face of (a plate on a wall head)
        parts.append(_plane([-0.2, 0.0, 2.0], [1, 0, 0], [0, 1, 0], 0.2, 3.0, 0.01, rng))
    xyz = np.vstack(parts)
    n0 = len(floor) + len(far)
    idx_wall = n0 + np.flatnonzero(wall[:, 2] >= 1.86)
    idx_ceil = n0 + len(wall) + np.flatnonzero(ceiling[:, 0] <= 0.06)
    facets = [
        _facet(xyz, idx_wall, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        _facet(xyz, idx_ceil, [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]),
    ]
    cub = BeamCuboid(
        centre=np.array([0.03, 1.5, 1.93]),
        axes=np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]).T,
        length=3.0,
        width=0.06,
        height=0.14,
        rms=0.002,
        n_facets=2,
        faces_seen=2,
    )
    return xyz, facets, cub


def test_box_in_an_inside_corner_is_seen_from_behind():
    rng = np.random.default_rng(5)
    xyz, facets, cub = _room(rng, behind_wall=False)
    probe = xyz[::7]
    assert seen_from_behind(cub, facets, build_tree(xyz), probe, 0.6)


def test_member_face_with_its_body_behind_is_not_an_inside_corner():
    """A plate's inner side grouped with the wall head beside it (roof seed 12): the
    plate's top lies behind that face; the box is a member fitted wrongly, kept."""
    rng = np.random.default_rng(5)
    xyz, facets, cub = _room(rng, behind_wall=True)
    assert not seen_from_behind(cub, facets, build_tree(xyz), xyz[::7], 0.6)


def test_box_behind_its_faces_is_a_member():
    rng = np.random.default_rng(5)
    xyz, facets, cub = _room(rng, behind_wall=False)
    # the same two faces, the box behind them: a beam in the corner's place, seen
    behind = BeamCuboid(
        centre=np.array([-0.03, 1.5, 2.07]),
        axes=cub.axes,
        length=3.0,
        width=0.06,
        height=0.14,
        rms=0.002,
        n_facets=2,
        faces_seen=2,
    )
    assert not seen_from_behind(behind, facets, build_tree(xyz), xyz[::7], 0.6)
