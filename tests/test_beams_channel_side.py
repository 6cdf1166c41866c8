"""A strip of boarding beside a rafter is a channel, not a member seen on one face
(issue 13, cause 2).

Roof seed 4: a sliver of boarding 4 cm wide along a common rafter's top edge,
its plane tilted by 6 degrees by the noise across so narrow a strip, made a
"member" 3.25 m long seen on one face: the rafter's side comes forward from
one edge (a channel), and the boarding going on past the other edge, a
centimetre or two behind the tilted plane, was read as a side going back
(:func:`~pyheracles.beams.cuboids.going_back`).
"""

from __future__ import annotations

import numpy as np

from pyheracles.beams.cuboids import fit_one_face_cuboid, going_back
from pyheracles.beams.model import StraightFacet
from pyheracles.geometry.neighbours import build_tree

NOISE_M = 0.0045  # the draw's noise at the boarding


def _plane(origin, u, v, nu: float, nv: float, step: float, rng) -> np.ndarray:
    a = np.arange(0.0, nu, step)
    b = np.arange(0.0, nv, step)
    ga, gb = np.meshgrid(a, b, indexing="ij")
    o, u, v = (np.asarray(w, float) for w in (origin, u, v))
    p = o + ga.ravel()[:, None] * u + gb.ravel()[:, None] * v
    return p + rng.normal(scale=NOISE_M, size=p.shape)


def _attic(rng) -> tuple[np.ndarray, StraightFacet]:
    """Boarding z = 0 over a rafter 12 cm wide (x = +-6 cm, 15 cm deep), the room
    below; the sliver of boarding 4.5 cm wide along the rafter's edge, its plane
    tilted by 6 degrees (the boarding beyond it lies behind it)."""
    length = 2.4
    parts = [
        _plane([0.06, 0.0, 0.0], [1, 0, 0], [0, 1, 0], 0.6, length, 0.01, rng),  # boarding
        _plane([-0.66, 0.0, 0.0], [1, 0, 0], [0, 1, 0], 0.6, length, 0.01, rng),
        _plane([-0.06, 0.0, -0.15], [1, 0, 0], [0, 1, 0], 0.12, length, 0.01, rng),  # rafter
        _plane([0.06, 0.0, -0.15], [0, 0, 1], [0, 1, 0], 0.15, length, 0.01, rng),
        _plane([-0.06, 0.0, -0.15], [0, 0, 1], [0, 1, 0], 0.15, length, 0.01, rng),
        _plane([-2.0, -1.0, -2.5], [1, 0, 0], [0, 1, 0], 4.0, 4.4, 0.05, rng),  # floor
    ]
    xyz = np.vstack(parts)
    idx = np.flatnonzero((xyz[:, 0] >= 0.06) & (xyz[:, 0] <= 0.105) & (np.abs(xyz[:, 2]) < 0.02))
    theta = np.radians(6.0)
    facet = StraightFacet(
        index=idx,
        normal=np.array([np.sin(theta), 0.0, np.cos(theta)]),
        axis=np.array([0.0, 1.0, 0.0]),
        centre=xyz[idx].mean(axis=0),
        width=0.045,
        length=length,
        plane_rms=NOISE_M,
        parent=1,
    )
    return xyz, facet


def test_boarding_sliver_beside_a_rafter_is_a_channel():
    rng = np.random.default_rng(4)
    xyz, facet = _attic(rng)
    cub = fit_one_face_cuboid(xyz, build_tree(xyz), [facet], xyz[::5], bin_m=0.008, max_depth_m=0.6)
    assert cub is None


def test_side_points_within_the_noise_are_no_side():
    t = np.linspace(0.0, 2.0, 60)
    assert going_back(t, np.full(60, 0.018), (0.0, 2.0), 0.1, 0.033) == 0.0
    deep = np.linspace(0.02, 0.15, 60)
    assert going_back(t, deep, (0.0, 2.0), 0.1, 0.033) > 0.2
