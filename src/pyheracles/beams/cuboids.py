"""Oriented cuboids of beams from their straight facets; merging collinear pieces."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from pyheracles.beams.facets import half_max_edges
from pyheracles.beams.grouping import UnionFind
from pyheracles.beams.model import BeamCuboid, BeamParams, StraightFacet
from pyheracles.beams.one_face import edge_coverage, fit_one_face_cuboid, going_back
from pyheracles.beams.piece_joins import PieceFace, gap_clear, same_face
from pyheracles.beams.sections import Bow, centre_line_bow, face_edges, off_seen_sides
from pyheracles.errors import DegenerateGeometryError

__all__ = [
    "axis_evidence",
    "collinear",
    "edge_coverage",
    "face_points",
    "fit_beam_cuboid",
    "fit_one_face_cuboid",
    "going_back",
    "inward_normal",
    "join_pieces",
    "merge_and_absorb",
    "same_section",
    "section_overlap",
    "sparse_face",
    "thinner_than",
]


def face_points(
    xyz: NDArray[np.float64],
    f: StraightFacet,
    bin_m: float,
    free: NDArray[np.float64] | None,
    inward: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """The facet's points plus the unclaimed cloud points on its plane past its band.

    Near an edge the normals are blended and points often stay out of every
    facet; the side of a cuboid read from a face's edge needs them back.  Taken:
    points in no straight facet (``free``, their coordinates; the adjacent face's own edge strip
    would pile up at the edge) within 3 plane RMS of the plane, inside the
    facet's length and at most 5 cm (or 10 bins) past its band on either side.

    ``inward``: the face's unit normal pointing into the beam, if known.  A
    surface meeting the beam along a hidden side (boarding on a rafter's top, a
    floor under a plate, straight over a sagging member) goes on outwards from
    the face's plane, and its points near the corner fall within the plane's
    tolerance past the face's edge, where they moved the edge out by a
    centimetre or more; nothing is scanned inside a beam.  Free points more
    than one plane RMS outside the plane are left out: the face's own scatter
    keeps most of its points within that, the other surface's points spread
    evenly over the whole tolerance outwards.
    """
    if free is None:
        return xyz[f.index]
    across = np.cross(f.normal, f.axis)
    own = xyz[f.index]
    t = (own - f.centre) @ f.axis
    s = (own - f.centre) @ across
    margin = max(0.05, 10 * bin_m)
    lo = own.min(axis=0) - margin
    hi = own.max(axis=0) + margin
    cand = free[np.all((free >= lo) & (free <= hi), axis=1)]
    rel = cand - f.centre
    tol = max(3.0 * f.plane_rms, bin_m)
    keep = (
        (np.abs(rel @ f.normal) <= tol)
        & (rel @ f.axis >= t.min())
        & (rel @ f.axis <= t.max())
        & (rel @ across >= s.min() - margin)
        & (rel @ across <= s.max() + margin)
    )
    if inward is not None:
        keep &= rel @ inward >= -f.plane_rms
    return np.vstack([own, cand[keep]])


def inward_normal(
    f: StraightFacet, others: NDArray[np.float64], tol: float
) -> NDArray[np.float64] | None:
    """The facet's unit normal pointing towards the other faces of its beam (``others``).

    ``None`` when the other faces' points lie within ``tol`` (metres) of the
    facet's plane on average (no side of the plane holds the beam).
    """
    if len(others) == 0:
        return None
    depth = float(np.mean((others - f.centre) @ f.normal))
    if abs(depth) <= tol:
        return None
    return f.normal * np.sign(depth)


#: Share of the smaller section inside the larger that makes two parallel pieces
#: overlapping along their axis one member (:func:`collinear`; 0.8 for pieces apart).
OVERLAP_INSIDE_SHARE = 0.5
#: How well a section size is known on a piece not seen on all four sides, metres:
#: a side seen as no face is placed at the half-density edge of the faces next to
#: it (or from the few points behind a one-face band), to within about a point
#: spacing of a far member (1 cm at 10-20 m with the family's scanners, the step's
#: size target).  Two such pieces of one member may differ by twice that: each is
#: off by up to it, in opposite directions (:func:`same_section`).
EDGE_SIZE_UNCERTAINTY_M = 0.01
#: Fewest points on an unfaceted side of a beam that locate that side.
_SPARSE_FACE_MIN_POINTS = 15
#: Smallest share of the beam's length covered by those points (10 cm bins).
_SPARSE_FACE_MIN_COVER = 0.2


def sparse_face(
    free: NDArray[np.float64],
    axis: NDArray[np.float64],
    d: NDArray[np.float64],
    other: NDArray[np.float64],
    band: NDArray[np.float64],
    t_range: tuple[float, float],
    edge: float,
    sign: float,
    bin_m: float,
    bow: Bow | None = None,
) -> float:
    """Offset along ``d`` of a beam side seen by too few points for a facet.

    Candidates are the ``free`` points (in no facet) strictly between the
    planes of the two adjacent faces (offsets ``band`` along ``other``), within
    the beam's length, and within a few centimetres outside to one centimetre
    inside the ``edge`` estimated from the adjacent faces (``sign`` -1 for the
    low side, +1 for the high side).  Their median offset is returned when they
    are enough, spread along the beam (10 cm bins holding them cover at least
    ``_SPARSE_FACE_MIN_COVER`` of its length: the ends of beams resting on this
    one are local) and lie on one plane across ``d`` (interquartile range below
    ``bin_m``, at least 6 mm); otherwise ``edge`` is.  Offsets are taken
    about the centre line's ``bow`` across ``d`` (:func:`centre_line_bow`).
    """
    if len(free) == 0 or np.ptp(band) < 0.04:
        return edge
    margin = max(2.0 * bin_m, 0.01)
    b_lo, b_hi = float(band.min()) + margin, float(band.max()) - margin
    reach = max(6.0 * bin_m, 0.03)
    a = free @ d if bow is None or bow.is_zero else free @ d - bow(free @ axis)
    sel = (sign * (a - edge) <= reach) & (sign * (a - edge) >= -max(2.0 * bin_m, 0.01))
    if not sel.any():
        return edge
    cand = free[sel]
    o = cand @ other
    t = cand @ axis
    inside = (o >= b_lo) & (o <= b_hi) & (t >= t_range[0]) & (t <= t_range[1])
    vals = a[sel][inside]
    if len(vals) < _SPARSE_FACE_MIN_POINTS:
        return edge
    # a face runs along the beam: points bunched in a few spots (the ends of
    # beams resting on this one, at a joint) are no side of it, even if their
    # offsets agree by chance
    step = max(0.1, 10.0 * bin_m)
    occupied = len(np.unique(np.floor(t[inside] / step)))
    if occupied * step < _SPARSE_FACE_MIN_COVER * (t_range[1] - t_range[0]):
        return edge
    # one plane across d: a thin layer (noise), not points of a crossing
    # beam's faces, which fill the search window evenly
    q1, q3 = np.quantile(vals, [0.25, 0.75])
    if q3 - q1 > max(bin_m, 0.006):
        return edge
    if bow is not None and not bow.is_zero:
        # a face of a bowed beam bows with it: points whose own curvature along
        # the beam is nearer none than the bow's (the boarding left straight
        # over a sagging rafter, seen through the gap) are another surface
        s_t = t[inside] - bow.t0
        design = np.column_stack([np.ones(len(s_t)), s_t, s_t * s_t])
        curve = np.linalg.lstsq(design, (cand @ d)[inside], rcond=None)[0][2]
        if abs(curve) < abs(curve - bow.b2):
            return edge
    return float(np.median(vals))


def fit_beam_cuboid(
    xyz: NDArray[np.float64],
    facets: list[StraightFacet],
    *,
    bin_m: float,
    free: NDArray[np.float64] | None = None,
) -> BeamCuboid:
    """Oriented cuboid of a beam from its straight facets.

    Why not :func:`pyheracles.geometry.fitting.fit_oriented_box`: a beam in a
    roof is seen on two or three of its faces only, and a PCA / minimum-area
    box of such points underestimates the hidden sides.  The facets carry more
    information, used here:

    - the axis is the direction most orthogonal to the facet normals (smallest
      eigenvector of ``sum n n^T``, weighted by points), exact for two
      non-parallel faces;
    - the sizes are read about the centre line: where the faces facing one
      direction of the section show a bow along the beam (a sag of 1-3 cm,
      :func:`centre_line_bow`), every offset across that direction is taken
      from the bowed centre line, and the straight box is placed where the bow
      is on average (the box of a bent beam no longer encloses its sag);
    - each side of the cross-section comes from the plane of the face on that
      side (median offset, robust) when that face was seen, otherwise from the
      half-density edge of the adjacent faces' points (unbiased by noise,
      :func:`face_edges`: a pile at the edge is the surface meeting it there),
      including the ``free`` points (``(m, 3)`` coordinates of the points in no
      facet) on those faces' planes, which
      restores the edge strips where blended normals kept points out of facets;
    - the length from the 0.5 / 99.5 % quantiles of the points along the axis.

    Raises
    ------
    DegenerateGeometryError
        When the facets do not define a cross-section (all parallel).
    """
    normals = np.array([f.normal for f in facets])
    w = np.array([len(f.index) for f in facets], dtype=float)
    m = (normals * w[:, None]).T @ normals
    ev, evec = np.linalg.eigh(m)
    ref = facets[int(np.argmax(w))].axis
    mean_axis = np.sum([f.axis * np.sign(f.axis @ ref) * len(f.index) for f in facets], axis=0)
    if ev[1] >= 0.05 * ev.sum():
        axis = evec[:, 0] * np.sign(evec[:, 0] @ mean_axis)
    else:
        # only parallel (opposite) faces: normal to the planes, along the band
        # of the cleanest face (lowest plane RMS; an occluded face may carry a
        # neighbour's points that tilt its band)
        nrm = evec[:, 2]
        best = min(facets, key=lambda f: f.plane_rms)
        axis = best.axis - (best.axis @ nrm) * nrm
        axis /= np.linalg.norm(axis)
        axis *= np.sign(axis @ mean_axis)
    # cross-section frame: the direction closer to horizontal is "width"
    big = facets[int(np.argmax(w))].normal
    u = big - (big @ axis) * axis
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    if abs(u[2]) > abs(v[2]):  # make u the more horizontal one
        u, v = v, -u
    pts = np.vstack([xyz[f.index] for f in facets])
    t = pts @ axis
    t_lo, t_hi = np.quantile(t, [0.005, 0.995])
    bounds = []
    bows = []
    seen = 0
    for d, other in ((u, v), (v, u)):
        facing = [f for f in facets if abs(f.normal @ d) >= abs(f.normal @ other)]
        across = [f for f in facets if abs(f.normal @ d) < abs(f.normal @ other)]
        # the sizes are read about the centre line, bowed as the facing faces show
        bow = Bow()
        if facing:
            own_f = [xyz[f.index] for f in facing]
            bow = centre_line_bow(
                np.concatenate([q @ axis for q in own_f]),
                np.concatenate([q @ d for q in own_f]),
                np.repeat(np.arange(len(own_f)), [len(q) for q in own_f]),
                float(t_hi - t_lo),
            )

        def along(q: NDArray[np.float64], d=d, bow=bow) -> NDArray[np.float64]:
            return q @ d if bow.is_zero else q @ d - bow(q @ axis)

        offsets = np.array([np.median(along(xyz[f.index])) for f in facing])
        if across:
            a_vals = np.concatenate(
                [
                    along(face_points(xyz, f, bin_m, free, inward_normal(f, pts, bin_m)))
                    for f in across
                ]
            )
            tol_f = np.array([max(3.0 * f.plane_rms, bin_m) for f in facing])
            e_lo, e_hi = face_edges(off_seen_sides(a_vals, offsets, tol_f), bin_m)
        else:
            e_lo, e_hi = half_max_edges(along(pts), bin_m)
        if across:
            # the free points restore the edge strips, outwards; where many pile up
            # along one edge (the corner with a face seen edge-on) the half-density
            # level is theirs and both edges close in round that pile; and a face
            # scanned at a grazing angle is denser near one edge, so that the
            # half-density level of its far part is reached inside it: the faces'
            # own points reach at least as far as their half-density edges and
            # their 2 / 98 % quantiles (inside the edges of a uniform band)
            own = np.concatenate([along(xyz[f.index]) for f in across])
            own_lo, own_hi = half_max_edges(own, bin_m)
            q_lo, q_hi = np.quantile(own, [0.02, 0.98])
            e_lo, e_hi = min(e_lo, own_lo, float(q_lo)), max(e_hi, own_hi, float(q_hi))
        mid = 0.5 * (e_lo + e_hi)
        if not across and len(offsets) >= 2:
            mid = 0.5 * (offsets.min() + offsets.max())  # two opposite faces
        lo_faces = offsets[offsets < mid] if len(offsets) else offsets
        hi_faces = offsets[offsets >= mid] if len(offsets) else offsets
        b_lo = float(np.median(lo_faces)) if len(lo_faces) else e_lo
        b_hi = float(np.median(hi_faces)) if len(hi_faces) else e_hi
        if free is not None and across and not (len(lo_faces) and len(hi_faces)):
            # A side whose face gave no facet (seen by too few points, or at a
            # grazing angle) is located by the edge of the adjacent faces only
            # to within a scan-line spacing; the face's own points, if any were
            # scanned, fix it (they lie between the adjacent faces' planes).
            band = np.array([np.median(xyz[f.index] @ other) for f in across])
            t_rng = (float(t_lo), float(t_hi))
            if not len(lo_faces):
                b_lo = sparse_face(free, axis, d, other, band, t_rng, e_lo, -1.0, bin_m, bow)
            if not len(hi_faces):
                b_hi = sparse_face(free, axis, d, other, band, t_rng, e_hi, 1.0, bin_m, bow)
        bounds.append((b_lo, b_hi))
        bows.append(bow)
        seen += int(len(lo_faces) > 0) + int(len(hi_faces) > 0)
    (u_lo, u_hi), (v_lo, v_hi) = bounds
    # the straight box stands for the bowed beam where the bow is on average
    u_mid = 0.5 * (u_lo + u_hi) + bows[0].mean(float(t_lo), float(t_hi))
    v_mid = 0.5 * (v_lo + v_hi) + bows[1].mean(float(t_lo), float(t_hi))
    if min(u_hi - u_lo, v_hi - v_lo) <= 0:
        raise DegenerateGeometryError("the facets of this beam give no cross-section")
    centre = axis * 0.5 * (t_lo + t_hi) + u * u_mid + v * v_mid
    cub = BeamCuboid(
        centre=centre,
        axes=np.column_stack([axis, u, v]),
        length=float(t_hi - t_lo),
        width=float(u_hi - u_lo),
        height=float(v_hi - v_lo),
        rms=0.0,
        n_facets=len(facets),
        faces_seen=seen,
    )
    dist = np.abs(cub.signed_distance(pts))
    return replace(cub, rms=float(np.sqrt(np.mean(dist**2))))


def section_overlap(big: BeamCuboid, small: BeamCuboid) -> tuple[float, NDArray[np.float64]]:
    """Share of ``small``'s cross-section inside ``big``'s, and its extents in ``big``'s frame.

    Both sections are taken as rectangles in the plane across ``big``'s axis
    (the axes are nearly parallel); ``small``'s is its bounding rectangle there.
    """
    d = small.centre - big.centre
    rot = np.abs(big.axes[:, 1:].T @ small.axes[:, 1:])  # (2, 2) |cos| between section axes
    half_small = rot @ (0.5 * np.array([small.width, small.height]))
    centre = big.axes[:, 1:].T @ d
    half_big = 0.5 * np.array([big.width, big.height])
    inter = np.clip(
        np.minimum(centre + half_small, half_big) - np.maximum(centre - half_small, -half_big),
        0.0,
        None,
    )
    return float(np.prod(inter) / max(np.prod(2 * half_small), 1e-12)), 2 * half_small


def axis_evidence(c: BeamCuboid) -> tuple[int, bool, float]:
    """How well a cuboid's axis and section are known, for ordering pieces of one member.

    Faces seen, then whether its depth is measured, then its length (metres):
    the axis of a long piece seen on several faces is the better known.
    """
    return (c.faces_seen, c.height_measured, c.length)


def collinear(
    a: BeamCuboid, b: BeamCuboid, cos_par: float, max_gap: float, max_shadow: float = 0.0
) -> bool:
    """Two cuboids that are pieces of one beam cut by an X joint or a shadow.

    Parallel, separated along the axis by at most ``max_gap``, and either with
    the same cross-section (centres within 30 % of it, measured across the
    axis of the piece whose axis is the better known, :func:`axis_evidence`;
    sizes within 25 % or 2 cm), or with the smaller section inside the larger one and one of its
    sizes equal to the larger one's: a piece seen on too few faces (a side
    shadowed by a crossing beam) has one side located by the edge of a partly
    seen face, so one size comes out short; the refit of the merged beam takes
    that side from the other piece's face.  Farther apart, up to
    ``max_shadow`` and no more than the longer piece's length (a stretch of a
    member in the shadow of one nearer the scanner), only pieces with one
    located section (:func:`same_section`) are.
    """
    if abs(a.axis @ b.axis) < cos_par:
        return False
    gap = abs((b.centre - a.centre) @ a.axis) - 0.5 * (a.length + b.length)
    if gap > max_gap:
        return bool(gap <= min(max_shadow, max(a.length, b.length)) and same_section(a, b))
    # the offset across the axis in the frame of the piece whose axis is better
    # known: a short piece's axis a degree off puts a centre 2 m along it 3 cm
    # aside (roof seed 4: a common rafter's 1.8 m piece seen on one face)
    ref, other = (a, b) if axis_evidence(a) >= axis_evidence(b) else (b, a)
    d = other.centre - ref.centre
    same = bool(
        abs(d @ ref.axes[:, 1]) <= 0.3 * ref.width and abs(d @ ref.axes[:, 2]) <= 0.3 * ref.height
    )
    dims_a = np.sort([a.width, a.height])
    dims_b = np.sort([b.width, b.height])
    tol = np.maximum(0.25 * np.maximum(dims_a, dims_b), 0.02)
    if same and not np.any(np.abs(dims_a - dims_b) > tol):
        return True
    big, small = (a, b) if a.width * a.height >= b.width * b.height else (b, a)
    inside, sizes = section_overlap(big, small)
    big_sizes = np.array([big.width, big.height])
    one_equal = np.any(np.abs(sizes - big_sizes) <= np.maximum(0.1 * big_sizes, 0.01))
    # pieces overlapping along the axis share a stretch of space, which no two
    # members do: half the smaller section inside the larger is enough (roof
    # seed 18: a plate's two one-face pieces overlapping by 0.34 m, 79 % inside)
    least = OVERLAP_INSIDE_SHARE if gap < 0 else 0.8
    return bool(inside >= least and one_equal)


def same_section(a: BeamCuboid, b: BeamCuboid) -> bool:
    """Two cuboids with one section on one line: pieces of a member apart by a shadow.

    Both sections measured, at least one located (seen on two faces or more;
    the other may be seen on one face with its depth measured behind it: roof
    seed 29, a common rafter's foot seen on its side alone past a 1.6 m
    shadow), their sizes within 10 % of each other or within the sum of the
    two pieces' uncertainties of a size read at an edge
    (``EDGE_SIZE_UNCERTAINTY_M`` each, for a piece not seen on all four
    sides; at least that once), and each centre
    within a quarter of the other's section of its axis line.  Two members on
    one line with the same section to a centimetre or two are rare; a member whose
    middle lies in the shadow of a nearer one is not.
    """
    if max(a.faces_seen, b.faces_seen) < 2 or not (a.height_measured and b.height_measured):
        return False
    dims_a = np.sort([a.width, a.height])
    dims_b = np.sort([b.width, b.height])
    # each piece's sizes read at an edge are known to EDGE_SIZE_UNCERTAINTY_M; the
    # difference of two such readings to twice that (roof draw 3: a common
    # rafter's two pieces, 1.5 m apart past a shadow, 0.131 and 0.149 m deep for
    # 0.141, each within 1 cm of it)
    known = EDGE_SIZE_UNCERTAINTY_M * sum(int(c.faces_seen < 4) for c in (a, b))
    tol = np.maximum(0.1 * np.maximum(dims_a, dims_b), max(known, EDGE_SIZE_UNCERTAINTY_M))
    if np.any(np.abs(dims_a - dims_b) > tol):
        return False
    for x, y in ((a, b), (b, a)):
        d = y.centre - x.centre
        if abs(d @ x.axes[:, 1]) > 0.25 * x.width or abs(d @ x.axes[:, 2]) > 0.25 * x.height:
            return False
    return True


def thinner_than(cub: BeamCuboid, min_width: float) -> bool:
    """Whether a cuboid's located section is narrower than any beam (``min_width``, metres).

    Facets grouped across a beam's edge with a coplanar strip of something
    else, or a sliver of a face with the edge strip of another, can make a
    box a centimetre or two thick; no member of a frame is, so it is no beam.
    Only a section located by faces on two sides is judged so: the depth
    behind a beam seen on one face, read from a few side points or not
    measured, may come out that thin for a true member, which is judged by
    the size across its face only.
    """
    sizes = [cub.width, cub.height]
    size = min(sizes) if cub.faces_seen >= 2 and cub.height_measured else max(sizes)
    return bool(size < min_width)


def join_pieces(
    beams: list[BeamCuboid],
    cos_par: float,
    max_gap: float,
    max_shadow: float = 0.0,
    faces: list[PieceFace | None] | None = None,
    plane_tol: float = 0.01,
) -> tuple[list[BeamCuboid], NDArray[np.int32]]:
    """Join the cuboids that are pieces of one beam along their common axis.

    The pieces of a member cut by a crossing member or a shadow are merged
    before their cuboids are lengthened (:func:`merge_and_absorb`), but a
    piece's ends are only known once it has been lengthened over the faces
    seen past them: two pieces 2 m apart as fitted may come out 0.4 m apart.
    Cuboids that are :func:`collinear` (parallel, the same section on one
    line, at most ``max_gap`` apart, or up to ``max_shadow`` with one located
    section) are joined, repeatedly: the joined
    cuboid keeps the section and axis of the piece seen on more faces (then
    the longer one) and spans both pieces along that axis.  With ``faces``
    (:func:`~pyheracles.beams.piece_joins.piece_faces` of ``beams``), two
    pieces seen on one face that show the same face
    (:func:`~pyheracles.beams.piece_joins.same_face`, planes within
    ``plane_tol`` metres) are joined up to ``max_shadow`` apart too (no more
    than the longer piece's length, or farther when the line between them runs
    through no other cuboid, :func:`~pyheracles.beams.piece_joins.gap_clear`):
    their sections, measured behind one face, need not agree.

    Returns
    -------
    beams
        The joined cuboids.
    new_id
        ``(len(beams) + 1,)`` new 1-based id of each old id (index 0 maps to 0).
    """
    out = list(beams)
    ids = list(range(len(beams)))  # current cuboid of each input cuboid
    face_of: list[PieceFace | None] = list(faces) if faces is not None else [None] * len(out)

    def one_member(i: int, j: int) -> bool:
        a, b = out[i], out[j]
        if collinear(a, b, cos_par, max_gap, max_shadow):
            return True
        gap = abs((b.centre - a.centre) @ a.axis) - 0.5 * (a.length + b.length)
        if gap > max_shadow or not same_face(a, b, face_of[i], face_of[j], cos_par, plane_tol):
            return False
        # a shadow longer than either piece: when nothing lies on the line between them
        others = [c for k, c in enumerate(out) if k not in (i, j)]
        return bool(gap <= max(a.length, b.length) or gap_clear(a, b, others))

    joined = True
    while joined:
        joined = False
        if len(out) < 2:
            break
        # candidate pairs: parallel, each centre within a section of the other's axis
        axes = np.array([c.axis for c in out])
        centres = np.array([c.centre for c in out])
        reach = np.array([max(c.width, c.height) for c in out])
        d = centres[None, :, :] - centres[:, None, :]
        perp = d - np.einsum("ijk,ik->ij", d, axes)[:, :, None] * axes[:, None, :]
        near = np.linalg.norm(perp, axis=2) <= reach[:, None] + reach[None, :]
        near &= np.abs(axes @ axes.T) >= cos_par
        for i, j in zip(*np.nonzero(np.triu(near, 1)), strict=True):
            i, j = int(i), int(j)
            if not one_member(i, j):
                continue
            a, b = out[i], out[j]
            main = a if axis_evidence(a) >= axis_evidence(b) else b
            face_of[i] = face_of[i] if main is a else face_of[j]
            ends = np.array(
                [c.centre + s * 0.5 * c.length * c.axis for c in (a, b) for s in (-1.0, 1.0)]
            )
            t = (ends - main.centre) @ main.axis
            lo, hi = float(t.min()), float(t.max())
            out[i] = replace(
                main,
                centre=main.centre + main.axis * 0.5 * (lo + hi),
                length=hi - lo,
                n_facets=a.n_facets + b.n_facets,
            )
            del out[j]
            del face_of[j]
            ids = [i if k == j else (k - 1 if k > j else k) for k in ids]
            joined = True
            break
    new_id = np.concatenate([[0], np.asarray(ids, dtype=np.int32) + 1]).astype(np.int32)
    return out, new_id


def merge_and_absorb(
    xyz: NDArray[np.float64],
    facets: list[StraightFacet],
    group: NDArray[np.int32],
    p: BeamParams,
    bin_m: float,
    free: NDArray[np.float64] | None = None,
) -> NDArray[np.int32]:
    """Merge collinear beam pieces and absorb lone facets lying on a beam.

    A beam crossed by another (X joint) or shadowed by one is seen as separate
    pieces; their cuboids are collinear with the same cross-section, so they
    are merged (gap at most ``max_gap_m``).  A straight facet left alone (one
    face of a piece) joins the beam whose cuboid, extended by ``max_gap_m``
    along its axis, it lies on.
    """
    n_groups = int(group.max(initial=0))
    cubs: dict[int, BeamCuboid] = {}
    for g in range(1, n_groups + 1):
        try:
            cubs[g] = fit_beam_cuboid(
                xyz, [facets[i] for i in np.flatnonzero(group == g)], bin_m=bin_m, free=free
            )
        except DegenerateGeometryError:
            continue
    cos_par = np.cos(np.radians(p.parallel_deg))
    ids = sorted(cubs)
    uf = UnionFind(n_groups + 1)
    for i, gi in enumerate(ids):
        for gj in ids[i + 1 :]:
            if collinear(cubs[gi], cubs[gj], cos_par, p.max_gap_m):
                uf.union(gi, gj)
    out = np.zeros(len(group), dtype=np.int32)
    for k, g in enumerate(group):
        if g > 0 and g in cubs:
            out[k] = uf.find(int(g))
    # lone facets on an (extended) beam
    tol = max(3.0 * float(np.median([f.plane_rms for f in facets])), 0.01) if facets else 0.01
    for k in np.flatnonzero(out == 0):
        f = facets[k]
        pts = xyz[f.index]
        for g in ids:
            c = cubs[g]
            if abs(f.axis @ c.axis) < cos_par:
                continue
            longer = replace(c, length=c.length + 2 * p.max_gap_m)
            if np.median(np.abs(longer.signed_distance(pts))) <= tol:
                out[k] = uf.find(g)
                break
    # renumber 1..B by decreasing point count
    roots = np.unique(out[out > 0])
    sizes = [sum(len(facets[k].index) for k in np.flatnonzero(out == r)) for r in roots]
    order = [int(r) for _, r in sorted(zip(sizes, roots, strict=True), key=lambda t: (-t[0], t[1]))]
    remap = {r: i + 1 for i, r in enumerate(order)}
    return np.array([remap.get(int(g), 0) for g in out], dtype=np.int32)
