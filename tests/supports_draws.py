"""Test helpers of the supports tests: a supports family draw segmented by step 2 and
scored as the benchmark scores it (the draw-based tests of ``test_supports_face_rise``,
``test_supports_round_shaft`` and ``test_supports_outline_kind``), and the extraction of
a synthetic pier piece (``test_supports_wall_over_lintels``,
``test_supports_sparse_wall_faces``), and the walled bands of a synthetic pier piece
beside walls (``test_supports_flush_face_lines``, ``test_supports_band_under_top``), and
the face lines of sections (``test_supports_responds``, ``test_supports_respond_back``),
and the shafts and pulpit tubs of synthetic rooms (``test_supports_carried``,
``test_supports_shaft_above``)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np


def scored_supports_draw(seed: int, **overrides: Any) -> dict:
    """The scores of :func:`~pyheracles.synthetic.families.supports_score.score_supports`
    for draw ``seed`` of the supports family (``overrides`` such as ``noise_draw``),
    segmented by :func:`~pyheracles.building.segment_building`, its attic given."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate
    from pyheracles.synthetic.families.supports_score import score_supports

    sim = simulate("supports", seed, **overrides)
    seg, found, _, _ = segment_building(sim.clouds["cloud"].xyz)
    return score_supports(
        sim, found.instance, found.objects, section_height=found.section_height,
        attic_mask=seg.class_id == 2,
    )  # fmt: skip


def height_bands(p: np.ndarray) -> Callable[[float, float], np.ndarray]:
    """``band(z_lo, z_hi)``: the indices of the points of ``p`` between two heights, from
    one sort by height (what step 2 passes to its band tests)."""
    order = np.argsort(p[:, 2], kind="stable")
    z_sorted = p[order, 2]

    def band(z_lo: float, z_hi: float) -> np.ndarray:
        a, b = np.searchsorted(z_sorted, [z_lo, z_hi])
        return order[a:b]

    return band


def pier_shape(half: np.ndarray, params: Any, **extra: Any) -> dict:
    """The section shape of a pier piece centred at the origin along x (half sides
    ``half``, metres) with step 2's buffer for it (``params``: ``SupportParams``)."""
    sh = {"class": "pier", "centre": np.zeros(2), "angle": 0.0, "half": half.copy(), **extra}
    sh["buffer"] = max(params.buffer_min_m, params.pier_buffer_fraction * float(half.max()))
    return sh


def extract_pier_piece(
    p: np.ndarray, half: np.ndarray, step: float, h_sec: float, z_span: tuple[float, float]
) -> tuple[object, dict]:
    """:func:`~pyheracles.supports.cookies.extract_support` of a pier piece centred at the
    origin along x (half sides ``half``, metres) found in the section at ``h_sec`` of the
    cloud ``p`` (median spacing ``step``), its body spanning ``z_span``; returns what the
    extraction kept and the piece's section shape."""
    from pyheracles.supports.cookies import cookies, extract_support
    from pyheracles.supports.core import SupportParams, scales

    params = SupportParams()
    sh = pier_shape(half, params, circularity=1.3)
    (idx, rho, ang), = cookies(p, [sh], params)  # fmt: skip
    kept = extract_support(p, idx, rho, ang, sh, params, scales(step, params), h_sec, z_span,
                           height_bands(p))  # fmt: skip
    return kept, sh


def vertical_face(
    fixed: int, at: float, lo: float, hi: float, z0: float, z1: float, step: float
) -> np.ndarray:
    """A grid of points (spacing ``step``) on a vertical face at coordinate ``fixed``
    (0: x, 1: y) = ``at``, from ``lo`` to ``hi`` along the other coordinate and ``z0`` to
    ``z1`` up (metres)."""
    uu, zz = np.meshgrid(np.arange(lo, hi + 1e-9, step), np.arange(z0, z1 + 1e-9, step))
    u = uu.ravel()
    xy = np.c_[np.full(u.size, at), u] if fixed == 0 else np.c_[u, np.full(u.size, at)]
    return np.c_[xy, zz.ravel()]


