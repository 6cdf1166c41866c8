"""Back into 3D: the cookie-cutter around each section shape, floor and ceiling off,
clutter off, final clustering."""

from __future__ import annotations

from collections.abc import Callable
from itertools import pairwise

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.segment.euclidean import voxel_clusters
from pyheracles.supports.core import Array, Scales, SupportParams
from pyheracles.supports.corner_walls import shown_corner
from pyheracles.supports.face_rise import face_rise_along_wall
from pyheracles.supports.floors import foot_floor
from pyheracles.supports.kernels import REACH_MARGIN_M, cookie_candidates
from pyheracles.supports.piers import (
    FOOT_FROM_M,
    FOOT_OWN_M,
    FOOT_REACH_M,
    FOOT_TO_M,
    MAX_NARROW_LAYERS,
    UPPER_FROM_M,
    UPPER_TO_M,
    WallLine,
    flush_wall_ends,
    narrow_share,
    rect_coords,
    walled_at_both_ends,
    walled_piece,
)
from pyheracles.supports.profile import (
    attached_share,
    band_reach,
    carried_surface,
    end_pieces,
    head_cut,
    overhead_cover,
    surface_tolerance,
    wall_beside,
)
from pyheracles.supports.shaft_follow import follow_shaft
from pyheracles.threads import map_threads

RING_M = 0.3  # width of the ring around a cookie that tells floor and ceiling heights
#: Half height of the slab around the section where a support's own spacing is measured.
LOCAL_SLAB_M = 0.5
#: A pier joined to a wall in more than this share of its height layers is a wall edge, a
#: column so joined is an engaged column.
MAX_ATTACHED_SHARE = 0.5


def cookies(
    p: Array, shapes: list[dict], params: SupportParams
) -> list[tuple[NDArray[np.intp], Array, Array]]:
    """Points within buffer + ring of each shape: (indices, offset rho, angle) per shape.

    A point near several shapes (twin columns on one plinth) goes to the one it is
    closest to, relative to the buffers.  The candidates of each shape (the points in the
    cells of side 0.25 m around it, near its outline) come from one compiled pass over the
    cloud in input order (:func:`~pyheracles.supports.kernels.cookie_candidates`); the
    offsets and the test that keeps a point are numpy's, on those candidates only.
    """
    cell = 0.25
    x0, y0 = float(p[:, 0].min()), float(p[:, 1].min())
    # the largest cell index is that of the largest coordinate (the cell is monotonic)
    width = int((float(p[:, 0].max()) - x0) * (1.0 / cell)) + 1
    height = int((float(p[:, 1].max()) - y0) * (1.0 / cell)) + 1
    xy0 = np.array([x0, y0])
    boxes = np.zeros((len(shapes), 4), dtype=np.int64)
    for sid, sh in enumerate(shapes):
        reach = float(np.hypot(*sh["half"])) + sh["buffer"] + RING_M
        lo = np.maximum(np.floor((sh["centre"] - reach - xy0) / cell).astype(int), 0)
        hi = np.minimum(
            np.floor((sh["centre"] + reach - xy0) / cell).astype(int), [width - 1, height - 1]
        )
        boxes[sid] = (*lo, *hi)
    cands = cookie_candidates(p, (x0, y0), cell, (height, width), boxes, *outline_table(shapes))

    def within(sid: int) -> tuple[NDArray[np.intp], Array, Array]:
        """The candidates of shape ``sid`` within its buffer + ring, offsets, angles."""
        sh, idx = shapes[sid], cands[sid]
        rho, ang = offset(np.take(p, idx, axis=0)[:, :2], sh)
        keep = rho <= sh["buffer"] + RING_M
        return idx[keep], rho[keep], ang[keep]

    sid_l, idx_l, rho_l, ang_l = [], [], [], []
    # cookies holding each point: one byte unless there are 256 shapes or more
    n_cookies = np.zeros(len(p), dtype=np.uint8 if len(shapes) < 256 else np.int32)
    # numpy's arithmetic on a cookie's points releases the interpreter: shapes on threads
    for sid, (idx, rho, ang) in enumerate(map_threads(within, range(len(shapes)))):
        n_cookies[idx] += 1  # the indices of one cookie are distinct
        sid_l.append(np.full(len(idx), sid))
        idx_l.append(idx)
        rho_l.append(rho)
        ang_l.append(ang)
    sid_all, idx_all = np.concatenate(sid_l), np.concatenate(idx_l)
    rho_all, ang_all = np.concatenate(rho_l), np.concatenate(ang_l)
    # a point in several cookies goes to the shape it is closest to (relative to the
    # buffers); only those few points are sorted
    shared = np.flatnonzero(n_cookies[idx_all] > 1)
    if len(shared):
        keep = np.ones(len(idx_all), dtype=bool)
        bufs = np.array([sh["buffer"] for sh in shapes])
        srt = shared[np.lexsort((rho_all[shared] / bufs[sid_all[shared]], idx_all[shared]))]
        first = np.r_[True, idx_all[srt][1:] != idx_all[srt][:-1]]
        keep[srt[~first]] = False
        sid_all, idx_all = sid_all[keep], idx_all[keep]
        rho_all, ang_all = rho_all[keep], ang_all[keep]
    bounds = np.r_[0, np.cumsum(np.bincount(sid_all, minlength=len(shapes)))]
    # grouped by shape, each cookie in input order (its candidates were)
    return [(idx_all[a:b], rho_all[a:b], ang_all[a:b]) for a, b in pairwise(bounds)]


