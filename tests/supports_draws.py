"""A supports family draw segmented by step 2 and scored as the benchmark scores it
(test helper: the draw-based tests of ``test_supports_face_rise``,
``test_supports_round_shaft`` and ``test_supports_outline_kind``)."""

from __future__ import annotations

from typing import Any


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
