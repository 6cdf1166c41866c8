"""What the scan simulator is asked to acquire: scanner stations, camera networks, flights.

The parameter sets of :func:`pyheracles.synthetic.scanner.scan` (one frozen
dataclass per kind of acquisition, with units and defaults), kept apart from
the simulator so that the scanner module holds only how hits become points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from pyheracles.errors import InputError

__all__ = [
    "Acquisition",
    "AirborneSurvey",
    "Outliers",
    "PhotoViews",
    "SurfaceSampling",
    "TLSStation",
]


@dataclass(frozen=True)
class TLSStation:
    """A terrestrial laser scanner set up at one station.

    Parameters
    ----------
    position
        Optical centre (x, y, z), metres (the tripod height included).
    step_deg
        Angular step in azimuth and elevation, degrees (0.036 deg = 6.3 mm at 10 m).
    elevation_deg
        Lowest and highest elevation scanned, degrees; the lowest sets the
        blind cone under the tripod (-60 deg: a 30 deg cone).
    azimuth_deg
        Azimuth window, degrees (0-360 for a full dome).
    range_m
        Nearest and farthest range that returns, metres.
    noise_m, noise_per_m
        Range noise sigma = ``noise_m + noise_per_m * r`` (1.5 mm + 0.05 mm/m
        is a phase-based scanner's datasheet figure).
    grazing_limit_deg
        No return where the beam meets the surface at less than this angle
        (incidence beyond ``90 - grazing_limit_deg`` from the normal).
    detection
        Signal level (reflectance x cos(incidence) x (10 m / r)^2) at which
        the return probability is 63 %; lower values lose fewer points.
    mixed_pixel_share
        Share of depth-edge beams that return a point between the two surfaces.
    edge_jump_m
        Range jump between neighbouring beams that makes a depth edge.
    """

    position: tuple[float, float, float]
    step_deg: float = 0.05
    elevation_deg: tuple[float, float] = (-60.0, 90.0)
    azimuth_deg: tuple[float, float] = (0.0, 360.0)
    range_m: tuple[float, float] = (0.6, 120.0)
    noise_m: float = 0.0015
    noise_per_m: float = 0.00005
    grazing_limit_deg: float = 5.0
    detection: float = 0.002
    mixed_pixel_share: float = 0.3
    edge_jump_m: float = 0.05

    def validate(self) -> None:
        """Raise :class:`InputError` on impossible settings."""
        if not (0 < self.step_deg <= 10):
            raise InputError(f"TLS step_deg must be in (0, 10], got {self.step_deg}")
        lo, hi = self.elevation_deg
        if not (-90 <= lo < hi <= 90):
            raise InputError(f"TLS elevation window must lie in [-90, 90], got {lo}, {hi}")
        if not (0 <= self.range_m[0] < self.range_m[1]):
            raise InputError(f"TLS range window must be increasing, got {self.range_m}")


@dataclass(frozen=True)
class PhotoViews:
    """A photogrammetric block (terrestrial or UAV) and its dense matching.

    Parameters
    ----------
    positions
        ``(C, 3)`` camera centres, metres.
    targets
        ``(C, 3)`` points the cameras look at.
    focal_px, width_px, height_px
        Pinhole camera (principal point at the centre).
    pixel_step
        Dense matching keeps one point per ``pixel_step`` pixels (2 = half
        resolution, as Metashape's "high").
    sigma_m
        Matching noise at ``reference_range_m``, metres, grown with range
        and clipped to ``sigma_clip_m`` (dense matching: 5-15 mm).
    max_incidence_deg
        Views that see a surface more obliquely do not match it.
    min_views
        Views needed to triangulate a point.
    """

    positions: ArrayLike
    targets: ArrayLike
    focal_px: float = 3000.0
    width_px: int = 4000
    height_px: int = 3000
    pixel_step: int = 8
    sigma_m: float = 0.008
    reference_range_m: float = 10.0
    sigma_clip_m: tuple[float, float] = (0.005, 0.015)
    max_incidence_deg: float = 75.0
    min_views: int = 2

    def validate(self) -> None:
        """Raise :class:`InputError` on impossible settings."""
        p = np.asarray(self.positions, float).reshape(-1, 3)
        if len(p) < self.min_views:
            raise InputError(f"photogrammetry needs at least {self.min_views} views, got {len(p)}")


@dataclass(frozen=True)
class AirborneSurvey:
    """An airborne LiDAR survey of a rectangle in parallel overlapping strips.

    Parameters
    ----------
    bounds
        ``(xmin, ymin, xmax, ymax)`` of the area, metres.
    altitude_m
        Flying height above z = 0.
    density_per_m2
        Target pulse density of one strip's swath (the overlap adds to it).
    half_fov_deg
        Half scan angle (zig-zag across track).
    overlap
        Side overlap of neighbouring strips (0.2-0.5).
    heading_deg
        Flight direction, degrees from the x axis.
    noise_m
        Range noise sigma, metres.
    max_returns
        Returns recorded per pulse.
    min_separation_m
        Returns of one pulse closer than this merge (pulse length).
    scan_rate_hz, speed_mps
        Scan lines per second and ground speed.
    """

    bounds: tuple[float, float, float, float]
    altitude_m: float = 500.0
    density_per_m2: float = 10.0
    half_fov_deg: float = 20.0
    overlap: float = 0.3
    heading_deg: float = 0.0
    noise_m: float = 0.03
    max_returns: int = 5
    min_separation_m: float = 1.0
    scan_rate_hz: float = 100.0
    speed_mps: float = 60.0

    def validate(self) -> None:
        """Raise :class:`InputError` on impossible settings."""
        x0, y0, x1, y1 = self.bounds
        if not (x1 > x0 and y1 > y0):
            raise InputError(f"airborne survey bounds are empty: {self.bounds}")
        if self.density_per_m2 <= 0 or self.altitude_m <= 0:
            raise InputError("airborne density and altitude must be positive")
        if not (0 <= self.overlap < 0.9):
            raise InputError(f"strip overlap must be in [0, 0.9), got {self.overlap}")


@dataclass(frozen=True)
class Outliers:
    """Gross errors added to a scan, as a share of its output points.

    Parameters
    ----------
    share
        Outliers / all points (0.005 = 0.5 %).
    isolated, clusters, reflections
        Relative weights of the three kinds: isolated points (half of them
        under scanned surfaces, as multipath echoes), small clusters (dust, birds, passers-by), and
        virtual points behind glass (mirror images); reflections fall back to
        isolated points when the scene has no glass.
    cluster_size
        Points per cluster (min, max).
    below_m
        How far under a scanned surface the low isolated points lie, metres.
    """

    share: float = 0.005
    isolated: float = 0.5
    clusters: float = 0.3
    reflections: float = 0.2
    cluster_size: tuple[int, int] = (5, 40)
    below_m: float = 2.0

    def validate(self) -> None:
        """Raise :class:`InputError` on impossible settings."""
        if not (0 <= self.share < 0.5):
            raise InputError(f"outlier share must be in [0, 0.5), got {self.share}")


@dataclass(frozen=True)
class SurfaceSampling:
    """An idealised registered union: every surface sampled uniformly, no shadows.

    What a very well planned multi-station survey approaches, and what the
    project's first named scenes were; kept so that those scenes stay
    reproducible through the one simulator.  Real scanners are
    :class:`TLSStation`, :class:`PhotoViews` and :class:`AirborneSurvey`.

    Parameters
    ----------
    spacing_m
        Mean point spacing: ``1 / spacing_m**2`` points per m^2.
    noise_m
        Isotropic Gaussian noise, metres.
    parts
        Restrict to these part names (None = every surface).
    """

    spacing_m: float = 0.02
    noise_m: float = 0.003
    parts: tuple[str, ...] | None = None

    def validate(self) -> None:
        """Raise :class:`InputError` on impossible settings."""
        if self.spacing_m <= 0 or self.noise_m < 0:
            raise InputError("surface sampling needs spacing_m > 0 and noise_m >= 0")


Acquisition = TLSStation | PhotoViews | AirborneSurvey | SurfaceSampling
