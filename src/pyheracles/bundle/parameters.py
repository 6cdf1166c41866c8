"""Parameters of a bundle adjustment (:class:`BundleParameters`) and their choices."""

from __future__ import annotations

from dataclasses import dataclass

from pyheracles.errors import InputError

__all__ = ["DAMPINGS", "DATUMS", "EO_NAMES", "SNOOPING_TESTS", "BundleParameters"]

DAMPINGS = ("gna", "lm", "gn")
DATUMS = ("auto", "control", "depend", "free")
SNOOPING_TESTS = ("w", "tau")
EO_NAMES = ("X0", "Y0", "Z0", "omega", "phi", "kappa")


@dataclass(frozen=True)
class BundleParameters:
    """Settings of :func:`bundle_adjust` (defaults are DBAT's).

    Parameters
    ----------
    damping
        "gna" (Gauss-Newton with Armijo line search, DBAT default), "lm"
        (Levenberg-Marquardt) or "gn" (undamped Gauss-Newton).
    max_iterations
        Maximum number of iterations (DBAT: 20).
    tolerance
        Relative termination tolerance ``||J p|| <= tol ||r||`` (DBAT: 1e-6).
    armijo_mu
        Sufficient-decrease constant of the line search (DBAT: 0.1).
    alpha_min
        Shortest step length of the line search (DBAT: 1e-9).
    lm_lambda0
        Initial Levenberg-Marquardt damping, relative to the normal matrix diagonal.
    estimate_io
        Interior parameters to estimate for every camera (names of
        :data:`~pyheracles.bundle.camera.IO_NAMES`, "pp" = px and py); None keeps the
        project's own choice (a DBAT script's), an empty tuple fixes the cameras.
    datum
        "auto" (control points if the project has at least 3 fixed or weighted
        ones, else dependent relative orientation), "control", "depend", or
        "free" (no datum at all: the adjustment then reports the rank deficiency
        and names the undetermined parameters, as DBAT's no-datum demo).
    min_rays
        Tie points seen by fewer images are dropped with a warning.
    covariance
        Compute the posterior covariance (IO, EO, every object point's 3x3 block).
    blas_threads
        BLAS threads during the adjustment (None = library default).
    snooping
        Data snooping test of the image observations: "w" (Baarda's w-test with
        the a priori standard deviations, critical value 3.29) or "tau" (Pope's
        tau test with the posterior sigma0, critical value from the tau
        distribution for the redundancy, at ``snooping_alpha`` per observation).
    snooping_alpha
        Significance level of the tau test (per observation; Pope 1976).
    """

    damping: str = "gna"
    max_iterations: int = 20
    tolerance: float = 1e-6
    armijo_mu: float = 0.1
    alpha_min: float = 1e-9
    lm_lambda0: float = 1e-3
    estimate_io: tuple[str, ...] | None = None
    datum: str = "auto"
    min_rays: int = 2
    covariance: bool = True
    blas_threads: int | None = 1
    snooping: str = "w"
    snooping_alpha: float = 0.001

    def __post_init__(self) -> None:
        if self.snooping not in SNOOPING_TESTS:
            raise InputError(
                f"unknown data snooping test '{self.snooping}'; choose one of "
                f"{list(SNOOPING_TESTS)}"
            )
        if not (0 < self.snooping_alpha < 1):
            raise InputError("snooping_alpha must be in (0, 1)")
        if self.damping not in DAMPINGS:
            raise InputError(f"unknown damping '{self.damping}'; choose one of {list(DAMPINGS)}")
        if self.datum not in DATUMS:
            raise InputError(f"unknown datum '{self.datum}'; choose one of {list(DATUMS)}")
        if self.max_iterations < 1 or not (0 < self.tolerance < 1):
            raise InputError("max_iterations must be >= 1 and 0 < tolerance < 1")
