"""Colours of objects in pictures and 3D views: distinct, and never the ground's or the remainder's.

The ground is drawn light grey and the remainder dark grey in every picture of
pyheracles; objects get saturated colours spread around the hue circle by the
golden angle, so that neighbouring instance numbers never look alike and no
object is ever grey.

Examples
--------
>>> cols = object_colours(40)
>>> cols.shape
(40, 3)
>>> bool((cols.max(1) - cols.min(1) > 0.3).all())   # no grey among them
True
"""

from __future__ import annotations

import colorsys

import numpy as np
from numpy.typing import NDArray

__all__ = ["GROUND", "REMAINDER", "hex_colour", "object_colours"]

#: Ground (light grey) and remainder (dark grey), RGB 0-1.
GROUND = (0.80, 0.80, 0.80)
REMAINDER = (0.35, 0.35, 0.35)

_GOLDEN = 0.618033988749895


def object_colours(n: int) -> NDArray[np.float64]:
    """``(n, 3)`` RGB colours, 0-1, for objects 1..n (row ``i`` for object ``i + 1``)."""
    out = np.empty((max(n, 0), 3))
    for i in range(max(n, 0)):
        h = (0.05 + i * _GOLDEN) % 1.0
        s = (0.95, 0.75, 0.85)[i % 3]
        v = (0.90, 0.70, 0.80)[(i // 3) % 3]
        out[i] = colorsys.hsv_to_rgb(h, s, v)
    return out


def hex_colour(rgb: NDArray[np.float64] | tuple[float, float, float]) -> str:
    """``#rrggbb`` of an RGB triple in 0-1."""
    r, g, b = (round(255 * float(c)) for c in rgb)
    return f"#{r:02x}{g:02x}{b:02x}"
