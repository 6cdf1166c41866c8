"""Cloth Simulation Filter (Zhang et al. 2016) through the ``cloth-simulation-filter`` package.

The cloud is turned upside down and a cloth of ``cloth_resolution_m`` particles is dropped
on it; points within ``class_threshold_m`` of the settled cloth are ground.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.errors import InputError

__all__ = ["CSFParams", "csf"]


@dataclass(frozen=True)
class CSFParams:
    """Parameters of the Cloth Simulation Filter.

    Defaults are those of the ``cloth-simulation-filter`` package (Zhang et al. 2016;
    the thesis, Murtiyoso 2020, used CSF with hand-set values of this kind).

    Attributes
    ----------
    cloth_resolution_m
        Distance between cloth particles, metres (1.0). About the point spacing or a
        few times it; larger = faster and smoother, but small ground features are lost.
    rigidness
        Cloth stiffness: 1 steep terrain, 2 relief, 3 flat (urban) terrain (3).
    class_threshold_m
        Largest distance of a ground point from the cloth, metres (0.5).
    iterations
        Maximum number of simulation steps (500); the simulation stops earlier once the
        cloth no longer moves.
    time_step
        Simulation time step (0.65).
    slope_smooth
        Post-process the cloth on steep slopes (``bSloopSmooth``; True).
    remove_low_outliers
        Leave points far below the terrain out of the simulation (they become off-ground):
        each one holds the inverted cloth up like a tent pole. Not part of CSF (False, the
        package's behaviour); the automatic parameters switch it on. See
        :func:`~pyheracles.groundfilters.smrf.low_outliers`.
    """

    cloth_resolution_m: float = 1.0
    rigidness: int = 3
    class_threshold_m: float = 0.5
    iterations: int = 500
    time_step: float = 0.65
    slope_smooth: bool = True
    remove_low_outliers: bool = False

    def __post_init__(self) -> None:
        if not (np.isfinite(self.cloth_resolution_m) and self.cloth_resolution_m > 0):
            raise InputError(
                f"CSFParams.cloth_resolution_m must be > 0 metres, got {self.cloth_resolution_m!r}"
            )
        if self.rigidness not in (1, 2, 3):
            raise InputError(f"CSFParams.rigidness must be 1, 2 or 3, got {self.rigidness!r}")
        if not (np.isfinite(self.class_threshold_m) and self.class_threshold_m > 0):
            raise InputError(
                f"CSFParams.class_threshold_m must be > 0 metres, got {self.class_threshold_m!r}"
            )
        if int(self.iterations) < 1:
            raise InputError(f"CSFParams.iterations must be >= 1, got {self.iterations!r}")
        if not (np.isfinite(self.time_step) and self.time_step > 0):
            raise InputError(f"CSFParams.time_step must be > 0, got {self.time_step!r}")


@contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Send the C++ library's progress lines (written to file descriptor 1) to /dev/null.

    The CSF extension prints with ``std::cout`` and has no switch for it; library code
    must not print, so the descriptor itself is redirected for the duration of the call.
    """
    sys.stdout.flush()
    try:
        saved = os.dup(1)
    except OSError:  # no stdout at all (daemon): nothing to silence
        yield
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def csf(xyz: NDArray[np.float64], params: CSFParams | None = None) -> NDArray[np.bool_]:
    """Classify ground with the Cloth Simulation Filter.

    Parameters
    ----------
    xyz
        (N, 3) float64 points, local frame (z up), metres.
    params
        :class:`CSFParams`; None = the package defaults.

    Returns
    -------
    numpy.ndarray
        (N,) bool, True for ground. Deterministic: the simulation runs on one thread.

    References
    ----------
    Zhang, W., Qi, J., Wan, P., Wang, H., Xie, D., Wang, X., Yan, G. (2016). An easy-to-use
    airborne LiDAR data filtering method based on cloth simulation. Remote Sensing 8(6), 501.
    """
    import CSF  # the cloth-simulation-filter package; imported lazily (C extension)

    p = CSFParams() if params is None else params
    sim = CSF.CSF()
    sim.params.bSloopSmooth = bool(p.slope_smooth)
    sim.params.cloth_resolution = float(p.cloth_resolution_m)
    sim.params.rigidness = int(p.rigidness)
    sim.params.class_threshold = float(p.class_threshold_m)
    sim.params.interations = int(p.iterations)
    sim.params.time_step = float(p.time_step)
    keep = np.arange(xyz.shape[0])
    if p.remove_low_outliers:
        from pyheracles.groundfilters.smrf import low_outliers

        keep = np.flatnonzero(~low_outliers(xyz))
    ground = CSF.VecInt()
    off_ground = CSF.VecInt()
    from threadpoolctl import threadpool_limits

    # one OpenMP thread: the package's parallel cloth update races (the same cloud gave
    # 7681-7696 ground points from run to run on ISPRS sample 11), and one thread is
    # not slower there (8.6 s against 16.7 s with two)
    with threadpool_limits(limits=1, user_api="openmp"), _quiet_stdout():
        sim.setPointCloud(np.ascontiguousarray(xyz[keep], dtype=np.float64))
        sim.do_filtering(ground, off_ground, False)  # False: do not write the cloth to a file
    mask = np.zeros(xyz.shape[0], dtype=bool)
    mask[keep[np.asarray(ground, dtype=np.intp)]] = True
    return mask