def outline_table(shapes: list[dict]) -> tuple[Array, NDArray[np.bool_]]:
    """The shapes' outlines for :func:`~pyheracles.supports.kernels.cookie_candidates`:
    ``(cx, cy, (radius + reach)**2, cos, sin, half_u, half_v, reach)`` per shape (reach =
    buffer + ring + a margin of rounding) and whether each is round (offset as in
    :func:`offset`)."""
    table = np.zeros((len(shapes), 8))
    round_ = np.zeros(len(shapes), dtype=bool)
    for k, sh in enumerate(shapes):
        round_[k] = sh["class"] in ("column", "engaged_column")
        angle = 0.0 if round_[k] else float(sh["angle"])
        table[k, :2] = sh["centre"]
        reach = sh["buffer"] + RING_M + REACH_MARGIN_M
        table[k, 2] = (sh["radius"] + reach) ** 2 if round_[k] else 0.0
        table[k, 3:5] = np.cos(angle), np.sin(angle)
        table[k, 5:7] = (0.0, 0.0) if round_[k] else sh["half"]
        table[k, 7] = reach
    return table, round_


def floor_level(pts: Array, ring: NDArray[np.bool_], h_sec: float, z_min: float) -> float:
    """Floor under a support: a low quantile (5 %) of the ring points below the section
    (of all cookie points below it when the ring holds fewer than 10)."""
    z = pts[:, 2]
    below = z < h_sec
    floor_pts = z[below & ring] if np.count_nonzero(below & ring) >= 10 else z[below]
    return float(np.quantile(floor_pts, 0.05)) if len(floor_pts) else z_min


#: The wall face beside an engaged column is tested in at most this many layers of its
#: height.
FACE_LAYERS = 40
#: A layer holds the face when its face points span this share of the cookie's width
#: along the face, or ``FACE_SPAN_M`` metres if less (a post or a pipe beside a column
#: spans its own width only).
FACE_SPAN_SHARE = 0.5
FACE_SPAN_M = 0.2


