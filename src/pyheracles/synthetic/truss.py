"""Synthetic timber roof frameworks scanned by a terrestrial laser scanner.

A roof of ``n_trusses`` king-post trusses (tie beam, two rafters, king post,
two oblique struts each) joined by a ridge beam and two purlins: with the
default two trusses that is 15 beams touching in L joints (rafter feet on the
tie beam, rafters at the apex), T joints (king post on the tie beam, struts on
the king post and rafters) and X joints (purlins and the ridge beam crossing
rafters and king posts).  Tie beams and king posts have the same thickness, so
their side faces are coplanar and form T-shaped facets, as in real trusses.

The cloud is simulated, not sampled: every scanner position shoots rays on a
regular azimuth/elevation grid (as a TLS does), each ray stops at the first
beam it hits (exact ray/oriented-box intersection, so occlusion and the
density fall-off with range and incidence are real), and Gaussian noise is
added to the points.  The reference is the index of the beam each ray hit and
the true cuboid of every beam (used by tests and ``benchmarks/bench_framework``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from pyheracles.errors import InputError

__all__ = [
    "Beam",
    "SyntheticTruss",
    "TrussParams",
    "default_scanners",
    "make_truss_roof",
    "scan_boxes",
    "truss_beams",
]


@dataclass(frozen=True)
class Beam:
    """A true beam: an oriented cuboid.

    Attributes
    ----------
    name
        ``tie``, ``rafter``, ``king_post``, ``strut``, ``ridge``, ``purlin`` + index.
    centre
        ``(3,)`` centre, metres.
    axis
        ``(3,)`` unit vector along the length.
    up
        ``(3,)`` unit vector along the height, orthogonal to ``axis``; the width
        runs along ``cross(axis, up)``.
    length, width, height
        Edge lengths, metres.
    """

    name: str
    centre: NDArray[np.float64]
    axis: NDArray[np.float64]
    up: NDArray[np.float64]
    length: float
    width: float
    height: float

    @property
    def side(self) -> NDArray[np.float64]:
        """Unit vector along the width."""
        return np.cross(self.axis, self.up)

    @property
    def rotation(self) -> NDArray[np.float64]:
        """``(3, 3)`` matrix whose columns are ``axis``, ``side``, ``up``."""
        return np.column_stack([self.axis, self.side, self.up])

    @property
    def half_extents(self) -> NDArray[np.float64]:
        return 0.5 * np.array([self.length, self.width, self.height])


def _beam_between(
    name: str, start: NDArray, end: NDArray, width: float, height: float, up_hint: NDArray
) -> Beam:
    """Beam whose axis runs from ``start`` to ``end`` (centre line), height near ``up_hint``."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    axis = end - start
    length = float(np.linalg.norm(axis))
    axis /= length
    up = np.asarray(up_hint, float) - np.dot(up_hint, axis) * axis
    up /= np.linalg.norm(up)
    return Beam(name, 0.5 * (start + end), axis, up, length, width, height)


@dataclass(frozen=True)
class TrussParams:
    """Geometry and scanning of the synthetic roof.

    Attributes
    ----------
    n_trusses
        King-post trusses (6 beams each) plus one ridge beam and two purlins.
    span_m
        Distance between the rafter feet, metres.
    truss_spacing_m
        Distance between trusses along x, metres.
    pitch_deg
        Roof slope, degrees.
    tie_height_m
        Height of the tie beam's centre line above the floor, metres.
    scanner_height_m
        Height of the scanner's optical centre, metres.
    n_scanners
        2 or 3 scanner positions below the trusses.
    n_points
        Approximate number of points in the final cloud.
    noise_m
        Standard deviation of the Gaussian noise on every coordinate, metres.
    """

    n_trusses: int = 2
    span_m: float = 6.0
    truss_spacing_m: float = 3.2
    pitch_deg: float = 40.0
    tie_height_m: float = 3.0
    scanner_height_m: float = 1.6
    n_scanners: int = 3
    n_points: int = 200_000
    noise_m: float = 0.003


@dataclass(frozen=True)
class SyntheticTruss:
    """A scanned roof with its ground truth.

    Attributes
    ----------
    xyz
        ``(N, 3)`` points, metres.
    labels
        ``(N,)`` int32 reference beam id (1-based index into ``beams``).
    scanner
        ``(N,)`` int8 index of the scanner position that measured each point.
    scanners
        ``(S, 3)`` scanner positions.
    beams
        The true cuboids.
    params
        The parameters used.
    """

    xyz: NDArray[np.float64]
    labels: NDArray[np.int32]
    scanner: NDArray[np.int8]
    scanners: NDArray[np.float64]
    beams: tuple[Beam, ...]
    params: TrussParams = field(default_factory=TrussParams)


