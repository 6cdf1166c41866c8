"""Straight facets: bands of constant width cut from planar facets (Hough search on points)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pyheracles.beams.facets import half_max_edges, on_own_plane, plane_frame
from pyheracles.beams.model import BeamParams, StraightFacet

__all__ = ["best_direction", "edge_line_direction", "sharpest_direction", "split_facet"]


def best_direction(
    q: NDArray[np.float64], angles: NDArray[np.float64], bin_m: float
) -> tuple[float, float]:
    """Hough-style search: direction whose perpendicular profile has the densest bin.

    Returns the angle (radians) and the offset of the peak bin centre.
    """
    from pyheracles.beams.extents import offset_histograms

    # histogram of the offsets across the band for every angle: (n_angles, bins)
    acc, smin = offset_histograms(
        np.ascontiguousarray(q[:, 0]), np.ascontiguousarray(q[:, 1]),
        np.sin(angles), np.cos(angles), float(bin_m),
    )  # fmt: skip
    nb = acc.shape[1]
    # a band is wider than one bin: score a 3-bin window
    acc = acc[:, :-2] + acc[:, 1:-1] + acc[:, 2:] if nb > 2 else acc
    k = int(acc.argmax())
    ia, ib = divmod(k, acc.shape[1])
    shift = 1 if nb > 2 else 0
    return float(angles[ia]), float(smin[ia] + (ib + shift + 0.5) * bin_m)


def sharpest_direction(
    q: NDArray[np.float64], ang0: float, half_range: float, bin_m: float, n_angles: int = 81
) -> float:
    """Direction near ``ang0`` across which the band is narrowest.

    A strip tilted by ``d`` spans ``w + L |d|`` across: the robust across-extent
    (0.5 to 99.5 % quantiles) is smallest when aligned.  Unlike PCA this is not
    pulled by an uneven density (overlapping scans) or by a crossing beam's
    points inside the band, and unlike a histogram sharpness it does not lock on
    the scan-line pattern.  ``n_angles`` directions are tried over
    ``ang0 +- half_range``.
    """
    del bin_m  # the extent needs no histogram
    angles = ang0 + np.linspace(-half_range, half_range, n_angles)
    lo, hi = across_quantiles(q, angles, 0.005, 0.995)
    score = -(hi - lo)
    k = int(score.argmax())
    if 0 < k < len(angles) - 1:
        y0, y1, y2 = score[k - 1], score[k], score[k + 1]
        den = y0 - 2 * y1 + y2
        frac = 0.5 * (y0 - y2) / den if den != 0 else 0.0
        return float(angles[k] + np.clip(frac, -1, 1) * (angles[1] - angles[0]))
    return float(angles[k])


def quantile_positions(
    count: NDArray[np.intp], q: float
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]:
    """Where numpy's ``np.quantile(x, q)`` (method "linear") reads a sorted ``x`` of
    ``count`` values, per group: the two positions and the interpolation weight."""
    n = count.astype(np.float64)
    virtual = (n - 1.0) * q
    prev = np.floor(virtual)
    nxt = prev + 1.0
    above = virtual >= n - 1.0
    prev[above] = n[above] - 1.0
    nxt[above] = n[above] - 1.0
    below = virtual < 0
    prev[below] = 0.0
    nxt[below] = 0.0
    return prev.astype(np.intp), nxt.astype(np.intp), virtual - prev


def quantile_lerp(
    a: NDArray[np.float64], b: NDArray[np.float64], gamma: NDArray[np.float64]
) -> NDArray[np.float64]:
    """numpy's interpolation between the values ``a`` and ``b`` read at
    :func:`quantile_positions` (the same numbers to the bit)."""
    diff = b - a
    out = a + diff * gamma
    high = gamma >= 0.5
    out[high] = (b - diff * (1.0 - gamma))[high]
    return out


def sorted_quantile(
    values: NDArray[np.float64], start: NDArray[np.intp], count: NDArray[np.intp], q: float
) -> NDArray[np.float64]:
    """``np.quantile(values[start[i]:start[i] + count[i]], q)`` for every group ``i`` of
    ``values`` sorted within its group, by numpy's formulas (method "linear": its virtual
    index and its interpolation, so the same numbers to the bit)."""
    prev, nxt, gamma = quantile_positions(count, q)
    return quantile_lerp(values[start + prev], values[start + nxt], gamma)


def across_quantiles(
    q: NDArray[np.float64], angles: NDArray[np.float64], q_lo: float, q_hi: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Low and high quantiles of the offsets across every direction of ``angles``.

    ``np.quantile(-q[:, :1] * sin(angles) + q[:, 1:] * cos(angles), [q_lo, q_hi],
    axis=0)`` to the bit, with ``q_lo`` near 0 and ``q_hi`` near 1: the few extreme
    values are kept by a compiled pass
    (:func:`~pyheracles.beams.extents.extreme_order_statistics`) instead of a
    partition of every direction's offsets (928 such quantiles were a seventh of
    the beams of a 100 k-point roof).
    """
    from pyheracles.beams.extents import extreme_order_statistics

    m = len(q)
    count = np.array([m], dtype=np.intp)
    lo_prev, lo_next, lo_gamma = quantile_positions(count, q_lo)
    hi_prev, hi_next, hi_gamma = quantile_positions(count, q_hi)
    stats = extreme_order_statistics(
        np.ascontiguousarray(q[:, 0]),
        np.ascontiguousarray(q[:, 1]),
        np.sin(angles),
        np.cos(angles),
        int(lo_prev[0]),
        int(lo_next[0]),
        int(hi_prev[0]),
        int(hi_next[0]),
    )  # (angles, 4): the values at those ranks
    ones = np.ones(len(angles))
    lo = quantile_lerp(stats[:, 0], stats[:, 1], lo_gamma[0] * ones)
    hi = quantile_lerp(stats[:, 2], stats[:, 3], hi_gamma[0] * ones)
    return lo, hi