def face_cover(
    pts: Array,
    z: Array,
    front: Array,
    rho: Array,
    sh: dict,
    sc: Scales,
    floor_z: float,
    top_z: float,
) -> float:
    """Share of the height of the wall face beside an engaged column that holds the
    face (0..1).

    Layers of ``max(3 x spacing, 5 cm, height / FACE_LAYERS)`` from the floor to the top;
    a layer holds the face when its points on the face line, within the cookie's width
    on either side of the column, span at least ``FACE_SPAN_SHARE`` of that width (or
    ``FACE_SPAN_M``) along it: a wall does in every layer it is seen in, a fence, a
    rail or a bench in a few, a post beside the column in none.  Cells of
    ``3 x spacing`` over the face's area, as before, counted the wall of a tall nave as
    a third covered: high up and far from the stations its points are further apart
    than the cloud's median spacing (draw 39 of the supports family: 0.6 m engaged
    columns 17 m tall, points in 64-68 of about 70 layers of 25 cm, 5-45 % of the cells).
    """
    c = max(0.05, 3.0 * sc.spacing)
    width = sh["buffer"] + RING_M - 2 * sc.tol
    on = (np.abs(front) <= max(sh["face_gap"], sc.tol)) & (rho > 2 * sc.tol)
    on &= (z > floor_z) & (z < top_z)
    if width <= 0 or top_z <= floor_z or not on.any():
        return 0.0
    t = np.array([-sh["normal"][1], sh["normal"][0]])
    along = (pts[on, :2] - sh["centre"]) @ t
    step = max(c, (top_z - floor_z) / FACE_LAYERS)
    n_layers = int(np.ceil((top_z - floor_z) / step))
    iz = np.minimum(((z[on] - floor_z) / step).astype(np.int64), n_layers - 1)
    hi = np.full(n_layers, -np.inf)
    lo = np.full(n_layers, np.inf)
    np.maximum.at(hi, iz, along)
    np.minimum.at(lo, iz, along)
    need = min(FACE_SPAN_SHARE * width, FACE_SPAN_M)
    return float(np.count_nonzero(hi - lo >= need)) / n_layers


