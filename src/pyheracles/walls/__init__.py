"""Walls of a building cloud: vertical planes, thickness, outlines with openings.

Step 2 (DESIGN.md), after M_HERACLES ``wallSeg``, ``intersectMultPlanes`` and
``meshSnap``.  :func:`segment_walls` finds the vertical planar faces of a cloud
(TLS inside or outside, or a step-1 object), pairs parallel faces a wall
thickness apart into one wall (thickness measured where both faces are seen),
draws each wall's outline on its plane with the openings (windows, doors) as
holes, and joins walls that meet at their plane intersection.

Method
------
1. Detection sample: one point per ``voxel_m`` cube; normals by local PCA
   (k = 16); candidates are points whose normal is within ``max_tilt_deg`` of
   horizontal.
2. Faces: peaks of a histogram of the candidates' (normal azimuth, offset);
   each peak is refitted by least squares (inliers within ``distance_m`` and
   ``normal_angle_deg``), split into connected parts along the plane, and kept
   when at least ``min_length_m`` long, ``min_height_m`` high and
   ``min_area_m2`` in area.
3. Walls: two parallel faces (``parallel_deg``) whose offsets differ by
   ``min_thickness_m`` to ``max_thickness_m`` and which are seen over the same
   stretch of wall (half the smaller face's cells shared) form one wall, the pairs
   sharing most taken first (mid-plane, thickness = their separation); a face
   between the two faces of a wall (panes, leaves, reveals) is in no wall; a lone
   face on the plane of a wall's face and within its other face's extent is a piece
   of that face (a face crossed by a roof: a nave arcade's aisle side under the
   aisle's roof, its clerestory above); a face alone is a wall seen on one face
   (thickness NaN, said in ``notes``).  A wall that another wall abuts along its
   length from the building's side (a church's front, where the arcades between nave
   and aisles meet it) is cut there: its faces, and every face on their planes, are
   cut at the junction and paired again (:mod:`~pyheracles.walls.junctions`).
4. Outline: the faces' points on a ``cell_m`` grid of the wall plane ``(u, z)``,
   each face's gaps closed at its own point density; the envelope spans each column
   from the wall's foot to its top.  Empty parts of the envelope are openings when
   they are large enough and the points through them lie in the wall (reveals,
   glass, doors' leaves) or beyond it, rather than in front (an occluder's shadow is
   not an opening); a hole reaching the envelope's top over most of its columns is
   open to the top, not enclosed, and holes one above the other whose band holds
   none of the points a face would have there (a sparse face's stray returns
   closed across a narrow light) are one hole
   (:func:`~pyheracles.walls.bands.join_stray_bands`).  Openings whose foot is
   within ``door_step_m`` of a face's foot are doors (from the highest face foot
   under them: the floor inside above a step down outside), the others windows.
   Their edges are refined from each face's points on its plane (stray points
   inside the opening and mixed pixels off the plane left out), and the opening
   through the wall is where every face is open.
5. Joins: the ends of walls that meet are moved to the least-squares
   intersection of the planes meeting there (:func:`intersect_planes`,
   ``intersectMultPlanes``) when within ``snap_m`` (vertex snapping,
   ``meshSnap``).

Examples
--------
>>> import numpy as np
>>> from pyheracles.walls import intersect_planes
>>> intersect_planes([[1, 0, 0], [0, 1, 0], [0, 0, 1]], [1.0, 2.0, 3.0]).round(6).tolist()
[1.0, 2.0, 3.0]
"""

from __future__ import annotations

from pyheracles.walls.model import (
    WALL_CLASS,
    WALL_CLASS_ID,
    Opening,
    Wall,
    WallFace,
    WallParams,
    WallResult,
)
from pyheracles.walls.openings import merge_lights
from pyheracles.walls.planes import intersect_planes
from pyheracles.walls.segment import segment_walls

__all__ = [
    "WALL_CLASS",
    "WALL_CLASS_ID",
    "Opening",
    "Wall",
    "WallFace",
    "WallParams",
    "WallResult",
    "intersect_planes",
    "merge_lights",
    "segment_walls",
]