def piece_among_walls(
    half: np.ndarray, top: float, walls: list[np.ndarray], step: float,
    rng: np.random.Generator, noise_m: float = 0.0035,
) -> np.ndarray:  # fmt: skip
    """A pier piece centred at the origin along x (half sides ``half``), its four faces
    from the floor to ``top``, a 6 x 6 m floor (5 cm grid) and the wall faces ``walls``,
    with Gaussian noise of ``noise_m`` on every coordinate."""
    hx, hy = half
    parts = [
        vertical_face(1, -hy, -hx, hx, 0.0, top, step),
        vertical_face(1, hy, -hx, hx, 0.0, top, step),
        vertical_face(0, -hx, -hy, hy, 0.0, top, step),
        vertical_face(0, hx, -hy, hy, 0.0, top, step),
        *walls,
    ]
    fx, fy = np.meshgrid(np.arange(-3.0, 3.0, 0.05), np.arange(-3.0, 3.0, 0.05))
    parts.append(np.c_[fx.ravel(), fy.ravel(), np.zeros(fx.size)])
    p = np.vstack(parts)
    return p + rng.normal(0.0, noise_m, p.shape)


def walled_bands_of_piece(
    p: np.ndarray, half: np.ndarray, step: float, h_sec: float, top: float
) -> int:
    """:func:`~pyheracles.supports.cookies.walled_band_count` of a pier piece centred at
    the origin along x (half sides ``half``) from the floor to ``top``, found in the
    section at ``h_sec`` of the cloud ``p`` (median spacing ``step``)."""
    from pyheracles.supports.cookies import cookies, walled_band_count
    from pyheracles.supports.core import SupportParams, scales

    params = SupportParams()
    sh = pier_shape(half, params)
    (idx, rho, _), = cookies(p, [sh], params)  # fmt: skip
    return walled_band_count(p, p[idx], rho, sh, scales(step, params), h_sec, (0.0, top),
                             height_bands(p))  # fmt: skip


def section_line(a, b, step: float = 0.02) -> np.ndarray:
    """Points every ``step`` metres (at least 2) on the segment from ``a`` to ``b`` (plan
    coordinates): a face line of a section."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    n = max(2, int(np.hypot(*(b - a)) / step) + 1)
    return a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)


def wall_face(y: float, x_runs, step: float = 0.02) -> np.ndarray:
    """Section points of a wall face along ``y`` over the runs ``(x0, x1)`` of ``x_runs``
    (the gaps between them are openings)."""
    return np.vstack([section_line((x0, y), (x1, y), step) for x0, x1 in x_runs])


def tube(centre, radius: float, z0: float, z1: float, step: float) -> np.ndarray:
    """Points every ``step`` metres round a vertical cylinder of ``radius`` about
    ``centre`` (x, y) from ``z0`` to ``z1``."""
    n = max(8, int(2 * np.pi * radius / step))
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    tt, zz = np.meshgrid(t, np.arange(z0, z1 + 1e-9, step))
    return np.c_[
        centre[0] + radius * np.cos(tt.ravel()), centre[1] + radius * np.sin(tt.ravel()), zz.ravel()
    ]


def tub_sides(centre, z: float, step: float) -> np.ndarray:
    """The four sides of a pulpit's 1.2 x 1.0 m tub about ``centre``, 1.05 m high from
    ``z`` (its underside, level with the scanners, unseen), every ``step`` metres."""
    cx, cy = centre
    up = np.arange(z, z + 1.05 + 1e-9, step)
    out = []
    for x in (cx - 0.6, cx + 0.6):
        u, v = np.meshgrid(np.arange(cy - 0.5, cy + 0.5 + 1e-9, step), up)
        out.append(np.c_[np.full(u.size, x), u.ravel(), v.ravel()])
    for y in (cy - 0.5, cy + 0.5):
        u, v = np.meshgrid(np.arange(cx - 0.6, cx + 0.6 + 1e-9, step), up)
        out.append(np.c_[u.ravel(), np.full(u.size, y), v.ravel()])
    return np.vstack(out)