def extract_support(
    p: Array,
    idx: NDArray[np.intp],
    rho: Array,
    ang: Array,
    sh: dict,
    params: SupportParams,
    sc: Scales,
    h_sec: float,
    z_range: tuple[float, float],
    height_band: Callable[[float, float], NDArray[np.intp]] | None = None,
) -> tuple[NDArray[np.intp], Array, Array] | None:
    """The points of one support inside its cookie (indices, offsets, coordinates), or
    None if it is not one.

    ``height_band(z_lo, z_hi)`` gives the indices of the points of ``p`` between two
    heights (a slice of the sorted heights): with it, a pier candidate whose foot stands
    in a wall face (:func:`~pyheracles.supports.piers.foot_on_wall_line`) is a wall
    piece.  A pier, carrying something or not, must be a prism as wide as its section
    (:func:`~pyheracles.supports.piers.narrow_share`: a lying drum is not, nor the tub
    of a pulpit on its post, which "carries" the ceiling above it).  Sets
    ``sh["carries"]`` (whether a carried surface was found above it) and
    ``sh["carried_z"]`` (the underside of what it carries, inf if nothing),
    ``sh["reaches"]`` (whether it carries something and reaches it,
    :func:`reaches_carried`) and, if not, ``sh["overhead"]``
    (:func:`~pyheracles.supports.profile.overhead_cover`).

    From the floor under it (off by the floor's own noise) up to the underside of what it
    carries (:func:`~pyheracles.supports.profile.carried_surface`; the points above the
    body, an attic, count too), within the reach of its own profile per height band
    (:func:`~pyheracles.supports.profile.band_reach`), connected to its section island.  It must be
    ``min_height_fraction`` of the floor-to-carried height tall, or, carrying nothing (a
    broken column, a column under the open sky), ``min_free_height_m``.
    """
    pts = np.take(p, idx, axis=0)  # one gather of the cookie's points
    ring = rho > sh["buffer"]
    z = pts[:, 2]
    floor_z = floor_level(pts, ring, h_sec, z_range[0])
    cell = max(0.05, 3.0 * sc.spacing)
    bounds = (0.01, 0.05)
    ftol = params.floor_tolerance_m or surface_tolerance(
        z[ring & (z < h_sec)], floor_z, cell, bounds
    )
    wall = np.zeros(len(z), dtype=bool)
    front = None
    if sh["class"] == "engaged_column" or sh.get("respond", False):
        front = pts[:, :2] @ sh["normal"] - sh["d"]  # distance to the face, + into the room
        wall = front <= sh["face_gap"]  # 3 sigma of the wall face off the face
    free = np.flatnonzero(~wall)
    top_z, carried_free = carried_surface(
        pts[free, :2], z[free], rho[free], sh["centre"], sh["buffer"], RING_M, sc,
        h_sec + sc.thickness / 2,
    )  # fmt: skip
    carried = np.zeros(len(z), dtype=bool)
    carried[free[carried_free]] = True
    ctol = 0.0
    if np.isfinite(top_z):
        ctol = params.ceiling_tolerance_m or surface_tolerance(
            z[carried & ring], top_z, cell, bounds
        )
    # what it carries may stand over its own plan below its spanning layer (a vault
    # springing from its abacus): the top is where points first lie well inside its
    # outline (only under a carried surface: the fracture of a broken column, seen from
    # above, lies inside its outline too)
    layer = max(0.05, 3.0 * sc.spacing)
    n_sec = max(8, int(2 * np.pi * max(float(np.max(sh["half"])), 0.05) / (3 * sc.spacing)))
    if np.isfinite(top_z):
        inner = free[~ring[free]]
        z_head = head_cut(
            rho[inner], ang[inner], z[inner], h_sec + sc.thickness / 2 + layer, top_z,
            layer, min(n_sec, 72), sc.tol,
        )  # fmt: skip
        if z_head < top_z - ctol:
            top_z, ctol = z_head, 0.0
    if front is not None:
        # an engaged column stands in a wall: the face must rise with it (a fence rail or
        # a bench touching a one-sided scanned column is no wall)
        top = top_z if np.isfinite(top_z) else z_range[1]
        if (
            # an engaged column of a row whose rings stop on one line (engaged_rows): its
            # wall was never seen beside it (a ruin's walls end below its section)
            not sh.get("row_cut", False)
            and face_cover(pts, z, front, rho, sh, sc, floor_z, top) < 0.5
            and not (
                sh["class"] == "engaged_column"
                and height_band is not None
                and face_rise_along_wall(p, height_band, sh, sc.tol, (floor_z, top), cell) >= 0.5
            )
        ):  # the face in the cookie is shadowed or cut by an opening: followed along
            # the wall, it rises with the column (supports draw 0)
            if sh.get("respond", False):
                return None  # a bump on a wall that does not rise with it: clutter
            sh["class"] = "column"
            wall[:] = False
    inside = ~ring & ~wall & (z > floor_z + ftol) & (z < top_z - ctol)
    cidx, cpts = idx[inside], pts[inside]
    if len(cidx) < params.min_points:
        return None
    # clutter: only what is within the reach of the support's own profile in its height
    # band (a fence rail or a chair touching a column fills a few sectors of a band)
    r_in, a_in, z_in = rho[inside], ang[inside], cpts[:, 2]
    radius = float(sh["radius"]) if sh["class"] != "pier" else 0.0
    keep = r_in <= band_reach(r_in, a_in, z_in, layer, min(n_sec, 72), radius, sc.tol)
    cidx, crho, cpts, cang = cidx[keep], r_in[keep], cpts[keep], a_in[keep]
    if len(cidx) < params.min_points:
        return None
    # final clustering: keep what is connected to the section island, at the support's
    # own point spacing (a column far from the scanners is crossed by scan lines further
    # apart than the cloud's median spacing: at that spacing it falls into pieces)
    near_sec = np.abs(cpts[:, 2] - h_sec) <= LOCAL_SLAB_M  # the spacing where it was cut
    gap = local_spacing(cpts[near_sec] if np.count_nonzero(near_sec) >= 50 else cpts)
    voxel = max(0.03, 3.0 * sc.spacing, 3.0 * gap)
    lab = voxel_clusters(cpts, voxel, 1)
    in_sec = np.abs(cpts[:, 2] - h_sec) <= sc.thickness / 2
    good = np.unique(lab[in_sec & (lab > 0)])
    if len(good) == 0:
        return None
    # and, round a column, the pieces cut off at its ends by faces not seen (a plinth's
    # top, an abacus's underside; a pier's plinth and impost stand out of it by less than
    # the gap, and a pulpit's tub cut as a pier is not to be joined to its post: draw 24)
    conn = np.isin(lab, good)
    if sh["class"] != "pier":
        # a round shaft on through the sparse stretches of its height, at their own
        # spacing (draw 33: the dense band of the scans ends at 7-10 m of 15 m columns;
        # not a pier: a jamb followed up its wall's face stood free of it, draw 10)
        followed = follow_shaft(cpts, crho, conn, voxel, sc.tol)
        sh["followed"] = int(np.count_nonzero(followed & ~conn))
        conn = followed
        # and not below the level its foot stands on: at a dais's edge the ring holds
        # the ground beyond it, and the dais's face flush with a plinth is no piece of
        # it (the level is read in the ring's outer half: a plinth's corners reach into
        # the inner half)
        outer = (rho > sh["buffer"] + 0.5 * RING_M) & (z < h_sec)
        foot_z = foot_floor(
            pts[outer, :2], z[outer], float(cpts[conn, 2].min()), floor_z, cell, ftol
        )
        if foot_z > floor_z:
            foot_tol = params.floor_tolerance_m or surface_tolerance(z[outer], foot_z, cell, bounds)
            lab = np.where(cpts[:, 2] > foot_z + foot_tol, lab, 0)
        conn = end_pieces(cpts[:, 2], crho, cang, lab, conn, cell, min(n_sec, 72))
    cidx, crho, cpts = cidx[conn], crho[conn], cpts[conn]
    height = float(np.ptp(cpts[:, 2]))
    if sh["class"] in ("pier", "column"):
        # joined to a wall over most of its height: a pier is a wall edge (a jamb, a
        # reveal, a ruined wall), a column is engaged in the wall (whose junction with
        # it was in the shadow at the section)
        lo, hi = float(cpts[:, 2].min()) + cell, float(cpts[:, 2].max()) - cell
        share = attached_share(
            pts[free, :2], z[free], rho[free], sh["centre"], sh["buffer"], RING_M, sc, (lo, hi)
        )
        feet = foot_levels(cpts[:, 2], floor_z, ftol)
        # the band under its own top whether or not a carried surface was found over
        # it: the wall over the lintels beside a wall piece is one with it whatever
        # the ceiling above showed (draw 29, noise draws 0 and 1)
        own_top = float(cpts[:, 2].max())
        span = (floor_z, float(cpts[:, 2].max()))
        if (
            sh["class"] == "pier"
            and not sh.get("respond", False)
            and (
                share > MAX_ATTACHED_SHARE
                or wall_piece_in_bands(p, pts, rho, sh, sc, h_sec, feet, own_top, height_band)
                or walled_in_bands(p, pts, rho, sh, sc, h_sec, span, height_band)
            )
        ):  # joined to a wall in most layers, or the wall runs on from its foot, over
            # the lintels beside it or in bands of its height: a wall piece
            sh["wall_edge"] = True
            return None
        if sh["class"] == "column" and share > MAX_ATTACHED_SHARE:
            sh["class"] = "engaged_column"
        elif sh["class"] == "column":
            mine = np.zeros(len(z), dtype=bool)
            mine[np.searchsorted(idx, cidx)] = True
            face = wall_beside(
                pts[~mine, :2], z[~mine], rho[~mine], sh["centre"], sh["radius"], sc,
                (0.5 * (lo + hi), hi),  # the upper half: a fence or a bench stays low
            )  # fmt: skip
            if face is not None:
                sh["class"], sh["normal"], sh["d"] = "engaged_column", face[0], face[1]
    # a support carrying nothing (a broken column, one under the open sky) stands
    # min_free_height_m tall; one carrying something no lower, whatever it "carries" (a
    # sign board on its post, a pile of debris under a fallen block), and spans
    # min_height_fraction of the height up to what it carries (its foot or top may be
    # in the shadow: its own points need not reach its floor)
    free_need = min(params.min_free_height_m, params.min_height_fraction * (z_range[1] - floor_z))
    need = params.min_height_fraction * (top_z - floor_z) if np.isfinite(top_z) else free_need
    own_top = float(cpts[:, 2].max())
    sh["carries"] = bool(np.isfinite(top_z))
    sh["carried_z"] = float(top_z)
    # a support carrying something reaches it; one ending well below the surface found
    # over it (a pulpit's post under its tub's rim) may stand under what it does not carry
    sh["reaches"] = sh["carries"] and reaches_carried(own_top, floor_z, top_z)
    sh["overhead"] = 0.0 if sh["reaches"] else overhead_cover(z[ring], ang[ring], own_top)
    if height < need or own_top - floor_z < free_need:
        return None  # a chair, a sign board, a fence post: not a support
    if (
        sh["class"] == "pier"
        and narrow_share(cpts[:, :2], cpts[:, 2], sh, sc.tol, cell) > MAX_NARROW_LAYERS
    ):  # no prism, whatever it carries: a lying drum, debris, the tub of a pulpit on
        # its post under a ceiling (draw 4: three tubs cut by the section were piers)
        return None
    return cidx, crho, cpts


