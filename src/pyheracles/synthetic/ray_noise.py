"""Random numbers that belong to one ray of the scan simulator.

Every draw of a simulated point (detection, range noise, glass, mixed pixels,
photo matching) is a function of the acquisition's key, the ray's grid
indices and a stream number, so a ray that hits differently on another CPU
changes only its own point.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import ndtri

__all__ = ["acquisition_key", "ray_ids", "ray_normal", "ray_uniform"]

Array = NDArray[np.float64]

# Why hand-written and not a numpy Generator: a Generator hands out numbers in
# sequence, so the noise of a point would depend on how many rays hit before it.
# Embree's hits at triangle edges differ between instruction sets (AVX2 vs
# AVX-512 builds of the same intersector), so one ray more or less on another CPU
# shifted every later point's noise and made the generated families differ from
# machine to machine. A counter-based hash gives each ray its own numbers: a ray
# that hits differently changes its own point only. numpy offers counter-based
# bit generators (Philox) but no way to evaluate them per element.
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_STREAM = np.uint64(0xD1B54A32D192ED03)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


def ray_ids(outer: ArrayLike, inner: ArrayLike) -> NDArray[np.uint64]:
    """One 64-bit id per ray from its two grid indices (e.g. azimuth column, elevation row)."""
    a = np.asarray(outer).astype(np.uint64)
    b = np.asarray(inner).astype(np.uint64)
    return (a << np.uint64(32)) | b


def ray_uniform(key: int, rays: NDArray[np.uint64], stream: int) -> Array:
    """Uniform numbers in (0, 1), one per ray, that depend only on (key, ray, stream).

    SplitMix64's finaliser (Steele, Lea and Flood 2014) applied to the ray id
    offset by the key and the stream: different streams of the same ray are
    independent draws.

    Parameters
    ----------
    key
        The acquisition's key (drawn once from the scan's generator).
    rays
        Ray ids (:func:`ray_ids`).
    stream
        Which draw of the ray (detection, noise, glass layer ...).

    Examples
    --------
    >>> u = ray_uniform(7, ray_ids([0, 0, 1], [0, 1, 0]), 0)
    >>> bool(((u > 0) & (u < 1)).all()), len(set(u.tolist()))
    (True, 3)
    >>> bool((ray_uniform(7, ray_ids([1], [0]), 0) == u[2]).all())
    True
    """
    with np.errstate(over="ignore"):
        x = rays * _GOLDEN + np.uint64(key) + np.uint64(stream) * _STREAM
        x = (x ^ (x >> np.uint64(30))) * _MIX1
        x = (x ^ (x >> np.uint64(27))) * _MIX2
        x = x ^ (x >> np.uint64(31))
    return ((x >> np.uint64(11)).astype(np.float64) + 0.5) * 2.0**-53


def ray_normal(key: int, rays: NDArray[np.uint64], stream: int) -> Array:
    """Standard normal numbers, one per ray (:func:`ray_uniform` through the normal quantile)."""
    return ndtri(ray_uniform(key, rays, stream))


def acquisition_key(rng: np.random.Generator) -> int:
    """The key of one acquisition: one draw of the scan's generator, whatever it hits."""
    return int(rng.integers(0, 2**63))
