"""A wall with one splayed window, scanned: the scene of the walls' reveal tests.

Shared by ``test_walls_reveals`` and ``test_walls_splayed_sill`` (church draws 4, 14,
15 and 17): a wall ``thickness`` thick, its outer face at y = 0 facing -y, with an
unglazed opening ``u0``-``u1`` x ``z0``-``z1`` whose reveals run straight from the outer
face to ``pane`` deep and are splayed by ``splay`` from there to the inner face.
"""

from __future__ import annotations

import numpy as np

from pyheracles.synthetic.scanner import TLSStation, scan
from pyheracles.synthetic.scene import Scene

#: A scanner without range noise growth, drop-outs or mixed pixels.
QUIET = {"noise_m": 0.002, "noise_per_m": 0.0, "detection": 1e-9, "mixed_pixel_share": 0.0}


def splayed_window(
    length: float,
    height: float,
    thickness: float,
    opening: tuple[float, float, float, float],
    splay: float,
    pane: float,
    stations: list[TLSStation],
    rng: int,
) -> np.ndarray:
    """Points (N, 3) of the wall and its reveals scanned from ``stations``."""
    u0, u1, z0, z1 = opening
    s = Scene()

    def face(y: float, a: float, b: float, lo: float, hi: float) -> None:
        for u_0, u_1, z_0, z_1 in ((0, a, 0, height), (b, length, 0, height),
                                   (a, b, 0, lo), (a, b, hi, height)):  # fmt: skip
            s.add_quad([[u_0, y, z_0], [u_1, y, z_0], [u_1, y, z_1], [u_0, y, z_1]],
                       instance=1, class_name="wall", part="face")  # fmt: skip

    def ring(y: float, grow: float) -> np.ndarray:
        return np.array([[u0 - grow, y, z0 - grow], [u1 + grow, y, z0 - grow],
                         [u1 + grow, y, z1 + grow], [u0 - grow, y, z1 + grow]])  # fmt: skip

    face(0.0, u0, u1, z0, z1)
    face(thickness, u0 - splay, u1 + splay, z0 - splay, z1 + splay)
    a, m, b = ring(0.0, 0.0), ring(pane, 0.0), ring(thickness, splay)
    for p, q in ((a, m), (m, b)):  # the straight reveals, then the splayed ones
        for k in range(4):
            s.add_quad([p[k], p[(k + 1) % 4], q[(k + 1) % 4], q[k]], instance=1,
                       class_name="wall", part="reveal")  # fmt: skip
    return scan(s, stations, rng=rng).xyz