#: A support carries what it reaches: its own top lies at least this share of the way
#: from its floor up to the underside of what it carries.
CARRIED_REACH_SHARE = 0.8


def reaches_carried(top: float, floor_z: float, carried_z: float) -> bool:
    """Whether a support whose own points end at ``top`` reaches the underside
    ``carried_z`` of the surface found above it, from its floor ``floor_z`` (metres).

    The carried surface is the lowest spanning one above the section, so a support
    reaches it but for a capital's or a top's points cut off with the ceiling's
    tolerance, or a top shadowed over a few decimetres (a column seen from 1.35 to 2.58
    m under a ceiling at 2.8 m reaches 0.92 of the way).  Clutter whose upper part was
    left out of it does not: the post of a pulpit ends under its tub, the surface found
    over it is the tub's rim 1 m higher (supports draw 26: 0.64 of the way).  Nor does
    the pier of an arcade, whose arches spring from its top and span only higher up
    (draw 32: 0.76 of the way), so a support not reaching what it was found under is
    only judged by what stands round its top
    (:func:`~pyheracles.supports.carriers.covered_free_columns`).
    """
    return top - floor_z >= CARRIED_REACH_SHARE * (carried_z - floor_z)


def foot_levels(z: Array, floor_z: float, ftol: float) -> tuple[float, ...]:
    """Heights a support's foot may stand at: the floor under it and, when its own lowest
    points ``z`` stand higher than :data:`~pyheracles.supports.piers.FOOT_FROM_M` above
    that floor, just below them (metres).

    The floor of a cookie is a low quantile of its ring (:func:`floor_level`): at the
    edge of a podium the ring holds the ground outside, 0.5-1 m below the floor the
    support stands on, and the foot band of :func:`wall_piece_in_bands` then lay in the
    podium's side (draw 15 of the supports family: the wall between two windows,
    standing on the podium with the wall below the sills, was a pier).  The floor stays
    a candidate: a jamb whose own lowest points were cut off above it stands in its
    wall there.
    """
    if not len(z):
        return (floor_z,)
    own = float(z.min()) - ftol
    return (floor_z, own) if own > floor_z + FOOT_FROM_M else (floor_z,)


