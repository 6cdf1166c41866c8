"""Noisy grid points on rectangles in space, as a scanner sees a planar face (test helper).

Used by the beam tests (``test_beams_oneface``, ``test_beams_spurious``) to build beams,
floors and walls face by face.
"""

from __future__ import annotations

import numpy as np


def grid_plane(origin, u, v, lu, lv, step, rng, noise: float = 0.002) -> np.ndarray:
    """Grid points on the rectangle ``origin + [0, lu] u + [0, lv] v``, with noise (m)."""
    a = np.arange(0.0, lu, step)
    b = np.arange(0.0, lv, step)
    ga, gb = np.meshgrid(a, b, indexing="ij")
    p = origin + ga.reshape(-1, 1) * u + gb.reshape(-1, 1) * v
    return p + rng.normal(scale=noise, size=p.shape)
