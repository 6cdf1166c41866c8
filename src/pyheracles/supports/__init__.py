"""Structural supports of a building body: columns, piers and engaged columns.

The MATLAB ``supportdetect`` of M_HERACLES (Murtiyoso 2020, ch. 6.2) cut the
body at mid-height, clustered the cross-section into islands, told columns
from piers by the circularity of the island hull, and used the buffered hull
as a 2.5D "cookie-cutter" back in 3D, after removing floor and ceiling planes.
This module keeps that structure and fixes the failures the thesis reports:

1. **Section height** -- chosen automatically: sections are taken every
   ``candidate_step_m`` between 25 % and 85 % of the body height; a support
   island counts at a height only if an island of the same kind is found at the
   same place ``persistence_m`` above and below (a chair seat or a sign board is
   not); the middle of the longest run of heights with the most islands is
   used.  The body runs between its lowest and highest dense levels
   (:func:`~pyheracles.supports.height.dense_extent`: not the outliers below the
   floor or above the roof, not the roof of a survey from above that holds most
   points) and is searched whole, whatever an attic split said (the columns of a
   ruin rise above its broken walls where the hull shrinks as at an attic).
   Capitals merge twin columns and fences join columns into wall-like
   islands, so such heights lose islands and are avoided (the thesis moved the
   section by hand in the St-Pierre choir).
2. **Islands** -- Euclidean clustering of the section (2D); each island is
   noise (too small), wall (long or elongated) or a support; a support is a
   column when a circle explains its points better than a rectangle and the
   hull circularity ``P^2 / 4 pi A`` is at most 1.12 (thesis threshold; a
   partially scanned column passes on the model test alone, or when its circle
   lies within the noise of the ring test), else a pier; the rectangle is the one
   the points lie on (a pier seen from a corner is an L, whose smallest enclosing
   rectangle lies along its diagonal), and points that lie on it are no ring.
   Islands that are arcs of one circle (the arcs of a large ring shadowed by its
   twin are long and thin like pieces of wall) are one column, with the scattered
   points of their ring.  The points left over
   are grouped again at their own spacing: column rings from their arcs (bunches
   of one ring further apart than the gap joined by their circle), then at
   gaps doubling up to 20 cm, largest first, rings, twin rings side by side and
   sparse piers on a rectangle outline (supports far from the scanners, crossed
   by scan lines far apart).  A second, 30 cm thick section finds the supports
   whose few points do not make an island in the thin one.  Pier islands in
   line with a wall, or with a side on the line of a wall face (the pieces of a
   wall between its openings), are walls.  A pier candidate between the two faces of
   a wall, which run on beyond both of its ends, stands in the wall's opening (a
   door's or a window's reveal in a thick wall): no pier.
3. **Engaged columns** -- on wall islands, the wall faces are fitted as lines
   (MSAC); the points left over that form an arc of circle attached to a face
   are half-columns (class ``engaged_column``, which the thesis could not find).
4. **Cookie-cutter** -- around each support, points within a buffer of its
   section shape (2.6 r for columns: square plinths and abaci) are collected
   from the whole cloud, attic included (overlaps go to the nearest support:
   twin columns conjoined at plinth and capital become two objects).  A support
   goes from the floor under it up to the underside of what it carries
   (:func:`~pyheracles.supports.profile.carried_surface`: architrave, beam,
   flat ceiling, vault; not eaves it passes through), whatever an attic split
   said; floor and carried surface are removed by their own noise.
5. **Clutter** -- in every height layer, only points within the reach of the
   support's own profile are kept (:func:`~pyheracles.supports.profile.band_reach`:
   a plinth band reaches its corners, a fence rail or a chair in a few sectors
   does not move it).  A final voxel clustering at the support's own scan-line
   gap keeps what is connected to the section island; a pier joined to a wall
   in most of its height layers, or standing in a wall face that runs on beyond both
   its ends (or round a corner) at its foot, is a wall edge (a jamb, the wall
   between two windows); a support carrying nothing must be ``min_free_height_m``
   tall (broken columns), a pier a prism as wide as its section, whatever it
   carries (not a lying drum, nor a pulpit's tub on its post), a column carrying
   nothing at least 0.3 x the radius of the thickest column that carries (not a
   post or a pulpit's stem); everything
   rejected goes back to the pool.
6. **Primitives** -- cylinder (axis, radius, height, RMS) for columns and
   engaged columns, oriented box (dimensions, RMS) for piers.

Modules (one per stage): :mod:`~pyheracles.supports.core` (parameters, results, lengths
from the point spacing), :mod:`~pyheracles.supports.height` (section height search),
:mod:`~pyheracles.supports.sections` (islands of a section),
:mod:`~pyheracles.supports.rings` (column rings from arcs, engaged columns),
:mod:`~pyheracles.supports.piers` (rectangles, wall pieces),
:mod:`~pyheracles.supports.openings` (piers inside a wall's opening: reveals, jambs),
:mod:`~pyheracles.supports.cookies` (cookie-cutter, floor, clutter, clustering),
:mod:`~pyheracles.supports.profile` (carried surface, reach per height band, wall edges),
:mod:`~pyheracles.supports.primitives` (cylinders, boxes, plausibility) and
:mod:`~pyheracles.supports.detect` (the driver).
"""

from pyheracles.supports.core import (
    SUPPORT_CLASSES,
    Island,
    SupportParams,
    SupportResult,
    one_blas_thread,
)
from pyheracles.supports.detect import detect_supports, detect_supports_checked
from pyheracles.supports.sections import section_islands

__all__ = [
    "SUPPORT_CLASSES",
    "Island",
    "SupportParams",
    "SupportResult",
    "detect_supports",
    "detect_supports_checked",
    "one_blas_thread",
    "section_islands",
]