def local_spacing(pts: Array, sample: int = 2000) -> float:
    """Scan-line gap of a support's own points (metres): the median distance to the
    fourth nearest neighbour (on a regular grid that is the spacing; on scan lines far
    apart, dense along each line, it follows the gap between the lines, which the nearest
    neighbour does not see), capped at 5 cm (sparser, a support's points are no
    surface)."""
    if len(pts) < 5:
        return 0.0
    q = pts[np.linspace(0, len(pts) - 1, min(len(pts), sample)).astype(np.intp)]
    d, _ = cKDTree(pts).query(q, k=5)
    return float(min(np.median(d[:, 4]), 0.05))


def offset(xy: Array, sh: dict) -> tuple[Array, Array]:
    """Offset of points from a support's section shape (metres, >0 outside) and angle."""
    q = xy - sh["centre"]
    if sh["class"] in ("column", "engaged_column"):
        return np.hypot(q[:, 0], q[:, 1]) - sh["radius"], np.arctan2(q[:, 1], q[:, 0])
    u, v = rect_coords(xy, sh["centre"], sh["angle"]).T
    a, b = sh["half"]
    return np.maximum(np.abs(u) - a, np.abs(v) - b), np.arctan2(v / b, u / a)


def wall_piece_in_bands(
    p: Array,
    pts: Array,
    rho: Array,
    sh: dict,
    sc: Scales,
    h_sec: float,
    feet: tuple[float, ...],
    top: float | None,
    height_band: Callable[[float, float], NDArray[np.intp]] | None,
) -> bool:
    """Whether a pier candidate is a piece of a wall: its foot stands in a wall face
    (:func:`~pyheracles.supports.piers.foot_on_wall_line`, at any of the heights
    ``feet``), or (``top``: its own highest point; None: the foot only) wall faces
    flush with its faces run on beyond both of its ends at its foot or in the band
    under its top (:data:`~pyheracles.supports.piers.UPPER_FROM_M` to
    :data:`~pyheracles.supports.piers.UPPER_TO_M` below it), one end in one band and
    the other in the other if need be
    (:func:`~pyheracles.supports.piers.walled_at_both_ends`), or two of them, on faces
    it shows and at least 45 degrees apart, run on beyond one of its ends each, in
    either band, parallel to its sides
    (:func:`~pyheracles.supports.corner_walls.shown_corner`: a corner).

    Under the top of an anta, the echinus of the column in antis 0.6 m beyond its end
    was read as a line 9 degrees across its side and flush with it at one corner: with
    the cella wall at its foot, two "walls" met at it (the temple scene of
    :mod:`pyheracles.synthetic.buildings`); a wall flush with a face runs parallel to it.

    Where two walls meet between a window in one and a door in the other, the section
    cuts the corner off like a pier, and the shadows of the supports standing in front
    of the walls cut its faces off the walls beside it over most of its height: only
    under its top do both walls run on from it, beyond one end each (supports draw 0:
    an inner corner 1.2 x 0.56 m between a window and the next wall, seen from inside;
    draw 3, noise draws 2 and 3: a ruin's corner block between a window and a door,
    its walls standing to 1.4 m).

    The wall between a door and a window, or between two doors, stands free from the
    floor up to the lintels and is cut off like a pier; the wall above the lintels is
    one with it and runs on beyond its ends below the ceiling it reaches (supports draw
    29).  A pier carries what rests on it: the arches of an arcade spring from its
    top, a beam or an architrave lies over it, and nothing of a wall stands beside it
    under its top."""
    cell = max(0.05, 3.0 * sc.spacing)
    n_foot = max(1, int(np.ceil((FOOT_TO_M - FOOT_FROM_M) / cell)))
    foot_lines = []
    for foot in feet:
        band = (foot + FOOT_FROM_M, foot + FOOT_TO_M)
        lines = band_wall_lines(p, pts, rho, sh, sc, h_sec, band, height_band, n_foot)
        if walled_piece(lines):
            return True
        foot_lines.append(lines)
    if top is None:
        return False
    upper = band_wall_lines(
        p, pts, rho, sh, sc, h_sec, (top - UPPER_FROM_M, top - UPPER_TO_M), height_band
    )
    if not upper:
        return False
    axis = np.array([np.cos(sh["angle"]), np.sin(sh["angle"])])
    return any(
        walled_at_both_ends(lines + upper, axis)
        # or two walls meeting at it, each beyond one of its ends (a corner)
        or shown_corner(lines + upper, axis, sh["half"], sc.tol)
        for lines in foot_lines or [[]]
    )


