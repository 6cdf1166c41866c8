"""Stray bands: a light of a window cut across by its faces' stray returns is one hole.

A face's occupancy on the wall plane is closed (:func:`~pyheracles.walls.outlines.
occupancy`) to bridge the gaps between its scan lines; a few stray returns on the
plane inside a light (mixed pixels between a came or the glass and the scanner,
isolated outliers) are bridged to the jambs too, and a light narrower than twice the
closing's reach (0.3-0.4 m lights at 5 cm cells) is cut across by a band of closed
cells: two or three holes one above the other, each a window.  Such a band holds no
point of a face that is scanned densely all around it: a wall's solid band (a
transom, the wall between a door and the window above it) does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["StrayBandParams", "join_stray_bands"]


@dataclass(frozen=True)
class StrayBandParams:
    """Parameters of :func:`join_stray_bands` (shares of grid cells).

    Attributes
    ----------
    overlap
        Two holes are one above the other when their columns overlap over at least
        this share of the narrower one's (0.75).
    expected
        Fewest of the band's cells that a face would cover were the band wall scanned
        as densely as the wall around the two holes (its share of the wall's cells
        there, no hole, within ``margin`` cells, times the band's cells): 2.
    empty
        The band is a stray band when such a face covers at most this share of what it
        would (0.2).
    margin
        Cells around the two holes over which a face's density is measured (6: 0.3 m
        at 5 cm).
    max_rows
        Most rows of a stray band (5: the square of a face's closing at two
        iterations): stray returns bridge a light over the closing's reach; a taller
        band empty on the dense face is wall in its shadow (church draw 26: 0.6 m
        between a door and the window over it, the inner face shadowed there).
    """

    overlap: float = 0.75
    expected: float = 2.0
    empty: float = 0.2
    margin: int = 6
    max_rows: int = 5

    def __post_init__(self) -> None:
        for name in ("overlap", "empty"):
            v = getattr(self, name)
            if not 0 < v <= 1:
                raise ValueError(f"{name} must be a share in (0, 1], got {v!r}")
        if not self.expected > 0:
            raise ValueError(f"expected must be positive, got {self.expected!r}")
        for name in ("margin", "max_rows"):
            v = getattr(self, name)
            if not (isinstance(v, int) and v >= 1):
                raise ValueError(f"{name} must be an integer >= 1, got {v!r}")


def join_stray_bands(holes: NDArray[np.bool_], raw: list[NDArray[np.bool_]],
                     p: StrayBandParams | None = None) -> NDArray[np.bool_]:  # fmt: skip
    """``holes`` (columns along ``u``, rows up ``z``) with the stray bands between
    holes one above the other filled in: one hole.

    ``raw`` holds, per face, the cells holding its points (not closed).  A band is
    the rows between two holes' boxes over their shared columns (at least ``overlap``
    of the narrower's), at most ``max_rows`` of them; it is a stray band when a face
    that would cover ``expected`` of its cells or more, were it wall scanned as
    densely as the wall around the two holes (within ``margin`` cells), covers at most
    ``empty`` of that: a face's strays do not make wall where another face sees none.

    Church draws 6, 23 and 26: lights 0.3-0.6 m wide each found as two or three
    windows one above the other, cut by closed rows of the sparse outer face's mixed
    pixels, where the dense inner face had no point.

    Examples
    --------
    >>> import numpy as np
    >>> holes = np.zeros((12, 20), dtype=bool)
    >>> holes[4:9, 3:9] = holes[4:9, 11:17] = True
    >>> dense = ~holes
    >>> dense[4:9, 9:11] = False  # the inner face: nothing between the two holes
    >>> int(np.count_nonzero(join_stray_bands(holes, [dense]) != holes))
    10
    >>> int(np.count_nonzero(join_stray_bands(holes, [~holes]) != holes))  # a transom
    0
    """
    from scipy import ndimage

    p = p or StrayBandParams()
    lab, k = ndimage.label(holes)
    if k < 2:
        return holes
    boxes = ndimage.find_objects(lab)
    out = holes.copy()
    for a in range(k):
        for b in range(k):
            sa, sb = boxes[a], boxes[b]
            if a == b or sa is None or sb is None or sb[1].start < sa[1].stop:
                continue  # b above a, their boxes apart
            c0, c1 = max(sa[0].start, sb[0].start), min(sa[0].stop, sb[0].stop)
            narrow = min(sa[0].stop - sa[0].start, sb[0].stop - sb[0].start)
            if c1 - c0 < p.overlap * narrow:
                continue
            band = (slice(c0, c1), slice(sa[1].stop, sb[1].start))
            rows = sb[1].start - sa[1].stop
            if 0 < rows <= p.max_rows and _stray(holes, raw, (a + 1, b + 1), lab, band, p):
                out[band] = True
    return out


def _stray(holes: NDArray[np.bool_], raw: list[NDArray[np.bool_]], pair: tuple[int, int],
           lab: NDArray[np.int32], band: tuple[slice, slice],
           p: StrayBandParams) -> bool:  # fmt: skip
    """Whether ``band`` between the holes ``pair`` of ``lab`` is a stray band."""
    sel = np.isin(lab, pair)
    cols, rows = np.nonzero(sel)
    m = p.margin
    box = (slice(max(cols.min() - m, 0), cols.max() + 1 + m),
           slice(max(rows.min() - m, 0), rows.max() + 1 + m))  # fmt: skip
    around = ~holes[box]
    around[band[0].start - box[0].start : band[0].stop - box[0].start,
           band[1].start - box[1].start : band[1].stop - box[1].start] = False  # fmt: skip
    n_around = np.count_nonzero(around)
    if n_around == 0:
        return False
    n_band = (band[0].stop - band[0].start) * (band[1].stop - band[1].start)
    for r in raw:
        would = n_band * np.count_nonzero(r[box] & around) / n_around
        if would >= p.expected and np.count_nonzero(r[band]) <= p.empty * would:
            return True
    return False