def truss_beams(params: TrussParams) -> list[Beam]:
    """The true beams of the roof described by ``params`` (trusses in y-z planes)."""
    half = params.span_m / 2.0
    tan = np.tan(np.radians(params.pitch_deg))
    cos = np.cos(np.radians(params.pitch_deg))
    h0 = params.tie_height_m
    z, y, x = np.array([0.0, 0, 1]), np.array([0.0, 1, 0]), np.array([1.0, 0, 0])
    tie_w, tie_h = 0.18, 0.22
    raf_w, raf_h = 0.16, 0.18
    kp_w = 0.18
    strut_w, strut_h = 0.12, 0.14
    # rafter centre line: passes above the tie beam end and meets the other at the apex
    foot_z = h0 + tie_h / 2 + raf_h / (2 * cos) - 0.06
    apex_z = foot_z + half * tan
    beams: list[Beam] = []
    xs = np.arange(params.n_trusses) * params.truss_spacing_m
    for i, xt in enumerate(xs):
        c = np.array([xt, 0.0, 0.0])
        beams.append(
            Beam(f"tie{i}", c + np.array([0, 0, h0]), y, z, params.span_m + 0.5, tie_w, tie_h)
        )
        for s, sgn in (("l", -1.0), ("r", 1.0)):
            foot = c + np.array([0, sgn * (half - 0.05), foot_z])
            # extend past the apex so the two rafters interpenetrate (halved joint)
            d = np.array([0, -sgn, tan]) / np.hypot(1.0, tan)
            top = c + np.array([0, 0, apex_z]) + 0.07 * d
            beams.append(_beam_between(f"rafter{i}{s}", foot, top, raf_w, raf_h, z))
        kp_bottom = c + np.array([0, 0, h0 + tie_h / 2])
        kp_top = c + np.array([0, 0, apex_z - 0.10])
        beams.append(_beam_between(f"king_post{i}", kp_bottom, kp_top, kp_w, kp_w, x))
        for s, sgn in (("l", -1.0), ("r", 1.0)):
            # from the foot of the king post to the rafter's lower face, nearly
            # square to the rafter as in real king-post trusses
            low = c + np.array([0, sgn * (kp_w / 2 - 0.02), h0 + tie_h / 2 + 0.32])
            yy = sgn * half * 0.36
            z_raf = foot_z + (half - abs(yy)) * tan - raf_h / (2 * cos)
            high = c + np.array([0, yy, z_raf + 0.03])
            beams.append(_beam_between(f"strut{i}{s}", low, high, strut_w, strut_h, x))
    x0, x1 = xs[0] - 0.45, xs[-1] + 0.45
    ridge_z = apex_z - 0.10
    beams.append(_beam_between("ridge", [x0, 0, ridge_z], [x1, 0, ridge_z], 0.14, 0.20, z))
    for s, sgn in (("l", -1.0), ("r", 1.0)):
        yy = sgn * half * 0.62
        zz = foot_z + (half - abs(yy)) * tan - 0.02
        normal = np.array([0.0, sgn * tan, 1.0])  # roof normal on that side
        beams.append(_beam_between(f"purlin{s}", [x0, yy, zz], [x1, yy, zz], 0.14, 0.22, normal))
    return beams


def default_scanners(params: TrussParams) -> NDArray[np.float64]:
    """The ``params.n_scanners`` default scanner positions ``(S, 3)`` below the trusses."""
    xs = np.arange(params.n_trusses) * params.truss_spacing_m
    zc = params.scanner_height_m
    half = params.span_m / 2.0
    pts = [
        [xs[0] - 2.2, -0.35 * half, zc],
        [xs[-1] + 2.2, 0.35 * half, zc],
        [0.5 * (xs[0] + xs[-1]) + 0.3, 0.55 * half, zc],
    ]
    return np.array(pts[: params.n_scanners], dtype=np.float64)


