"""A colonnade seen only below the height search's range (supports draw 2): the note
says that no height held a persistent support island, not that candidates were short."""

from __future__ import annotations

import numpy as np

from pyheracles.supports import detect_supports
from supports_draws import vertical_face

STEP = 0.03  # point spacing, metres


def portico(seen_top: float, rng: np.random.Generator) -> np.ndarray:
    """Supports draw 2's geometry: five piers 0.6 x 0.5 m on a bay of 1.11 m along the
    open front of a 7.8 x 5.7 m portico, walls 2.5 m high on the three other sides, a
    gable roof from 2.5 m up to 9.3 m over it; the piers' faces seen from the floor up to
    ``seen_top`` (the eaves hang in front of the rest)."""
    parts = []
    for x in 1.68 + 1.11 * np.arange(5):
        for fixed, at, lo, hi in (
            (1, 5.11, x - 0.3, x + 0.3), (1, 5.61, x - 0.3, x + 0.3),
            (0, x - 0.3, 5.11, 5.61), (0, x + 0.3, 5.11, 5.61),
        ):  # fmt: skip
            parts.append(vertical_face(fixed, at, lo, hi, 0.0, seen_top, STEP))
    parts += [
        vertical_face(1, 0.0, 0.0, 7.8, 0.0, 2.5, STEP),
        vertical_face(0, 0.0, 0.0, 5.7, 0.0, 2.5, STEP),
        vertical_face(0, 7.8, 0.0, 5.7, 0.0, 2.5, STEP),
    ]
    fx, fy = np.meshgrid(np.arange(0.0, 7.8, 0.05), np.arange(0.0, 5.7, 0.05))
    parts.append(np.c_[fx.ravel(), fy.ravel(), np.zeros(fx.size)])
    rx, ry = np.meshgrid(np.arange(0.0, 7.8, 0.05), np.arange(0.0, 5.7, 0.02))
    rz = 9.3 - (9.3 - 2.5) * np.abs(ry - 2.85) / 2.85
    parts.append(np.c_[rx.ravel(), ry.ravel(), rz.ravel()])
    p = np.vstack(parts)
    return p + rng.normal(0.0, 0.002, p.shape)


def test_supports_seen_below_every_section_are_said_unseen() -> None:
    found = detect_supports(portico(0.97, np.random.default_rng(2)))
    assert len(found.objects) == 0
    said = [n for n in found.notes if n.startswith("no height between")]
    assert len(said) == 1, found.notes
    assert "lower one at 1.20 m" in said[0]


def test_the_note_is_only_where_nothing_is_found() -> None:
    # seen up to their tops the piers are found from the lower section: no such note
    found = detect_supports(portico(2.5, np.random.default_rng(2)))
    assert len(found.objects) > 0
    assert not any(n.startswith("no height between") for n in found.notes)
