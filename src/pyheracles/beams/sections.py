"""Reading a beam's cross-section from its faces' points: edges and bow.

A fitted cuboid's sides come from the planes of the faces seen on them, or,
for a side whose face was not seen, from where the faces across it end
(:func:`face_edges`).  Both are read about the beam's centre line, which a
sagging or bowed member does not hold straight (:func:`centre_line_bow`).
Used by :func:`~pyheracles.beams.cuboids.fit_beam_cuboid`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.geometry.groups import group_medians

__all__ = ["Bow", "centre_line_bow", "face_edges", "off_seen_sides"]


#: Points per bin of a face's profile read finely (twice that per scan-line bin).
EDGE_DENSE_COUNT = 40
#: Finest bin of a face's profile, metres (about the noise of a scan).
EDGE_MIN_BIN_M = 0.002
#: A pile is sought this far inside a face's edge, metres (a few times the noise).
EDGE_PILE_REACH_M = 0.006
#: A bin at a face's edge holding this many times the plateau count is a pile.
EDGE_PILE_RATIO = 1.5
#: A sparse profile (no more than ``2 EDGE_DENSE_COUNT`` points per scan-line bin) is
#: read in bins of this fraction of a scan-line bin (no finer than ``EDGE_MIN_BIN_M``).
EDGE_SPARSE_SUBBINS = 4


def face_edges(values: NDArray[np.float64], bin_m: float) -> tuple[float, float]:
    """Edges of the points of a beam's faces across one direction of its section.

    As :func:`~pyheracles.beams.facets.half_max_edges` (half the plateau
    density), but read in finer bins, and with a rule for a surface meeting the
    face at its edge:

    - a dense profile (a plateau of more than ``2 EDGE_DENSE_COUNT`` points per
      ``bin_m`` bin) is read again in bins holding about ``EDGE_DENSE_COUNT``
      points each (no finer than ``EDGE_MIN_BIN_M``), as a running mean over
      ``bin_m`` (scan lines along the beam leave no gaps; a step edge keeps
      its half-density point), with empty bins past either end: bins of a
      scan-line spacing (1 cm where the scan is sparse) aligned on the first
      point put the edge up to a bin off, and the 3-bin smoothing carried the
      points of a surface lying past the edge (boarding left straight over a
      sagging rafter) across the gap between them;
    - a sparse profile is read the same way in bins of ``1 / EDGE_SPARSE_SUBBINS``
      of ``bin_m``: in bins of ``bin_m`` aligned on its first point the last bin
      may straddle the edge and hold more than half the plateau count (a few
      points of a surface meeting the face there, the boarding on a rafter's
      hidden top), and the edge was then the last point, up to a bin out (a
      sparse rafter's top read 2-6 mm out, up to a bin in 8 noise draws: the
      bins were aligned on the far end, which the seen face's corner strip
      moves);
    - on a dense profile, a pile at the edge, a bin holding ``EDGE_PILE_RATIO`` times the
      plateau count, is the trace of a surface meeting the face (the boarding
      on a rafter's hidden top, the edge strip of an adjacent face seen
      edge-on): the edge is the pile's median, not its outer half-density
      point, which noise puts beyond it.
    """
    v_lo = float(values.min())
    nb = max(int(np.ceil((float(values.max()) - v_lo) / bin_m)), 1)
    coarse = np.bincount(
        np.minimum(((values - v_lo) / bin_m).astype(np.int64), nb - 1), minlength=nb
    ).astype(float)
    if nb >= 3:
        coarse = np.convolve(coarse, np.ones(3) / 3.0, mode="same")
    level = float(np.median(coarse[coarse >= 0.25 * coarse.max()]))
    sparse = level <= 2 * EDGE_DENSE_COUNT
    if sparse:
        step = max(bin_m / EDGE_SPARSE_SUBBINS, EDGE_MIN_BIN_M)
    else:
        step = max(bin_m * EDGE_DENSE_COUNT / level, EDGE_MIN_BIN_M)
    level *= step / bin_m  # the plateau's count per fine bin
    half = 0.5 * level
    start = v_lo - step  # an empty bin before the first point, and two after the last
    nb = int(np.ceil((float(values.max()) - start) / step)) + 3
    raw = np.bincount(((values - start) / step).astype(np.int64), minlength=nb).astype(float)
    # a running mean over a scan-line spacing: no gaps between scan lines running
    # along the beam, and a step edge keeps its half-density point
    k = max(round(bin_m / step), 1) | 1
    hist = np.convolve(raw, np.ones(k) / k, mode="same") if k > 1 else raw
    i = j = int((float(np.median(values)) - start) / step)
    while i > 0 and hist[i - 1] >= half:
        i -= 1
    j = max(j, i)
    while j < nb - 1 and hist[j + 1] >= half:
        j += 1

    def cross(a: int, b: int) -> float:
        ha, hb = hist[a], hist[b]
        frac = 0.5 if ha == hb else (half - ha) / (hb - ha)
        return start + (a + 0.5 + frac * (b - a)) * step

    reach = max(int(np.ceil(EDGE_PILE_REACH_M / step)), 1)

    # piles are sought over three fine bins (a noise's width), which the running
    # mean would flatten
    narrow = np.convolve(raw, np.ones(3) / 3.0, mode="same")

    def pile(first: int, last: int) -> float | None:
        m = first + int(np.argmax(narrow[first : last + 1]))
        if narrow[m] < EDGE_PILE_RATIO * level:
            return None
        c = start + (m + 0.5) * step
        return float(np.median(values[np.abs(values - c) <= 1.5 * step]))

    left, right = cross(i - 1, i), cross(j, j + 1)
    if sparse:  # too few points per fine bin to tell a pile from the noise
        return left, right
    p_lo, p_hi = pile(i, min(i + reach, j)), pile(max(j - reach, i), j)
    left = left if p_lo is None else max(left, p_lo)
    right = right if p_hi is None else min(right, p_hi)
    return left, right


@dataclass(frozen=True)
class Bow:
    """A bow of a beam's centre line across one direction of its section.

    The offset of the centre line at position ``t`` along the axis (metres,
    from the cuboid's straight frame) is ``b1 (t - t0) + b2 (t - t0)^2``: a
    sag or a sideways bow (``b2``) and the small tilt of the fitted axis over
    the part seen (``b1``).  The zero bow leaves every offset as it is.
    """

    t0: float = 0.0
    b1: float = 0.0
    b2: float = 0.0

    def __call__(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """Offset of the centre line at positions ``t`` along the axis, metres."""
        s = t - self.t0
        return s * (self.b1 + self.b2 * s)

    @property
    def is_zero(self) -> bool:
        return self.b1 == 0.0 and self.b2 == 0.0

    def mean(self, t_lo: float, t_hi: float) -> float:
        """Mean offset over ``[t_lo, t_hi]`` (where a straight box stands for the bowed beam)."""
        a, b = t_lo - self.t0, t_hi - self.t0
        if b - a <= 0:
            return float(self(np.array([t_lo]))[0])
        return float(self.b1 * (b * b - a * a) / 2 + self.b2 * (b**3 - a**3) / 3) / (b - a)


#: Slice length along the axis for the bow of a centre line, metres.
BOW_SLICE_M = 0.1
#: Fewest points of one face in one slice that locate it.
BOW_MIN_SLICE_POINTS = 8
#: Fewest located slices, and the share of the length they span, for a bow.
BOW_MIN_SLICES = 5
BOW_MIN_COVER = 0.5
#: A bow is kept when its sag over the span seen exceeds this many standard errors.
BOW_MIN_SIGNIFICANCE = 3.0


def centre_line_bow(
    t: NDArray[np.float64],
    offset: NDArray[np.float64],
    face: NDArray[np.int64],
    length: float,
) -> Bow:
    """The bow shared by the faces facing one direction of a beam's section.

    A beam sagging (or bowed sideways) by a few centimetres is fitted by a
    straight cuboid that encloses the bow: the faces' offsets change along
    the beam, and a size read from the edges of the faces across them takes
    the bow in.  The faces facing the direction (``face``: which one, 0 ..
    F-1) move with the centre line: per slice of ``BOW_SLICE_M`` and face, the
    median ``offset`` (metres, along the direction) at position ``t``
    (metres along the axis) locates it, and ``offset = c_face + b1 s + b2 s^2``
    (``s = t - t0``, one constant per face: two opposite faces keep the
    section's size between them) is fitted by weighted least squares, with a
    4-sigma cut of slices.

    Returns the zero bow when fewer than ``BOW_MIN_SLICES`` slices locate a
    face, when they span less than ``BOW_MIN_COVER`` of ``length``, or when
    the sag over the span seen (``|b2| span^2 / 4``) is within
    ``BOW_MIN_SIGNIFICANCE`` standard errors of none (a straight beam keeps
    its straight cuboid).
    """
    if len(t) == 0:
        return Bow()
    lo = float(t.min())
    n_s = max(int(np.ceil((float(t.max()) - lo) / BOW_SLICE_M)), 1)
    k = np.minimum(((t - lo) / BOW_SLICE_M).astype(np.int64), n_s - 1)
    n_f = int(face.max()) + 1
    group = k * n_f + face
    n_g = n_s * n_f
    count = np.bincount(group, minlength=n_g)
    med = group_medians(offset, group, n_g)
    ok = np.flatnonzero(count >= BOW_MIN_SLICE_POINTS)
    slices = np.unique(ok // n_f)
    if len(slices) < BOW_MIN_SLICES:
        return Bow()
    t_mid = lo + (slices + 0.5) * BOW_SLICE_M
    span = float(np.ptp(t_mid)) + BOW_SLICE_M
    if span < BOW_MIN_COVER * length:
        return Bow()
    t0 = 0.5 * float(t_mid.min() + t_mid.max())
    s = lo + (ok // n_f + 0.5) * BOW_SLICE_M - t0
    y = med[ok]
    w = np.sqrt(count[ok].astype(np.float64))
    A = np.zeros((len(ok), n_f + 2))
    A[np.arange(len(ok)), ok % n_f] = 1.0
    A[:, n_f] = s
    A[:, n_f + 1] = s * s
    keep = np.ones(len(ok), dtype=bool)
    sol = np.zeros(n_f + 2)
    for _ in range(3):
        cols = np.flatnonzero(A[keep].any(axis=0))
        if keep.sum() <= len(cols):
            return Bow()
        Aw = (A[keep] * w[keep, None])[:, cols]
        sol = np.zeros(n_f + 2)
        sol[cols] = np.linalg.lstsq(Aw, y[keep] * w[keep], rcond=None)[0]
        res = y - A @ sol
        mad = float(np.median(np.abs(res[keep])))
        new = np.abs(res) <= max(4.0 * 1.4826 * mad, 1e-4)
        if np.array_equal(new, keep) or new.sum() < BOW_MIN_SLICES:
            break
        keep = new
    cols = np.flatnonzero(A[keep].any(axis=0))
    Aw = (A[keep] * w[keep, None])[:, cols]
    sol = np.zeros(n_f + 2)
    sol[cols] = np.linalg.lstsq(Aw, y[keep] * w[keep], rcond=None)[0]
    dof = int(keep.sum()) - len(cols)
    if dof <= 0 or n_f + 1 not in cols:
        return Bow()
    r = (y[keep] - A[keep] @ sol) * w[keep]
    sigma2 = float(r @ r) / dof
    cov = np.linalg.pinv(Aw.T @ Aw) * sigma2
    j = int(np.flatnonzero(cols == n_f + 1)[0])
    se_b2 = float(np.sqrt(max(cov[j, j], 0.0)))
    b2 = float(sol[n_f + 1])
    if abs(b2) <= BOW_MIN_SIGNIFICANCE * se_b2:
        return Bow()
    return Bow(t0=t0, b1=float(sol[n_f]), b2=b2)


def off_seen_sides(
    values: NDArray[np.float64], seen: NDArray[np.float64], tol: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The offsets of the points across a beam's faces without those on its seen sides.

    ``values``: offsets (metres) of the points of the faces across one direction
    of the section (their own and the free points on their planes); ``seen``: the
    offsets of the faces seen facing that direction, ``tol`` their tolerances
    (metres).  A seen side is located by its own face; the edge strip of that
    face, whose points lie on both planes at the corner, piles up there (several
    times the density of a sparse face across it) and set the half-density
    level of the profile: both edges closed in round that pile and the hidden
    side came out inside the beam (roof draw 14: a common rafter's hidden
    underside 3 cm inside).  The values within ``tol`` of a seen face at an end
    of the profile (at most a tenth of the values beyond it) are left out; all are
    kept when fewer than ten others remain.
    """
    if len(seen) == 0 or len(values) < 10:
        return values
    above = np.mean(values[:, None] > (seen + tol)[None, :], axis=0)
    below = np.mean(values[:, None] < (seen - tol)[None, :], axis=0)
    side = np.minimum(above, below) <= 0.1
    if not side.any():
        return values
    near = np.any(np.abs(values[:, None] - seen[None, side]) <= tol[None, side], axis=1)
    return values if int((~near).sum()) < 10 else values[~near]
