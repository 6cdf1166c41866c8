"""``noise_draw``: the same scene of a family scanned again with other random numbers.

Rules of the segmentation were fitted to the one noise draw each scene had; a family's
``noise_draw`` parameter rescans the scene (geometry, stations, targets unchanged) so that
a rule can be checked over the noise of its scene.  ``noise_draw=0`` is the draw's own
scan, the cloud every benchmark and baseline used.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.errors import InputError
from pyheracles.synthetic.families import church, roof, supports

SMALL = {
    "supports": (supports, 7, {"points_target": 300_000}),
    "roof": (roof, 3, {"n_points": 40_000}),
}


def _scene_key(sim) -> tuple:
    """What must not change between noise draws: the geometry and its objects (what
    the scan saw of each object, recorded in some families, may change)."""
    sc = sim.scene
    return (
        sc.triangles.tobytes(),
        sc.triangle_instance.tobytes(),
        sc.triangle_class.tobytes(),
        tuple((o["instance"], o["class"]) for o in sc.objects),
    )


@pytest.mark.parametrize("name", sorted(SMALL))
def test_noise_draw_rescans_the_same_scene(name: str) -> None:
    family, seed, small = SMALL[name]
    own = family.draw(seed, **small)
    zero = family.draw(seed, noise_draw=0, **small)
    other = family.draw(seed, noise_draw=1, **small)
    again = family.draw(seed, noise_draw=1, **small)
    third = family.draw(seed, noise_draw=2, **small)
    a, b, c, d = (s.clouds["cloud"].xyz for s in (own, other, again, third))
    # noise_draw 0 is the draw's own scan, bit for bit
    assert np.array_equal(zero.clouds["cloud"].xyz, a)
    # the same scene, other points; the same noise draw twice gives the same points
    assert _scene_key(own) == _scene_key(other) == _scene_key(third)
    assert np.array_equal(b, c)
    for x in (b, d):
        assert not np.array_equal(x, a)
        assert abs(len(x) - len(a)) < 0.03 * len(a)  # the same survey: as many points
    assert not np.array_equal(b, d)
    # the same surfaces: each rescan's points lie on the first scan's (within the noise
    # and the spacing), not somewhere else
    from scipy.spatial import cKDTree

    gap = cKDTree(a).query(b[:: max(1, len(b) // 5000)])[0]
    assert np.median(gap) < 0.05


@pytest.mark.parametrize("bad", [-1, 1.5, True, "two"])
@pytest.mark.parametrize("family", [supports, roof, church], ids=lambda f: f.__name__)
def test_noise_draw_must_be_a_whole_number(family, bad) -> None:
    resolve = roof.resolve_params if family is roof else family.draw_params
    with pytest.raises(InputError, match="noise_draw"):
        resolve(0, noise_draw=bad)


@pytest.mark.slow
def test_church_noise_draw_keeps_targets_and_geometry() -> None:
    own, other = church.draw(0), church.draw(0, noise_draw=1)
    assert _scene_key(own) == _scene_key(other)
    assert np.allclose(own.transforms["interior"], other.transforms["interior"])
    for name in ("interior", "exterior"):
        a, b = own.clouds[name].xyz, other.clouds[name].xyz
        assert not np.array_equal(a, b)
        assert abs(len(a) - len(b)) < 0.03 * len(a)