def sorted_median(
    values: NDArray[np.float64], start: NDArray[np.intp], count: NDArray[np.intp]
) -> NDArray[np.float64]:
    """``np.median`` of every group of ``values`` sorted within its group (the middle
    value, or the mean of the two middle ones)."""
    half = count // 2
    odd = count % 2 == 1
    hi = values[start + half]
    lo = values[start + np.maximum(half - 1, 0)]
    return np.where(odd, hi, (lo + hi) / 2.0)


#: Fewest points of a slice of a band that give its two edges.
_EDGE_SLICE_MIN_POINTS = 8


def edge_line_direction(
    q: NDArray[np.float64], ang0: float, bin_m: float, slice_points: int = 40
) -> float:
    """Direction of a band's two edges near ``ang0``, robust to what pokes out of it.

    The band (``(m, 2)`` in-plane points) is cut along ``ang0`` into slices
    holding about ``slice_points`` points each (6 to 24 slices, at least 5 cm
    or 5 bins long); the low and high edges of every slice (2 / 98 %
    quantiles across) are two lines of points.  Each line's slope is a
    repeated median of its pairwise slopes (Siegel: right with up to half the
    slices wrong), and the two are averaged with weights from the inverse
    square of their scatter about their line (median absolute deviation, plus
    a tenth of a bin): slices where a coplanar face of another member joins
    the band (the face of a post flush with a tie beam's), where a shadow
    takes one edge away or where a mitred end cuts an edge back are outliers
    of the median and make that edge the less straight one, whereas they pull
    the extent that :func:`sharpest_direction` minimises (a few per cent of
    the points past one end tilt the band by degrees).  An in-plane bow gives
    the chord's direction.  ``ang0`` is returned when fewer than 4 slices hold
    enough points.
    """
    d = np.array([np.cos(ang0), np.sin(ang0)])
    n = np.array([-np.sin(ang0), np.cos(ang0)])
    t, s = q @ d, q @ n
    t_lo, t_hi = float(t.min()), float(t.max())
    n_slices = int(np.clip(len(q) // max(slice_points, 1), 6, 24))
    step = max((t_hi - t_lo) / n_slices, 0.05, 5.0 * bin_m)
    k = np.minimum(((t - t_lo) / step).astype(np.int64), max(int((t_hi - t_lo) / step), 0))
    count = np.bincount(k)
    start = np.concatenate([[0], np.cumsum(count)[:-1]])
    full = count >= _EDGE_SLICE_MIN_POINTS
    if int(full.sum()) < 4:
        return float(ang0)
    # each slice's values sorted once (by slice, then value): its median along and
    # its 2 / 98 % quantiles across, by numpy's own formulas (one call per band,
    # not three per slice: 4,321 small np.quantile calls took 1.1 s on a 1 M-point roof)
    tm = sorted_median(t[np.lexsort((t, k))], start[full], count[full])
    s_sorted = s[np.lexsort((s, k))]
    edges = np.array([sorted_quantile(s_sorted, start[full], count[full], q)
                      for q in (0.02, 0.98)])  # fmt: skip  (2, slices)
    dt = tm[None, :] - tm[:, None]
    pair = np.abs(dt) > 0.25 * step
    rows = pair.any(axis=1)
    slopes, spreads = [], []
    n_pairs = pair[rows].sum(axis=1)
    row_start = np.arange(len(n_pairs)) * pair.shape[1]
    for e in edges:
        pairwise = np.where(pair, (e[None, :] - e[:, None]) / np.where(pair, dt, 1.0), np.nan)
        # repeated medians; each row's median by a sort (NaN last), not np.nanmedian
        row_median = sorted_median(np.sort(pairwise[rows], axis=1).ravel(), row_start, n_pairs)
        slope = float(np.median(row_median))
        res = e - slope * tm
        res -= np.median(res)
        slopes.append(slope)
        spreads.append(float(np.median(np.abs(res))))
    # the straighter edge counts more (a mitred end or a flush face bends one)
    wts = 1.0 / np.square(np.asarray(spreads) + 0.1 * bin_m)
    return float(ang0) + float(np.arctan(np.dot(wts, slopes) / wts.sum()))


def split_facet(
    xyz: NDArray[np.float64],
    index: NDArray[np.int64],
    params: BeamParams,
    *,
    spacing_m: float,
    parent: int = 0,
    rng: np.random.Generator | None = None,
) -> list[StraightFacet]:
    """Cut an L-, T-, X- or Y-shaped planar facet into straight bands.

    Parameters
    ----------
    xyz
        ``(N, 3)`` all points, metres.
    index
        Indices of the facet's points.
    params
        :class:`BeamParams` (width range, elongation, angle step).
    spacing_m
        Point spacing, metres (sets the profile bin).
    parent
        Facet id recorded in the output.
    rng
        For the subsample of the direction search.

    Returns
    -------
    list of StraightFacet
        Longest band first; points in no band are left out (back to the pool).

    Notes
    -----
    The thesis rasterised the facet and ran a Hough line transform on it, then
    paired edges.  Here the Hough accumulator is built directly on the points:
    for each direction, the histogram of offsets across it; a straight face of a
    beam is the direction and offset with the densest line of points (the
    longest beam wins).  Its direction is refined by the narrowest extent
    (:func:`sharpest_direction`) and then by the robust lines of its two
    edges (:func:`edge_line_direction`).  Its width is read at half the
    band's density, the band is cut along its length at gaps, removed, and
    the search starts again on the rest.  No raster, no edge pairing, no width given by the user.
    """
    gen = rng if rng is not None else np.random.default_rng(0)
    pts = xyz[index]
    c, _, inplane = plane_frame(pts)
    q_all = (pts - c) @ inplane.T
    remaining = np.ones(len(index), dtype=bool)
    out: list[StraightFacet] = []
    bin_m = max(spacing_m, 0.004)
    step = np.radians(params.angle_step_deg)
    coarse = np.arange(0.0, np.pi, step)
    min_pts = params.min_facet_points
    for _ in range(64):  # bands per facet; a facet of a roof holds a handful
        live = np.flatnonzero(remaining)
        if len(live) < min_pts:
            break
        sub = live if len(live) <= 4000 else gen.choice(live, 4000, replace=False)
        ang, _ = best_direction(q_all[sub], coarse, 2 * bin_m)
        fine = ang + np.linspace(-step, step, 21)
        ang, off = best_direction(q_all[sub], fine, bin_m)
        s = q_all[live] @ np.array([-np.sin(ang), np.cos(ang)])
        near = np.abs(s - off) < params.max_beam_width_m
        if near.sum() < min_pts:
            remaining[live] = False
            break
        lo, hi = half_max_edges(s[near], bin_m)
        # refine the direction: the sharpest across-profile of the band's points
        in_band = (s >= lo - 1.5 * bin_m) & (s <= hi + 1.5 * bin_m)
        cand = live[in_band]
        if len(cand) > 3000:
            cand = gen.choice(cand, 3000, replace=False)
        ang = sharpest_direction(q_all[cand], ang, np.radians(6.0), bin_m, n_angles=41)
        ang = sharpest_direction(q_all[cand], ang, np.radians(0.3), bin_m)
        ang = edge_line_direction(q_all[cand], ang, bin_m)
        d2 = np.array([np.cos(ang), np.sin(ang)])
        n2 = np.array([-np.sin(ang), np.cos(ang)])
        s = q_all[live] @ n2
        off = float(np.median(s[in_band]))
        near = np.abs(s - off) < params.max_beam_width_m
        lo, hi = half_max_edges(s[near], bin_m)
        width = hi - lo
        in_band = (s >= lo - 1.5 * bin_m) & (s <= hi + 1.5 * bin_m)
        band = live[in_band]
        qb = q_all[band]
        t = qb @ d2
        order = np.argsort(t)
        gaps = np.flatnonzero(np.diff(t[order]) > max(2.0 * width, 20 * bin_m))
        runs = np.split(order, gaps + 1)
        accepted = False
        for run in runs:
            r_idx = band[run]
            length = float(t[run[-1]] - t[run[0]])
            ok_w = params.min_beam_width_m <= width <= params.max_beam_width_m
            if len(run) >= min_pts and ok_w and length >= params.min_elongation * width:
                # the band's own plane: a merged facet may hold faces a few
                # millimetres apart (T joints of members of unequal thickness)
                c_run, n_run, _ = plane_frame(pts[r_idx])
                # ... or centimetres apart (a strut's face behind the face of the
                # post it runs into): the band keeps the points of its own plane
                # and leaves the other face's points to its own band
                on = on_own_plane(pts[r_idx])
                d_run, w_run = d2, width
                if not on.all() and on.sum() >= min_pts:
                    # the direction and width were measured with the other
                    # face's points: measure them again on the band's own
                    r_idx = r_idx[on]
                    c_run, n_run, _ = plane_frame(pts[r_idx])
                    q_run = q_all[r_idx]
                    a_run = sharpest_direction(q_run, ang, np.radians(6.0), bin_m, n_angles=41)
                    a_run = sharpest_direction(q_run, a_run, np.radians(0.3), bin_m)
                    a_run = edge_line_direction(q_run, a_run, bin_m)
                    d_run = np.array([np.cos(a_run), np.sin(a_run)])
                    lo_r, hi_r = half_max_edges(
                        q_run @ np.array([-np.sin(a_run), np.cos(a_run)]), bin_m
                    )
                    t_on = q_run @ d_run
                    length = float(t_on.max() - t_on.min())
                    if params.min_beam_width_m <= hi_r - lo_r <= params.max_beam_width_m:
                        w_run = hi_r - lo_r
                axis3 = d_run @ inplane
                axis3 -= (axis3 @ n_run) * n_run
                rms = float(np.sqrt(np.mean(((pts[r_idx] - c_run) @ n_run) ** 2)))
                out.append(
                    StraightFacet(
                        index=index[r_idx],
                        normal=n_run,
                        axis=axis3 / np.linalg.norm(axis3),
                        centre=c_run,
                        width=float(w_run),
                        length=length,
                        plane_rms=rms,
                        parent=parent,
                    )
                )
                remaining[r_idx] = False
                accepted = True
        if not accepted:
            # the densest band is no beam face: drop its points from the search
            remaining[band] = False
    return out
