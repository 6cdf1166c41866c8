"""Photogrammetric quality control: bundle adjustment with self-calibration and diagnostics.

Python successor of the checks the thesis (Murtiyoso 2020, ch. 2) runs with DBAT,
the Damped Bundle Adjustment Toolbox (Börlin & Grussenmeyer): re-process a
project, expose sigma0, posterior standard deviations, correlations, control and
check point residuals and per-image statistics.
"""

from __future__ import annotations

from pyheracles.bundle.adjust import BundleResult, bundle_adjust
from pyheracles.bundle.camera import IO_NAMES, Camera
from pyheracles.bundle.parameters import BundleParameters
from pyheracles.bundle.project import BundleWarning, Project
from pyheracles.bundle.readers import read_project

__all__ = [
    "IO_NAMES",
    "BundleParameters",
    "BundleResult",
    "BundleWarning",
    "Camera",
    "Project",
    "bundle_adjust",
    "read_project",
]