#: Height bands of a pier candidate in which wall faces on faces it shows run on beyond
#: both of its ends (:func:`walled_band_count`) that make it a piece of a wall.
MIN_WALLED_BANDS = 2
#: The bands of :func:`walled_band_count` overlap by half: one starts this much higher
#: than the last (metres), at least; at most :data:`MAX_BANDS` bands per candidate.
BAND_STEP_M = 0.5 * (FOOT_TO_M - FOOT_FROM_M)
MAX_BANDS = 40


def walled_in_bands(
    p: Array,
    pts: Array,
    rho: Array,
    sh: dict,
    sc: Scales,
    h_sec: float,
    span: tuple[float, float],
    height_band: Callable[[float, float], NDArray[np.intp]] | None,
) -> bool:
    """Whether a pier candidate is a piece of a wall by the bands of its height
    (:func:`walled_band_count`): in :data:`MIN_WALLED_BANDS` of them the wall runs on
    beyond both of its ends (or round a corner).  A wall running on beyond one end
    only is an anta's or a respond's."""
    return walled_band_count(p, pts, rho, sh, sc, h_sec, span, height_band) >= MIN_WALLED_BANDS


def walled_band_count(
    p: Array,
    pts: Array,
    rho: Array,
    sh: dict,
    sc: Scales,
    h_sec: float,
    span: tuple[float, float],
    height_band: Callable[[float, float], NDArray[np.intp]] | None,
) -> int:
    """Number of height bands of a pier candidate, from its floor to its own top
    (``span``), in which wall faces flush with faces it shows run on from its ends
    (``from_end`` of :func:`band_wall_lines`) beyond both of them (or two of them, 45
    degrees apart, beyond one end each: a corner;
    :func:`~pyheracles.supports.piers.walled_piece` of the shown faces).

    A piece of a wall is one with the wall over part of its height: below the sills of
    the windows beside it, above their lintels, or, in a ruin, up to the broken tops of
    the wall's lower pieces on either side.  Where that is, the section does not say,
    and one band at its foot hinges on where the floor and its own lowest points were
    seen (supports draw 15: the ground outside a 0.6 m podium, the podium's side joined
    to it by the noise).  Bands of ``FOOT_TO_M - FOOT_FROM_M`` every
    :data:`BAND_STEP_M` over its whole height, the last one right under its top, each
    say whether the wall runs on (over a door and a window beside a building's corner
    the wall is one with the corner piece in the top 0.5 m only: supports draw 16, where
    the bands every 0.2 m stopped 0.12 m short of the top and one of them was walled); a
    free pier has none (a respond's back is flush with its wall but is no face it
    shows; a fence runs on its axis, a bench is in one band at most).
    """
    lo, hi = span[0] + FOOT_FROM_M, span[1] - UPPER_TO_M
    height = FOOT_TO_M - FOOT_FROM_M
    if hi - lo < height:
        return 0
    step = max(BAND_STEP_M, (hi - lo - height) / (MAX_BANDS - 1))
    cell = max(0.05, 3.0 * sc.spacing)
    n_layers = max(1, int(np.ceil(height / cell)))
    both = 0
    starts = np.arange(lo, hi - height + 1e-9, step)  # at most MAX_BANDS bands
    if hi - height - starts[-1] > 1e-6:  # and the band right under its top
        starts = np.r_[starts, hi - height]
    for z0 in starts:
        lines = band_wall_lines(
            p, pts, rho, sh, sc, h_sec, (float(z0), float(z0) + height), height_band, n_layers,
            from_end=True,
        )  # fmt: skip
        both += walled_piece([line for line in lines if line[2]])
    return both


