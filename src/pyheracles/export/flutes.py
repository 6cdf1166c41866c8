"""Flutes of a column shaft measured from its points, and the fluted shaft as a mesh.

A fluted shaft's points lie up to the flutes' depth inside the arrises: a smooth
cylinder or solid of revolution through them is off by about a third of that depth
in RMS (1-1.5 cm for the 3-4 cm flutes of a large column), whatever its radius.  The
flutes are measured here from the points' distances to the axis as a periodic signal
around it (their number, where they lie, and their profile, as measured rather than an
assumed shape), so that :mod:`pyheracles.export.ifc` can write the shaft as it is.

The shaft is then written as a closed polygonal face set (IFC4 ``IfcPolygonalFaceSet``):
rings of the fluted outline at the stations of the measured radius profile, joined by
quads.  A swept solid would need a fluted profile swept with a varying scale
(``IfcExtrudedAreaSolidTapered`` per station); the geometry kernel of IfcOpenShell 0.9
prints its topology to standard output for every such solid it reads, which would
flood the terminal of whoever opens the model with it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

__all__ = ["FluteParams", "Flutes", "fluted_shaft_mesh", "measure_flutes"]


@dataclass(frozen=True)
class FluteParams:
    """How flutes are sought.

    Attributes
    ----------
    min_count, max_count
        Flute numbers tried (classical shafts have 16-24 flutes; 8-64 covers
        reeded and channelled shafts too).
    min_amplitude_m
        Smallest half-depth kept, metres: shallower flutes change the surface RMS
        by less than the scanners' noise.
    prominence
        The chosen number's amplitude must be this many times the median amplitude
        of all numbers tried (noise, ellipticity and mouldings spread over all).
    bins
        Bins of the measured profile over one flute.
    vertices_per_flute
        Vertices of the written outline per flute.
    max_points
        Points used for the profile (an even subsample of the shaft's).
    search_points
        Points used to find the number of flutes (a subsample of those).
    """

    min_count: int = 8
    max_count: int = 64
    min_amplitude_m: float = 0.002
    prominence: float = 4.0
    bins: int = 24
    vertices_per_flute: int = 12
    max_points: int = 50_000
    search_points: int = 5_000


@dataclass(frozen=True)
class Flutes:
    """Flutes measured on a shaft.

    Attributes
    ----------
    count
        Number of flutes.
    phase_rad
        Angle (element frame, from x towards y) where the measured profile starts.
    profile_m
        ``(bins,)`` offset of the surface from the fitted radius over one flute,
        metres, zero mean (negative in the flutes, positive at the arrises).
    depth_m
        Depth of the flutes: arris to flute bottom of the profile.
    rms_before_m, rms_after_m
        RMS of the points' radial residuals about the smooth radius and about the
        fluted surface.
    """

    count: int
    phase_rad: float
    profile_m: Array
    depth_m: float
    rms_before_m: float
    rms_after_m: float

    def offset(self, theta: Array) -> Array:
        """Offset of the surface from the smooth radius at angles ``theta`` (periodic
        interpolation of the profile)."""
        b = len(self.profile_m)
        psi = (self.count * np.asarray(theta) - self.phase_rad) % (2 * math.pi)
        pos = psi * (b / (2 * math.pi))
        centres = np.arange(b) + 0.5
        ext = np.r_[centres[-1] - b, centres, centres[0] + b]
        vals = np.r_[self.profile_m[-1], self.profile_m, self.profile_m[0]]
        return np.interp(pos, ext, vals)


def measure_flutes(
    local: Array,
    radius_at: Array,
    params: FluteParams | None = None,
) -> Flutes | None:
    """Flutes of a shaft from its points, or None for a smooth one.

    Parameters
    ----------
    local
        ``(N, 3)`` the shaft's points in its element frame (x, y across the axis, t
        along it).
    radius_at
        ``(N,)`` the smooth radius at each point's height (the fitted cylinder's, or
        the measured profile's).
    params
        :class:`FluteParams`.

    Notes
    -----
    The radial residual of each point (distance to the axis less ``radius_at``) is
    fitted, for each flute number ``n`` tried, by least squares with ``a cos(n
    theta) + b sin(n theta) + c``; the number with the largest amplitude is kept when
    that amplitude is at least ``min_amplitude_m`` and ``prominence`` times the
    median over all numbers.  The profile is then the median residual per bin of the
    flute's phase (bins without 5 points take the fitted cosine), so arrises sharper
    than a cosine are kept as measured.  Points more than 15 % of the radius off the
    smooth surface (a neighbour, a fixture) are left out.
    """
    p = params or FluteParams()
    local = np.asarray(local, dtype=np.float64)
    radius_at = np.asarray(radius_at, dtype=np.float64)
    if len(local) < 20 * p.bins:
        return None
    res = np.hypot(local[:, 0], local[:, 1]) - radius_at
    keep = np.isfinite(res) & (np.abs(res) <= 0.15 * np.abs(radius_at))
    if keep.sum() < 20 * p.bins:
        return None
    idx = np.flatnonzero(keep)
    if len(idx) > p.max_points:
        idx = idx[np.linspace(0, len(idx) - 1, p.max_points).astype(np.intp)]
    theta = np.arctan2(local[idx, 1], local[idx, 0])
    r = res[idx]
    counts = np.arange(p.min_count, p.max_count + 1)
    sub = np.linspace(0, len(r) - 1, min(len(r), p.search_points)).astype(np.intp)
    amp, coef = _harmonic_amplitudes(theta[sub], r[sub], counts)
    k = int(np.argmax(amp))
    if not (amp[k] >= p.min_amplitude_m and amp[k] >= p.prominence * float(np.median(amp))):
        return None
    n = int(counts[k])
    a, b, c = coef[k]
    phase = math.atan2(b, a)  # the cosine's crest (an arris) at n theta = phase
    psi = (n * theta - phase) % (2 * math.pi)
    which = np.minimum((psi * (p.bins / (2 * math.pi))).astype(np.intp), p.bins - 1)
    centres = (np.arange(p.bins) + 0.5) * (2 * math.pi / p.bins)
    prof = c + amp[k] * np.cos(centres)  # the fitted cosine where a bin is sparse
    for j in range(p.bins):
        vals = r[which == j]
        if len(vals) >= 5:
            prof[j] = float(np.median(vals))
    prof = prof - prof.mean()
    fl = Flutes(n, phase, prof, float(np.ptp(prof)), 0.0, 0.0)
    after = r - c - fl.offset(theta)
    return Flutes(
        n,
        phase,
        prof,
        float(np.ptp(prof)),
        float(np.sqrt(np.mean((r - np.median(r)) ** 2))),
        float(np.sqrt(np.mean(after**2))),
    )


def _harmonic_amplitudes(theta: Array, r: Array, counts: NDArray[np.int64]) -> tuple[Array, Array]:
    """Least-squares ``a cos(n theta) + b sin(n theta) + c`` of ``r`` for each ``n``:
    amplitudes ``hypot(a, b)`` and ``(a, b, c)`` per ``n`` (3 x 3 normal equations each,
    so that a shaft seen from one side only is fitted, not Fourier-summed).  All ``n``
    at once, with element-wise sums (no BLAS calls: on short vectors their threads
    cost more than the arithmetic)."""
    ang = counts[:, None].astype(np.float64) * theta[None, :]
    cs, sn = np.cos(ang), np.sin(ang)
    m = float(len(r))
    c1, s1 = cs.sum(axis=1), sn.sum(axis=1)
    ata = np.empty((len(counts), 3, 3))
    ata[:, 0, 0] = (cs * cs).sum(axis=1)
    ata[:, 1, 1] = (sn * sn).sum(axis=1)
    ata[:, 0, 1] = ata[:, 1, 0] = (cs * sn).sum(axis=1)
    ata[:, 0, 2] = ata[:, 2, 0] = c1
    ata[:, 1, 2] = ata[:, 2, 1] = s1
    ata[:, 2, 2] = m
    atb = np.stack([(cs * r).sum(axis=1), (sn * r).sum(axis=1), np.full(len(counts), r.sum())], 1)
    # too little of the turn seen for an n: its cosine and sine are nearly dependent
    ok = np.linalg.det(ata / m) > 1e-6
    coef = np.zeros((len(counts), 3))
    if ok.any():
        coef[ok] = np.linalg.solve(ata[ok], atb[ok][..., None])[..., 0]
    return np.hypot(coef[:, 0], coef[:, 1]), coef


def fluted_shaft_mesh(
    flutes: Flutes,
    stations: Array,
    params: FluteParams | None = None,
) -> tuple[Array, list[list[int]]]:
    """A closed fluted shaft: vertices and polygonal faces (0-based indices).

    ``stations`` are ``(radius, height)`` rows from the shaft's foot to its top (the
    measured radius profile, or the fitted radius at 0 and the length).  Each station
    gets a ring of ``count x vertices_per_flute`` vertices at its radius plus the
    flutes' offset; rings are joined by quads, and the end rings closed by one polygon
    each, wound so that every face's normal points out of the solid.
    """
    p = params or FluteParams()
    m = flutes.count * p.vertices_per_flute
    theta = flutes.phase_rad / flutes.count + np.arange(m) * (2 * math.pi / m)
    off = flutes.offset(theta)
    off = off - off.mean()  # each ring's mean radius is its station's
    stations = np.asarray(stations, dtype=np.float64)
    rings = []
    for radius, height in stations:
        rr = np.maximum(radius + off, 1e-3)
        rings.append(np.column_stack([rr * np.cos(theta), rr * np.sin(theta), np.full(m, height)]))
    verts = np.vstack(rings)
    faces: list[list[int]] = []
    for s in range(len(stations) - 1):
        a, b = s * m, (s + 1) * m
        for j in range(m):
            j1 = (j + 1) % m
            faces.append([a + j, a + j1, b + j1, b + j])  # counter-clockwise seen from outside
    faces.append(list(range(m - 1, -1, -1)))  # the foot, seen from below
    last = (len(stations) - 1) * m
    faces.append(list(range(last, last + m)))  # the top, seen from above
    return verts, faces
