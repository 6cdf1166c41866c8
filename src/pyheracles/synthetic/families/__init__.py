"""Randomised scene families: ``family(seed, **overrides)`` draws a scene and scans it.

Each family module draws its layout from wide parameter ranges (so that no
single layout can be tuned to), builds a :class:`~pyheracles.synthetic.scene.Scene`
and scans it through the one simulator (:mod:`pyheracles.synthetic.scanner`).
The project's named scenes are members of their family at fixed seeds or
layouts.

=========== ============================================ ==================
family      what it draws                                used by
=========== ============================================ ==================
supports    buildings with 4-80 columns, piers, engaged  step 2a (supports)
            columns, walls, ceilings, clutter; TLS
roof        roof frames with boarding, walls, floor,     step 2b (beams)
            stored timber; TLS inside the frame
church      churches with windows and panes; interior    registration
            TLS and exterior TLS/photogrammetry, each
            in its own frame
complex     walled complexes with GIS layers; airborne   step 1, ground
terrain     steep, terraced, vegetated terrain; airborne ground
=========== ============================================ ==================

Examples
--------
>>> from pyheracles.synthetic.families import FAMILIES
>>> sorted(FAMILIES)
['church', 'complex', 'roof', 'supports', 'terrain']
"""

from __future__ import annotations

from collections.abc import Callable
from importlib import import_module
from typing import Any

from pyheracles.errors import InputError
from pyheracles.synthetic.families.simulation import Simulation, write_simulation

__all__ = ["FAMILIES", "Simulation", "simulate", "write_simulation"]

#: Family name -> module of :mod:`pyheracles.synthetic.families` with a ``draw`` function.
FAMILIES: dict[str, str] = {
    "supports": "supports",
    "roof": "roof",
    "church": "church",
    "complex": "complex",
    "terrain": "terrain",
}


def family(name: str) -> Callable[..., Simulation]:
    """The ``draw(seed, **overrides)`` function of a family."""
    if name not in FAMILIES:
        raise InputError(
            f"unknown scene family {name!r}",
            hint=f"choose one of {', '.join(sorted(FAMILIES))}",
        )
    return import_module(f"pyheracles.synthetic.families.{FAMILIES[name]}").draw


def simulate(name: str, seed: int, **overrides: Any) -> Simulation:
    """Draw member ``seed`` of family ``name`` (overrides fix drawn parameters).

    Raises
    ------
    InputError
        Unknown family, a negative seed, or an override the family does not have.
    """
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"seed must be a whole number >= 0, got {seed!r}")
    return family(name)(seed, **overrides)
