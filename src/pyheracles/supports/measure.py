"""Per support: its points cut out of its cookie and its primitive, on two processes.

Why a module of its own: the per-support work of step 2a (floor and ceiling off, clutter
off, the final clustering, a pier that is round over its shaft taken again as a column,
the fitted primitive) is independent from one support to the next and is Python-heavy,
so threads do not share it out (issue 12, speed: about 2 s of CPU of the 10 M point
hall).  :func:`measure_supports` gives each support's result as the loop in
:func:`~pyheracles.supports.detect.detect_supports_checked` computed it, about half of
them computed by a forked child (:func:`pyheracles.forks.map_fork`); everything the
work changes in a shape comes back with its result.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from pyheracles.forks import map_fork
from pyheracles.supports.antae import end_at_anta
from pyheracles.supports.cookies import extract_support
from pyheracles.supports.core import Array, Scales, SupportParams
from pyheracles.supports.primitives import describe
from pyheracles.supports.round_shaft import column_again

__all__ = ["Measured", "measure_support", "measure_supports"]


class Measured(NamedTuple):
    """One support's result: its shape after the work (class, carried surface, ...),
    its points and offsets (None: not a support), its table row (None likewise),
    whether a pier was taken again as a column and whether a pier ending a wall (an anta)
    was cut off the wall's stub."""

    shape: dict
    points: tuple[NDArray[np.intp], Array] | None
    row: dict | None
    rounded: bool
    anta: bool = False


def measure_support(
    p: Array,
    cut: tuple[NDArray[np.intp], Array, Array],
    sh: dict,
    params: SupportParams,
    sc: Scales,
    h_sec: float,
    z_range: tuple[float, float],
    band: Callable[[float, float], NDArray[np.intp]],
) -> Measured:
    """Cut one support out of its cookie ``cut`` = (indices, offsets, angles), a pier
    that is round over its shaft again as a column, a pier ending a wall off the wall's
    stub, and describe its primitive (``h_sec``: the section it was found in).  Changes
    ``sh`` in place."""
    idx, rho, ang = cut
    kept = extract_support(p, idx, rho, ang, sh, params, sc, h_sec, z_range, band)
    if kept is None:
        return Measured(sh, None, None, False)
    rounded = False
    if sh["class"] == "pier" and not sh.get("respond", False):
        # a pier at its section whose shaft is round over its height: a column (a
        # sparse ring beside a sign at the section), its points taken again as one
        col = column_again(p, idx, kept[2], sh, params)
        if col is not None:
            again = extract_support(p, *col[1:], col[0], params, sc, h_sec, z_range, band)
            if again is not None:
                sh.clear()
                sh.update(col[0])
                kept, rounded = again, True
    anta = False
    if sh["class"] == "pier" and not sh.get("respond", False):
        # a pier ending a wall: the wall's stub off it, at the step of their faces
        ended = end_at_anta(kept[0], kept[2], sh, sc.tol)
        if ended is not None:
            kept, anta = ended, True
    cidx, crho, cpts = kept
    row = describe(cpts, crho, sh, sc.tol, z_ref=h_sec)
    return Measured(sh, (cidx, crho), row, rounded, anta)


def measure_supports(
    p: Array,
    shapes: list[dict],
    cut: list[tuple[NDArray[np.intp], Array, Array]],
    params: SupportParams,
    sc: Scales,
    h_sec: float,
    z_range: tuple[float, float],
    band: Callable[[float, float], NDArray[np.intp]],
) -> list[Measured]:
    """:func:`measure_support` of every shape (each at its own section height
    ``sh["h_sec"]``, else ``h_sec``), shared with a forked child; the shapes are
    updated in place with what the work changed, wherever it ran."""

    def one(k: int) -> Measured:
        sh = shapes[k]
        return measure_support(p, cut[k], sh, params, sc, sh.get("h_sec", h_sec), z_range, band)

    out = map_fork(one, range(len(shapes)), cost=[len(c[0]) for c in cut])
    for sh, m in zip(shapes, out, strict=True):
        if m.shape is not sh:  # measured in the child: its changes come back
            sh.clear()
            sh.update(m.shape)
    return out