def band_wall_lines(
    p: Array,
    pts: Array,
    rho: Array,
    sh: dict,
    sc: Scales,
    h_sec: float,
    z_band: tuple[float, float],
    height_band: Callable[[float, float], NDArray[np.intp]] | None,
    n_layers: int | None = None,
    from_end: bool = False,
) -> list[WallLine]:
    """The wall faces flush with a pier candidate's faces in the height band ``z_band``
    and the ends they run on beyond (:func:`~pyheracles.supports.piers.flush_wall_ends`),
    among the points of ``p`` in that band (from ``height_band``) within
    ``FOOT_REACH_M`` of its outline and beyond ``FOOT_OWN_M`` of it; ``pts``, ``rho``
    are the cookie's points and offsets, its own faces those at its section ``h_sec``;
    ``n_layers``: the band's height layers (by default its height over the layer)."""
    own = own_section(rho, pts[:, 2], h_sec, sc)
    if height_band is None or np.count_nonzero(own) < 10 or z_band[1] <= z_band[0]:
        return []
    band = height_band(*z_band)
    q = np.take(p, band, axis=0)
    reach = float(np.hypot(*sh["half"])) + FOOT_REACH_M
    near = np.flatnonzero(np.max(np.abs(q[:, :2] - sh["centre"]), axis=1) <= reach)
    q = q[near]
    r_off, _ = offset(q[:, :2], sh)
    q = q[(r_off > max(FOOT_OWN_M, 2.0 * sc.tol)) & (r_off <= FOOT_REACH_M)]
    cell = max(0.05, 3.0 * sc.spacing)
    layer = np.floor((q[:, 2] - z_band[0]) / cell).astype(np.int64)
    if n_layers is None:
        n_layers = max(1, int(np.ceil((z_band[1] - z_band[0]) / cell)))
    rng = np.random.default_rng(0)
    c = sh["centre"]
    return flush_wall_ends(
        q[:, :2] - c, layer, pts[own, :2] - c, sc.tol, cell, rng, n_layers, from_end
    )


def own_section(rho: Array, z: Array, h_sec: float, sc: Scales) -> NDArray[np.bool_]:
    """A support's own surface points in its section slab: within ``tol`` of its shape."""
    return (np.abs(z - h_sec) <= sc.thickness / 2) & (rho <= sc.tol)
