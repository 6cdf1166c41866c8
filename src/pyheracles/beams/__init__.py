"""Step 2b: beams of timber roof frameworks, each with a fitted cuboid.

Thesis chapter 6.3 (Murtiyoso 2020; MATLAB ``regiongrowingnormals``,
``axedetect``, ``beamSeg``).  The pipeline reads top-down:

0. clouds denser than ``thin_spacing_m`` are thinned at random for the
   geometry (normals of over-dense noisy scans are noise), each part to that
   spacing by its own density, so the sparse far faces are kept whole
   (:func:`~pyheracles.beams.thinning.thin_to_spacing`); labels come back to
   every input point at step 5;
1. a coarse (voxel-level) region growing finds the *wide surfaces* (floor,
   walls, boarding: wider than the widest beam face in every direction,
   :func:`~pyheracles.beams.facets.wide_surface_points`), which are left out;
   :func:`~pyheracles.segment.regiongrow.region_growing` then cuts the rest,
   with thresholds from the rest (the angle capped below the step of the
   normals round a beam's edge,
   :func:`~pyheracles.beams.facets.face_noise_thresholds`), into smooth planar
   *facets* (the faces of the beams; coplanar faces of beams meeting in a
   joint come out as one L-, T-, X- or Y-shaped facet); a region that bridged
   two faces of a beam along a rounded edge is split by its dominant normal
   directions, and one that joined parallel faces at different offsets (the
   undersides of rafters and the boarding between them) into its layers;
2. :func:`split_facet` cuts every facet into *straight facets*: bands of
   constant width found with a Hough-style search in the facet plane (the
   direction and offset whose band holds the densest line of points, longest
   first), its direction refined by the band's extent and then by the
   robust lines of its two edges (:func:`~pyheracles.beams.bands.edge_line_direction`:
   a coplanar face flush with the band, a shadow or a mitred end bends one
   edge over a few slices, not the median), the width measured automatically
   at half the band's density
   profile (the thesis asked the user for the beam width); a band that is a
   strip of a wider coplanar surface (boarding between rafters) is dropped
   (:func:`~pyheracles.beams.surfaces.wide_surface_bands`), but not one that
   stands proud of the coplanar surface beside it (the undersides of common
   rafters side by side, with the boarding between them behind);
3. :func:`group_facets` joins straight facets into beams: parallel axes and a
   shared edge (boundary-to-boundary contact over at least half of the shorter
   facet, not centroid distance), narrowest faces first and never into a
   group no single beam can be (two coplanar faces side by side); a beam
   needs at least two facets with non-parallel normals (otherwise no cuboid
   is defined) and the rest goes back to the pool;
   the pieces of one face that no beam took make a *beam seen on one face*
   when the band is convex (its side points lie behind it, away from the
   room it was scanned from; a boarding strip between two rafters is a
   concave channel), with the depth from its side points or flagged as not
   measured (:func:`~pyheracles.beams.one_face.fit_one_face_cuboid`);
4. collinear pieces of one beam (cut by a crossing beam in an X joint or by
   a shadow) are merged, and :func:`fit_beam_cuboid` fits one oriented cuboid
   per beam from its facets, lengthened over the short or sparse ends that
   gave no facet of their own (by the points on the faces seen along it, in
   rounds of ``max_gap_m``; not by normals, noisy where points are few);
   pieces with one located section on one line are joined across a longer
   gap too (``max_shadow_m``: a stretch in the shadow of a nearer member),
   and boxes thinner than any member (``min_beam_width_m``) are dropped, and
   so are the boxes fitted to a member's face and the strip of boarding
   beside it, when the face lies on another beam found apart: the air in
   that inside corner (:func:`~pyheracles.beams.hull_strips.on_hull_strip`);
   groups of touching beams that all lie on a surface
   (timber stored on the floor) are dropped
   (:func:`~pyheracles.beams.surfaces.resting_loose`), and so are the beams
   that are no members of the frame (``BeamParams.frame_only``,
   :func:`~pyheracles.beams.frame.frame_members`: timber lying at the frame's
   bottom joined to no rising member, a ladder leaning on a post, the strip
   of a wall head a plate rests on, what no frame holds): their points go
   to the remainder;
5. every point within ``surface_tolerance_m`` of a cuboid surface is given to
   the nearest cuboid (the thesis's re-merge of pool points): labels, not
   copies, and nothing is lost (the remainder is label 0).
"""

from __future__ import annotations

from pyheracles.beams.bands import split_facet
from pyheracles.beams.cuboids import fit_beam_cuboid
from pyheracles.beams.frame import FrameParams, FrameResult, analyse_frame
from pyheracles.beams.grouping import group_facets
from pyheracles.beams.model import (
    BEAM_CLASS,
    BEAM_CLASS_ID,
    BeamCuboid,
    BeamParams,
    BeamResult,
    StraightFacet,
)
from pyheracles.beams.segment import segment_beams

__all__ = [
    "BEAM_CLASS",
    "BEAM_CLASS_ID",
    "BeamCuboid",
    "BeamParams",
    "BeamResult",
    "FrameParams",
    "FrameResult",
    "StraightFacet",
    "analyse_frame",
    "fit_beam_cuboid",
    "group_facets",
    "segment_beams",
    "split_facet",
]
