"""Step 1: GIS-aided segmentation and annotation of a heritage complex.

Thesis chapter 5 (MATLAB ``shapeseg``): the complex's point cloud is split into
one object per GIS feature.  For every layer (one layer = one class) and every
polygon, the points inside the polygon buffered by ``buffer_m`` (a 2.5D
cookie-cutter: XY only) are clustered by Euclidean distance; the clusters
that belong to the feature are kept, the others go back to the pool for the
following polygons and layers.  Ground is extracted first and labelled, never
deleted.  Layers are processed lowest objects first, which the thesis found
necessary for walls under roofs and roofs under tree crowns.

Beyond the thesis:

* polygons that touch or whose buffers overlap (row houses sharing walls)
  never claim the same point: a point in several buffered polygons goes to the
  polygon that contains it, or else to the nearest one;
* the candidate search uses a grid index of the cloud instead of a
  point-in-polygon test of the whole cloud for each polygon;
* parameters default to multiples of the measured point spacing (the buffer,
  which absorbs digitising errors, does not grow with it);
* with echoes (LAS return numbers), points amid pass-through returns are
  foliage: they join an object only up to a little above its surface beside
  them, so crowns over roofs stay out at any density.
"""

from __future__ import annotations

from pyheracles.complex.levels import raised_ground_points
from pyheracles.complex.params import GROUND_METHODS, ComplexParams, ComplexResult, resolve_params
from pyheracles.complex.segment import prepare_layers, segment_complex

__all__ = [
    "GROUND_METHODS",
    "ComplexParams",
    "ComplexResult",
    "prepare_layers",
    "raised_ground_points",
    "resolve_params",
    "segment_complex",
]
