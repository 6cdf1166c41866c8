"""Sphere targets measured next to walls, floors and tripods (registration.targets)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.errors import DegenerateGeometryError
from pyheracles.registration.targets import measure_sphere

R = 0.0725  # a 145 mm scanner sphere


def _visible_half_sphere(centre, viewer, rng, n=1500, noise=0.001):
    """Points on the half of the sphere that faces the scanner, with range noise."""
    v = rng.normal(size=(4 * n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    to_viewer = (viewer - centre) / np.linalg.norm(viewer - centre)
    v = v[v @ to_viewer > 0.05][:n]
    return centre + v * (R + rng.normal(0, noise, (len(v), 1)))


def _wall(x0, rng, extent=0.5, density=40000, noise=0.001, centre_yz=(0.0, 1.5)):
    """A wall plane x = x0 around (y, z), ``density`` points per m2."""
    n = int(density * (2 * extent) ** 2)
    y = rng.uniform(-extent, extent, n) + centre_yz[0]
    z = rng.uniform(-extent, extent, n) + centre_yz[1]
    return np.column_stack([np.full(n, x0) + rng.normal(0, noise, n), y, z])


@pytest.mark.parametrize("gap", [0.0, 0.02, 0.06, 0.12])
def test_sphere_on_a_wall_bracket_is_not_pulled_towards_the_wall(gap: float) -> None:
    """A sphere whose surface is ``gap`` from a wall: the wall fills the search ball.

    Before the robust fit the centre was pulled 6-8 cm towards the wall; the wall's
    points near the sphere surface passed the 0.25 r residual gate.
    """
    rng = np.random.default_rng(int(gap * 1000))
    centre = np.array([0.0, 0.0, 1.5])
    viewer = np.array([-6.0, 1.0, 1.6])
    sphere = _visible_half_sphere(centre, viewer, rng)
    wall = _wall(R + gap, rng)
    wall = wall[np.linalg.norm(wall - centre, axis=1) > R]  # the sphere hides nothing behind
    xyz = np.vstack([sphere, wall])
    approx = centre + np.array([0.03, -0.02, 0.02])  # an operator's pick, 4 cm off
    fit = measure_sphere(xyz, approx, R, max_residual_m=0.25 * R)
    assert np.linalg.norm(fit.centre - centre) < 1.5e-3
    assert fit.n_points < len(sphere) * 1.1  # the wall is not in the fit


def test_sphere_on_a_floor_and_tripod_head() -> None:
    rng = np.random.default_rng(7)
    centre = np.array([2.0, 1.0, R + 0.01])
    sphere = _visible_half_sphere(centre, np.array([-4.0, 0.0, 1.7]), rng)
    n = 8000
    floor = np.column_stack(
        [rng.uniform(1.8, 2.2, n), rng.uniform(0.8, 1.2, n), rng.normal(0, 0.001, n)]
    )
    floor = floor[np.linalg.norm(floor - centre, axis=1) > R]
    fit = measure_sphere(np.vstack([sphere, floor]), centre + 0.02, R, max_residual_m=0.25 * R)
    assert np.linalg.norm(fit.centre - centre) < 1.5e-3


def test_a_wall_alone_is_no_sphere() -> None:
    rng = np.random.default_rng(3)
    wall = _wall(0.1, rng)
    with pytest.raises(DegenerateGeometryError):
        measure_sphere(wall, np.array([0.05, 0.0, 1.5]), R, max_residual_m=0.25 * R)
