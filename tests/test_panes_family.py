"""Pane tie points on church family draws that failed before (issue 14 baseline: 0/30).

Seeds 0 (photogrammetry outside, pointed and round-headed lights, splayed reveals)
and 2 (TLS outside, leaded lights, straight reveals) stopped with "no window pane
corners found"; seed 4 (a coarse exterior TLS, 0.55 deg, windows 7-14 m up) has too
few points on its openings for centimetre tie points and must be refused, not
registered wrongly.  Since the recess ICP (issue 14) seeds 4, 15 and 16 register: their
exterior outlines seen in part (shifted 7-16 cm in the glass plane, or reduced to
jambs) contradicted every outline solution, their raw reveal points agree.
"""

from __future__ import annotations

import numpy as np
import pytest

from church_registration import error_at_interior, register_church
from pyheracles.errors import InputError
from pyheracles.registration.transform import apply_to_points

pytestmark = pytest.mark.slow

RIGID = ("tx", "ty", "tz", "omega", "phi", "kappa")  # the scale is fixed (rigid model)


# 22 and 26: exterior outlines seen in part and single lights of mullioned windows
# (before: refused as contradicted)
@pytest.mark.parametrize("seed", [0, 2, 22, 26])
def test_draws_that_failed_now_register(seed: int) -> None:
    sim, clouds, tp, res = register_church(seed)
    assert tp.details["n_matched_openings"] >= 5
    assert error_at_interior(sim, clouds["interior"], res.T_target_source) < 0.01
    # the report of manual tie points: residuals, standard deviations, sigma0
    assert res.rms()["3d"] < 0.015
    assert all(np.isfinite(res.std[k]) and res.std[k] > 0 for k in RIGID)
    # every tie point is a point of a real window outline seen from both sides
    a = apply_to_points(sim.transforms["interior"], tp.source.xyz)
    b = apply_to_points(sim.transforms["exterior"], tp.target.xyz)
    assert np.median(np.linalg.norm(a - b, axis=1)) < 0.01


@pytest.mark.parametrize("seed", [4, 15, 16])
def test_the_recess_icp_rescues_shifted_outlines(seed: int) -> None:
    """Refused before the recess ICP (outlines contradicted); now right to a centimetre,
    verified by the raw points of at least three openings and a unique ICP minimum."""
    sim, clouds, tp, res = register_church(seed)
    assert tp.details["method"] == "recess_icp"
    assert tp.details["n_recess_verified"] >= 3
    assert tp.details["recess_basin_m"] < 0.005
    assert error_at_interior(sim, clouds["interior"], res.T_target_source) < 0.01
    assert res.rms()["3d"] < 0.015


@pytest.mark.parametrize("seed", [4, 15, 24])
def test_a_transform_is_right_or_refused(seed: int) -> None:
    """Seed 4: too few exterior points on the openings; 15: exterior outlines reduced to
    jambs (a pane can slide along them: once returned 13 cm off); 24: three openings on
    one wall, one with a reveal depth 5 cm short (once returned 5 cm off; on the per-ray
    noise draw 4.6 cm off, now refused: the turn about the wall's horizontal axis is
    loose, see ``test_panes_loose_pose``)."""
    try:
        sim, clouds, _tp, res = register_church(seed)
    except InputError as exc:
        assert "no trustworthy match" in str(exc) or "disagree" in str(exc)
        return
    assert error_at_interior(sim, clouds["interior"], res.T_target_source) < 0.015