def scan_boxes(
    beams: list[Beam] | tuple[Beam, ...],
    scanner: NDArray[np.float64],
    step_rad: float,
    *,
    chunk: int = 100_000,
) -> tuple[NDArray[np.float64], NDArray[np.int32]]:
    """First hits of a regular azimuth/elevation ray grid on a set of cuboids.

    Parameters
    ----------
    beams
        Cuboids to intersect.
    scanner
        ``(3,)`` optical centre, metres.
    step_rad
        Angular step of the grid in azimuth and elevation, radians.
    chunk
        Rays per vectorised batch (memory bound).

    Returns
    -------
    points, beam_index
        Noise-free hit points and the 0-based index of the beam hit.
    """
    o = np.asarray(scanner, dtype=np.float64)
    rot = np.stack([b.rotation for b in beams])  # (B, 3, 3)
    half = np.stack([b.half_extents for b in beams])  # (B, 3)
    ctr = np.stack([b.centre for b in beams])
    # angular window of every box corner seen from the scanner
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    corners = ctr[:, None] + np.einsum("bij,bcj->bci", rot, signs[None] * half[:, None])
    v = corners.reshape(-1, 3) - o
    az = np.arctan2(v[:, 1], v[:, 0])
    el = np.arctan2(v[:, 2], np.hypot(v[:, 0], v[:, 1]))
    # azimuth window: the smallest arc holding all corners
    az_s = np.sort(az)
    gaps = np.diff(np.concatenate([az_s, az_s[:1] + 2 * np.pi]))
    g = int(gaps.argmax())
    az0 = az_s[(g + 1) % len(az_s)]
    span = 2 * np.pi - gaps[g]
    n_az = int(np.ceil(span / step_rad)) + 1
    el_grid = np.arange(el.min(), el.max() + step_rad, step_rad)
    az_grid = az0 + np.arange(n_az) * step_rad
    o_local = np.einsum("bji,bj->bi", rot, o - ctr)  # (B, 3)
    pts_out, lab_out = [], []
    AZ, EL = np.meshgrid(az_grid, el_grid, indexing="ij")
    AZ, EL = AZ.ravel(), EL.ravel()
    for start in range(0, len(AZ), chunk):
        a, e = AZ[start : start + chunk], EL[start : start + chunk]
        d = np.column_stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
        d_local = np.einsum("bji,rj->rbi", rot, d)  # (R, B, 3)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / d_local
            t1 = (-half[None] - o_local[None]) * inv
            t2 = (half[None] - o_local[None]) * inv
        tnear = np.nanmax(np.minimum(t1, t2), axis=2)
        tfar = np.nanmin(np.maximum(t1, t2), axis=2)
        hit = (tnear <= tfar) & (tnear > 1e-6)
        tn = np.where(hit, tnear, np.inf)
        best = tn.argmin(axis=1)
        tbest = tn[np.arange(len(d)), best]
        ok = np.isfinite(tbest)
        pts_out.append(o + d[ok] * tbest[ok, None])
        lab_out.append(best[ok].astype(np.int32))
    return np.concatenate(pts_out), np.concatenate(lab_out)


def make_truss_roof(
    params: TrussParams | None = None,
    *,
    scanners: NDArray[np.float64] | None = None,
    rng: np.random.Generator | int | None = 0,
) -> SyntheticTruss:
    """Scan a synthetic king-post truss roof.

    Parameters
    ----------
    params
        Geometry, scanning and noise (:class:`TrussParams`).
    scanners
        ``(S, 3)`` scanner positions; default: ``params.n_scanners`` positions
        below the trusses, chosen so every beam shows at least two faces.
    rng
        Seed or generator for the noise.

    Returns
    -------
    SyntheticTruss

    Examples
    --------
    >>> roof = make_truss_roof(TrussParams(n_points=20_000))
    >>> len(roof.beams), roof.labels.min() >= 1
    (15, True)
    """
    p = params or TrussParams()
    if p.n_trusses < 1:
        raise InputError(f"n_trusses must be at least 1, got {p.n_trusses}")
    if p.n_points < 100:
        raise InputError(f"n_points must be at least 100, got {p.n_points}")
    if p.noise_m < 0:
        raise InputError(f"noise_m must be >= 0, got {p.noise_m}")
    gen = np.random.default_rng(rng)
    beams = truss_beams(p)
    scn = default_scanners(p) if scanners is None else np.asarray(scanners, float).reshape(-1, 3)
    if len(scn) == 0:
        raise InputError("at least one scanner position is needed")
    # calibrate the angular step: hits scale with 1 / step^2
    probe = np.radians(0.5)
    n_probe = sum(len(scan_boxes(beams, s, probe)[1]) for s in scn)
    if n_probe == 0:
        raise InputError("no ray from the scanner positions hits a beam")
    step = probe * np.sqrt(n_probe / p.n_points)
    xyz, lab, sid = [], [], []
    for i, s in enumerate(scn):
        pts, b = scan_boxes(beams, s, step)
        xyz.append(pts)
        lab.append(b + 1)
        sid.append(np.full(len(b), i, dtype=np.int8))
    pts = np.concatenate(xyz)
    pts = pts + gen.normal(scale=p.noise_m, size=pts.shape)
    return SyntheticTruss(
        xyz=pts,
        labels=np.concatenate(lab).astype(np.int32),
        scanner=np.concatenate(sid),
        scanners=scn,
        beams=tuple(beams),
        params=p,
    )
