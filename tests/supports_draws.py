"""Test helpers of the supports tests: a supports family draw segmented by step 2 and
scored as the benchmark scores it (the draw-based tests of ``test_supports_face_rise``,
``test_supports_round_shaft`` and ``test_supports_outline_kind``), and the extraction of
a synthetic pier piece (``test_supports_wall_over_lintels``,
``test_supports_sparse_wall_faces``)."""

from __future__ import annotations

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
    sc = scales(step, params)
    sh = {"class": "pier", "centre": np.zeros(2), "angle": 0.0, "half": half.copy(),
          "circularity": 1.3}  # fmt: skip
    sh["buffer"] = max(params.buffer_min_m, params.pier_buffer_fraction * float(half.max()))
    order = np.argsort(p[:, 2], kind="stable")
    z_sorted = p[order, 2]

    def band(z_lo: float, z_hi: float) -> np.ndarray:
        a, b = np.searchsorted(z_sorted, [z_lo, z_hi])
        return order[a:b]

    (idx, rho, ang), = cookies(p, [sh], params)  # fmt: skip
    kept = extract_support(p, idx, rho, ang, sh, params, sc, h_sec, z_span, band)
    return kept, sh
