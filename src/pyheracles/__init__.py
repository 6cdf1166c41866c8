"""pyheracles: 3D documentation of built heritage.

Point cloud segmentation across scales (complex, building, elements) and the
geometric quality control of the data it starts from (bundle adjustment,
registration, georeferencing).  Successor of M_HERACLES (Murtiyoso 2020).

The public API is curated here; heavy modules (plotting, bundle adjustment)
are imported on first use.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

from pyheracles.cloud import PointCloud
from pyheracles.errors import (
    CRSMismatchError,
    DegenerateGeometryError,
    EstimationError,
    HeraclesError,
    InputError,
)

__version__ = "0.1.0"

_LAZY_MODULES = {
    "io",
    "geometry",
    "segment",
    "ground",
    "complex",
    "building",
    "framework",
    "registration",
    "bundle",
    "evaluate",
    "synthetic",
    "report",
    "pipeline",
}

__all__ = [
    "CRSMismatchError",
    "DegenerateGeometryError",
    "EstimationError",
    "HeraclesError",
    "InputError",
    "PointCloud",
    "__version__",
    *sorted(_LAZY_MODULES),
]

if TYPE_CHECKING:  # pragma: no cover
    from pyheracles import io  # noqa: F401


def __getattr__(name: str) -> Any:
    if name in _LAZY_MODULES:
        return import_module(f"pyheracles.{name}")
    raise AttributeError(f"module 'pyheracles' has no attribute {name!r}")
