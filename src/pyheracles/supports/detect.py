"""The support detection: section height, islands, shapes, cookie-cutter, primitives."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from functools import partial

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.errors import InputError
from pyheracles.forks import ForkedCall
from pyheracles.geometry.sections import sort_order
from pyheracles.resources import check_spread
from pyheracles.supports.anta_islands import anta_islands
from pyheracles.supports.arcs import arc_owner, arc_wall_piers
from pyheracles.supports.carriers import (
    LOW_CARRY_SHARE,
    THIN_FREE_SHARE,
    covered_free_columns,
    low_carriers,
    thin_free_columns,
)
from pyheracles.supports.clutter import thin_pier
from pyheracles.supports.cookies import cookies
from pyheracles.supports.core import (
    MAX_SECTION_SHARE,
    Array,
    Island,
    Scales,
    SupportParams,
    SupportResult,
    empty_table,
    estimate_spacing,
    one_blas_thread,
    scales,
)
from pyheracles.supports.engaged_faces import engage_on_wall_faces
from pyheracles.supports.engaged_rows import engage_rows
from pyheracles.supports.face_boxes import join_face_parts, section_parts
from pyheracles.supports.face_rise import FACE_REACH_M, neighbour_discs
from pyheracles.supports.faceon import face_on_piers
from pyheracles.supports.height import choose_height, dense_extent, unseen_notes
from pyheracles.supports.line_responds import line_responds
from pyheracles.supports.low_section import low_heights, supports_floor
from pyheracles.supports.measure import measure_supports
from pyheracles.supports.openings import opening_piers
from pyheracles.supports.piers import WALL_LINE_GAP_M, in_wall_line, wall_alongside, wall_fragment
from pyheracles.supports.primitives import dedupe, implausible
from pyheracles.supports.responds import respond_island, responds_on_wall
from pyheracles.supports.ring_heights import arc_columns
from pyheracles.supports.rings import (
    RING_RADIUS_M,
    detached_half_column,
    engaged_on_wall,
    wall_face_lines,
)
from pyheracles.supports.sections import regroup_pier_pieces, section_islands
from pyheracles.supports.shaft_above import ends_short
from pyheracles.supports.thick_slab import (
    THICK_SECTION_M,
    shape_reach,
    slab_indices,
    thick_islands,
    thick_pier,
)

# ------------------------------------------------------------------------------ main
#: The lower section (supports ending below the automatic one) lies this many times
#: ``min_free_height_m`` above the floor: every support that counts crosses it.
LOW_SECTION_FACTOR = 0.8
#: A column of the thick low section is at most this many times the radius of the
#: thickest column found in the thin sections and the main thick one.
LOW_RADIUS_SHARE = 1.25


def detect_supports(
    xyz: Array,
    params: SupportParams | None = None,
    *,
    spacing_m: float | None = None,
    z_order: NDArray[np.intp] | None = None,
    z_sorted: Array | None = None,
    source: str | None = None,
) -> SupportResult:
    """Find columns, piers and engaged columns in a levelled body cloud.

    Parameters
    ----------
    xyz
        ``(N, 3)`` levelled coordinates of the building body, metres (z up).  Run
        :func:`pyheracles.building.attic_split` first to remove the attic.
    params
        Detection parameters (automatic where ``None``).
    spacing_m
        Known point spacing, metres; estimated when omitted.
    z_order, z_sorted
        ``argsort`` of ``xyz[:, 2]`` and ``xyz[z_order, 2]`` when the caller has them
        (saves a sort).
    source
        File name for error messages.

    Returns
    -------
    SupportResult
        Per-point support ids aligned with ``xyz`` and the supports table.  No
        supports, with a note saying why, when the cloud is too sparse for sections
        (the slab that keeps an outline in one piece would be thicker than half the
        body).  Candidates whose fitted primitive does not lie within their points,
        and pier-like pieces of walls, are left in the body (counted in the notes).

    Raises
    ------
    InputError
        NaN coordinates, fewer than ``params.min_points`` points, all points at one
        location, on one vertical line or at one height.

    Examples
    --------
    >>> from pyheracles.synthetic.buildings import building_scene
    >>> scene = building_scene("hall", spacing_m=0.06, rng=0)
    >>> found = detect_supports(scene.xyz)
    >>> found.objects["class"].value_counts().to_dict()
    {'engaged_column': 8, 'column': 8}
    """
    params = params or SupportParams()
    p = np.asarray(xyz, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(f"coordinates must have shape (N, 3), got {p.shape}", path=source)
    if not np.isfinite(p).all():
        raise InputError("the body has NaN or infinite coordinates", path=source,
                         hint="remove those points first")  # fmt: skip
    check_spread(p, step="supports", min_points=params.min_points, path=source, need_z=True)
    with one_blas_thread():
        return detect_supports_checked(p, params, spacing_m, z_order, z_sorted)


def detect_supports_checked(
    xyz: Array,
    params: SupportParams | None,
    spacing_m: float | None,
    z_order: NDArray[np.intp] | None,
    z_sorted: Array | None,
) -> SupportResult:
    """:func:`detect_supports` on input already checked (finite, enough points and spread:
    :func:`pyheracles.building.segment_building` checks the whole cloud once).

    ``z_order`` may index only part of ``xyz`` (the body below an attic limit): the
    section height and the islands are then searched in that part, while the supports
    are cut out of all of ``xyz`` (each up to what it carries)."""
    params = params or SupportParams()
    rng = np.random.default_rng(params.seed)
    p = np.asarray(xyz, dtype=np.float64)
    n = len(p)
    empty = SupportResult(np.zeros(n, dtype=np.int32), empty_table(), float("nan"), float("nan"))
    if n < params.min_points:  # a body left with too few points (checked input has more)
        return replace(empty, notes=("too few points for a support search",))
    if z_order is None:
        order, z_sorted = sort_order(p[:, 2])
    else:
        order = np.asarray(z_order)
        z_sorted = p[:, 2][order] if z_sorted is None else np.asarray(z_sorted)
    spacing = spacing_m if spacing_m is not None else estimate_spacing(p, z_sorted, rng)
    sc = scales(spacing, params)
    # the floor and the top, not the lowest and highest points: outliers below and above
    # moved the section search down or up into the sky
    z0, z1 = dense_extent(z_sorted)
    if params.section_thickness_m is None and sc.thickness > MAX_SECTION_SHARE * (z1 - z0):
        # a slab that thick from mid-height reaches floor and ceiling: it is no section,
        # and its islands are whatever the walls' points project to (pieces of walls)
        return SupportResult(
            empty.instance, empty.objects, float("nan"), spacing, [],
            (f"the cloud is too sparse for a support search: at {spacing:.2f} m point "
             f"spacing a section must be {sc.thickness:.1f} m thick to keep a support's "
             f"outline in one piece, more than half the body height ({z1 - z0:.1f} m); "
             "supports need a denser (terrestrial or close-range) scan",),
        )  # fmt: skip

    # 1. section height: given, or where support islands are most numerous and stable
    scores: list[tuple[float, int]] = []
    lo, hi = z0 + 0.25 * (z1 - z0), z0 + 0.85 * (z1 - z0)
    if params.section_height_m is not None:
        h_sec = z0 + params.section_height_m
    else:
        h_sec, scores = choose_height(p, order, z_sorted, params, sc, lo, hi)
    # 2. islands of the section, and the support shapes they give
    s, e = np.searchsorted(z_sorted, [h_sec - sc.thickness / 2, h_sec + sc.thickness / 2])
    sec_idx = order[s:e]
    thick = params.section_thickness_m is None and THICK_SECTION_M > 1.5 * sc.thickness

    def thick_call(hs: list[float]) -> ForkedCall | None:
        """The islands of the thick slabs about ``hs`` (2c, 2e; no random draws), from
        a forked child while this process searches the thin sections."""
        isl = partial(thick_islands, p, order, z_sorted, hs, params, sc.distance)
        return ForkedCall(isl) if thick and hs else None

    thick_main = thick_call([h_sec])
    islands = section_islands(p[sec_idx, :2], params, sc.distance)
    at = f"{h_sec - z0:.2f} m above the floor"
    notes: list[str] = [] if len(sec_idx) else [f"the section {at} is empty"]
    shapes, fragments = support_shapes(p[sec_idx, :2], islands, params, sc, rng)
    if fragments:
        notes.append(
            f"{fragments} pier-like island{'s' if fragments > 1 else ''} of the section "
            f"{'are pieces of walls' if fragments > 1 else 'is a piece of a wall'} (the wall "
            "goes on beside it): not supports"
        )
    # 2b. lower sections for the supports that end below the first one (broken columns,
    # stumps of a ruin): at 0.8 x min_free_height_m above the floor, and as high above
    # the floor the supports of the main section stand on when that is a platform (the
    # ground outside is the cloud's floor; draw 24: broken columns of 1.5-2.1 m on a
    # platform 0.8 m high, their feet shadowed by its edge), new shapes only
    main = [sh for sh in shapes if sh["class"] in ("column", "pier", "engaged_column")]
    z_sup = supports_floor(p, order, z_sorted, main, [shape_reach(sh) for sh in main], z0, h_sec)
    lows: list[tuple[float, Array]] = []  # per low section: height, plan points
    thick_lows = None
    if params.section_height_m is None:
        above = LOW_SECTION_FACTOR * params.min_free_height_m
        low_hs = list(low_heights(z0, z_sup, h_sec, above, params.persistence_m))
        thick_lows = thick_call(low_hs)
        for h_low in low_hs:
            low_xy = p[slab_indices(order, z_sorted, h_low, sc.thickness), :2]
            lows.append((h_low, low_xy))
            low_islands = section_islands(low_xy, params, sc.distance)
            low_shapes, _ = support_shapes(low_xy, low_islands, params, sc, rng, responds=False)
            if lows[0][0] != h_low:  # on a platform: columns only (its low ruin walls and
                # the posts of clutter are pier-like islands there: draws 19, 24)
                low_shapes = [sh for sh in low_shapes if sh["class"] == "column"]
            for sh in low_shapes:
                sh["h_sec"] = h_low
            shapes = dedupe(shapes + low_shapes)

    # 2c. a thick section for the supports too sparse for the thin one (a few hundred
    # points on a column far from every station): the same islands on a slab
    # THICK_SECTION_M thick, new shapes clear of every shape found and of the thick
    # slab's walls only (it holds more of the clutter and of the window frames), piers
    # at least min_support_size_m across both ways (draw 8: a 0.3 m pier with 7 points
    # in the thin section; draw 14: two antae with 19 and 24)
    def thick_at(
        h: float, thin_xy: Array, isl: list[Island]
    ) -> tuple[list[dict], NDArray[np.intp], list, Callable]:
        """New shapes of the thick slab about ``h`` (``thin_xy``: the thin section's
        plan points there; ``isl``: its islands, of ``thick_islands``), its indices and
        islands, and its walls' test."""
        thick_idx = slab_indices(order, z_sorted, h, THICK_SECTION_M)
        thick_xy = p[thick_idx, :2]
        walls = [thick_xy[i.index] for i in isl if i.kind == "wall"]
        # one tree of the slab's wall points, for its half-columns and for its walls' test
        wall_tree = cKDTree(np.vstack(walls)) if walls else None
        thick_shapes, _ = support_shapes(
            thick_xy, isl, params, sc, rng, responds=False, wall_tree=wall_tree
        )

        def free_of_walls(sh: dict) -> bool:
            """A free shape: no wall of the thick slab at it (a corner, a window frame)."""
            reach = shape_reach(sh) + 3 * sc.distance
            return wall_tree is None or not wall_tree.query_ball_point(sh["centre"], reach)

        added = [
            sh
            for sh in thick_shapes
            if sh["class"] in ("column", "pier")
            and clear_of(sh, shapes)
            and free_of_walls(sh)
            and (sh["class"] == "column" or thick_pier(sh, params, thin_xy))
        ]
        for sh in added:
            sh["sparse"] = True
        return added, thick_idx, isl, free_of_walls

    if thick_main is not None:
        added, thick_idx, thick_isl, free_of_walls = thick_at(
            h_sec, p[sec_idx, :2], thick_main.result()[0]
        )
        shapes += added
        # 2c'. responds on the building's wall face lines: a wall seen at a grazing
        # angle is broken into pieces shorter than a support in the section, no wall
        # island beside its responds (draw 37: eleven responds of 0.39 x 0.3 m)
        if params.engaged:
            thick_xy = p[thick_idx, :2]
            for sh in line_responds(thick_xy, thick_xy.mean(axis=0), params, sc):
                if clear_of(sh, shapes):
                    pier = sh["class"] == "pier"  # or an engaged column's arc front
                    frac = params.pier_buffer_fraction if pier else params.buffer_fraction
                    sh["buffer"] = max(params.buffer_min_m, frac * float(np.max(sh["half"])))
                    shapes.append(sh)
        # 2d. short tight arcs of small rings that the same circle continues above and
        # below (draw 36: twin columns of 0.14 m seen over 40-80 degrees at every height)
        for sh in arc_columns(p, order, z_sorted, h_sec, thick_idx, thick_isl, params):
            if clear_of(sh, shapes) and free_of_walls(sh):
                shapes.append(sh)
        # 2e. the thick slab about the low section: broken columns far from every
        # station (draw 24: 3-11 points in the thin slab, 24-160 in the thick one)
        # columns only (a thick slab low down holds the boards and posts of clutter), of
        # the building's columns' size: a broken column is one of them (draw 28: a
        # ring of 0.7 m in a wall beside columns of 0.23 m)
        radii = [float(sh["radius"]) for sh in shapes if sh["class"] == "column"]
        r_max = LOW_RADIUS_SHARE * max(radii, default=0.0)
        low_islands = thick_lows.result() if thick_lows is not None else []
        for (h_low, low_xy), low_isl in zip(lows, low_islands, strict=True):
            low_added = [
                sh
                for sh in thick_at(h_low, low_xy, low_isl)[0]
                if sh["class"] == "column" and float(sh["radius"]) <= r_max
            ]
            for sh in low_added:
                sh["h_sec"] = h_low
            shapes += low_added
    # 2f. piers seen face-on: straight lines of the section, free at both ends, whose
    # face rises from the floor (their section is a line like a wall's)
    if params.section_height_m is None:
        shapes += face_on_shapes(
            p, sec_idx, islands, shapes, order, z_sorted, h_sec, (z0, z1), params, sc
        )
    if params.engaged:
        engage_on_wall_faces(p, order, z_sorted, shapes, h_sec, sc, rng, params.seed)
        # rows of columns whose rings stop on one line: a wall never scanned beside them
        # (a ruin's walls end below the section; draw 24)
        n_rows = engage_rows(p, order, z_sorted, shapes, h_sec, sc, z_sup)
        if n_rows:
            notes.append(
                f"{n_rows} column{'s' if n_rows > 1 else ''} in rows whose rings stop on one "
                "line, no floor seen behind it (a wall not scanned beside them): engaged"
            )
        # no pier of an engaged column's arc and its wall's face (the column found in
        # another section: draw 38)
        main = [
            {**sh, "class": "low_pier"} if sh["class"] == "pier" and "h_sec" in sh else sh
            for sh in shapes
        ]  # the piers of the main section only: its points are tested
        arc_piers = arc_wall_piers(p[sec_idx, :2], main, sc.tol)
        if arc_piers:
            notes.append(
                f"{len(arc_piers)} pier candidate{'s are' if len(arc_piers) > 1 else ' is'} an "
                "engaged column's arc with its wall's face: not supports"
            )
            shapes = [sh for k, sh in enumerate(shapes) if k not in arc_piers]
    # 2g. no pier inside a wall's opening: the reveals of doors and windows in thick walls
    reveals = opening_piers(p, order, z_sorted, shapes, h_sec, sc)
    if reveals:
        notes.append(
            f"{len(reveals)} pier candidate{'s stand' if len(reveals) > 1 else ' stands'} "
            "between the two faces of a wall running on beyond both of its ends (the "
            "reveals and jambs of openings in thick walls): not supports"
        )
        shapes = [sh for k, sh in enumerate(shapes) if k not in reveals]
    # no persistent island at any height of the search: said where nothing is found
    unseen = unseen_notes(scores, (lo - z0, hi - z0), h_sec - z0, lows, z0, params)
    if not shapes:
        notes += unseen
        notes.append(
            f"no support found in the section {at} "
            f"({sum(i.kind == 'wall' for i in islands)} wall islands, "
            f"{sum(i.kind == 'noise' for i in islands)} noise islands)"
        )
        return SupportResult(
            empty.instance, empty.objects, h_sec, spacing, islands, tuple(notes), scores
        )
    # 3. cookie-cutter: the points around each shape, overlaps to the nearest shape
    cut = cookies(p, shapes, params)
    # 4. per support: floor and ceiling off, clutter off, final clustering, primitive

    def band(z_lo: float, z_hi: float) -> NDArray[np.intp]:  # points between two heights
        a, b = np.searchsorted(z_sorted, [z_lo, z_hi])
        return order[a:b]

    instance = np.zeros(n, dtype=np.int32)
    rows = []
    rejected: list[str] = []
    # per row: its points, whether it carries, the underside of what it carries (inf:
    # nothing) and the share of sectors covered just above its top
    members: list[tuple[NDArray[np.intp], bool, float, float]] = []
    # the shapes near each one: their surfaces are not the wall an engaged column stands in
    centres = np.array([np.asarray(sh["centre"], dtype=np.float64) for sh in shapes])
    reaches = np.array([shape_reach(sh) for sh in shapes])
    for k, sh in enumerate(shapes):
        if sh["class"] == "engaged_column":
            sh["neighbours"] = neighbour_discs(centres, reaches, k, FACE_REACH_M)
    rounded = thin_piers = antae = followed = 0
    # the points and primitive of each support (on two processes: measure_supports)
    measured = measure_supports(p, shapes, cut, params, sc, h_sec, (z0, z1), band)
    for sh, m in zip(shapes, measured, strict=True):  # loop over supports
        if m.points is None or m.row is None:
            continue
        rounded += m.rounded  # a pier round over its shaft, taken again as a column
        antae += m.anta  # a pier ending a wall, the wall's stub cut off it
        (cidx, crho), row = m.points, m.row
        cpts = np.take(p, cidx, axis=0)
        off = row.pop("off_shaft", None)  # a bench or a chair touching a column
        if off is not None and off.any():
            cidx, crho, cpts = cidx[~off], crho[~off], cpts[~off]
        if sh["class"] != "pier" and not (
            abs(row.get("cylinder_radius_m", row["radius_m"]) - sh["radius"])
            <= max(0.05, 0.3 * sh["radius"])
            and row.get("cylinder_radius_m", row["radius_m"]) >= RING_RADIUS_M[0]
        ):  # the 3D cylinder disagrees with the section circle (or failed, or is a pole
            # or a scaffold tube thinner than any column): not a column
            notes.append(
                f"a round candidate of radius {sh['radius']:.2f} m ({len(cidx)} points) "
                "was rejected: its cylinder fit disagrees with its section"
            )
            continue
        if (
            sh["class"] == "pier"
            and not sh.get("respond", False)  # a respond's bump may stand out little
            and thin_pier(cpts, params.min_support_size_m)
        ):
            thin_piers += 1  # a scaffold's standard: no pier
            continue
        why = implausible(row, cpts, sc)
        if why:  # a primitive must lie within its points: they go back to the body
            rejected.append(f"{sh['class']} of {len(cidx)} points: {why}")
            continue
        rows.append(row)
        followed += sh.get("followed", 0) > 0
        members.append(
            (
                cidx,
                bool(sh.get("carries", True)),
                float(sh.get("carried_z", np.inf)),
                float(sh.get("overhead", 0.0)),
                bool(sh.get("reaches", sh.get("carries", True))),
                bool(sh.get("sparse", False)),
            )
        )
    if thin_piers:
        notes.append(
            f"{thin_piers} pier candidate{'s' if thin_piers > 1 else ''} reaching less than "
            f"the smallest support across in {'their' if thin_piers > 1 else 'its'} layers "
            "(the standards of scaffolds): not supports"
        )
    if antae:
        notes.append(
            f"{antae} pier{'s' if antae > 1 else ''} ending a wall (anta): cut off "
            "the wall at the step of their faces"
        )
    if followed:
        notes.append(
            f"{followed} support{'s' if followed > 1 else ''} followed beyond the dense band "
            "of the scans through sparse stretches of the shaft, at their own spacing"
        )
    if rounded:
        notes.append(
            f"{rounded} pier candidate{'s are' if rounded > 1 else ' is'} round over "
            "the bands of its shaft (a sparse or cluttered section): column"
        )
    arcs = join_arcs_to_columns(p, rows, members, sc.tol)
    if arcs:
        notes.append(
            f"{arcs} pier candidate{'s' if arcs > 1 else ''} on the surface of a column "
            "found beside (an arc of its ring): joined to it"
        )
    thin = thin_free_columns(rows, [m[1] for m in members])
    if thin:
        notes.append(
            f"{len(thin)} round candidate{'s' if len(thin) > 1 else ''} carrying nothing and "
            f"thinner than {THIN_FREE_SHARE:g} x the radius of the columns that carry "
            "(posts, the stems of pulpits and stands, not broken columns): not supports"
        )
        rows = [r for k, r in enumerate(rows) if k not in thin]
        members = [m for k, m in enumerate(members) if k not in thin]
    carries, tops, covers, reach, sparse = ([m[j] for m in members] for j in (1, 2, 3, 4, 5))
    short = ends_short(p, rows, members, band, sc.tol)
    low = low_carriers(rows, carries, tops, sparse, short)
    short_low = low - low_carriers(rows, carries, tops, sparse)
    if short_low:
        notes.append(
            f"{len(short_low)} candidate{'s' if len(short_low) > 1 else ''} ending under the "
            "surface found above, the plan of the top empty up to it (the posts of pulpits, "
            "the bars of fences): judged by the own top"
        )
    low |= covered_free_columns(rows, reach, covers)
    if low:
        notes.append(
            f"{len(low)} candidate{'s' if len(low) > 1 else ''} ending lower than "
            f"{LOW_CARRY_SHARE:g} x the way up to where the other supports carry, or "
            "under something they do not carry in a ruin (the stems of pulpits under "
            "their tubs, posts under boards): not supports"
        )
        rows = [r for k, r in enumerate(rows) if k not in low]
        members = [m for k, m in enumerate(members) if k not in low]
    for k, (cidx, *_) in enumerate(members):
        instance[cidx] = k + 1
    if rejected:
        notes.append(
            f"{len(rejected)} support candidate{'s' if len(rejected) > 1 else ''} rejected, "
            f"the fitted primitive not within the points (they stay in the body): "
            + "; ".join(rejected[:5])
            + (f"; ... {len(rejected) - 5} more" if len(rejected) > 5 else "")
        )
    edges = sum(1 for sh in shapes if sh.get("wall_edge"))
    if edges:
        notes.append(
            f"{edges} pier candidate{'s are wall edges' if edges > 1 else ' is a wall edge'} "
            "(joined to a wall in most of the height: jambs, reveals): not supports"
        )
    rows = [{k: v for k, v in r.items() if k != "cylinder_radius_m"} for r in rows]
    objects = pd.DataFrame(rows) if rows else empty_table()
    if len(objects):
        objects.insert(0, "instance", np.arange(1, len(objects) + 1, dtype=np.int32))
    if not rows:
        notes += unseen
        notes.append("support candidates were found in the section but none spans the body height")
    return SupportResult(instance, objects, h_sec, spacing, islands, tuple(notes), scores)


def join_arcs_to_columns(p: Array, rows: list[dict], members: list[tuple], tol: float) -> int:
    """Join the pier candidates whose points lie on a column's surface to that column,
    in place (``rows``, ``members``: the supports' table rows and (points, ...) tuples);
    returns how many were joined.

    A large ring breaks into arcs in a thin section, and a flat arc is a pier island
    there; the column itself may be found in another section from another arc (supports
    draw 18: an arc of a 0.67 m column over 30 degrees was a pier in the main section,
    the column came from the low one; one column found twice)."""
    cols = [k for k, r in enumerate(rows) if r["class"] in ("column", "engaged_column")]
    piers = [k for k, r in enumerate(rows) if r["class"] == "pier"]
    if not cols or not piers:
        return 0
    columns = [(rows[k], p[members[k][0]]) for k in cols]
    gone = []
    for k in piers:
        j = arc_owner(p[members[k][0]], columns, tol)
        if j is None:
            continue
        c = cols[j]
        joined = np.union1d(members[c][0], members[k][0])
        members[c] = (joined, *members[c][1:])
        rows[c]["n_points"] = len(joined)
        gone.append(k)
    for k in sorted(gone, reverse=True):
        del rows[k], members[k]
    return len(gone)


def face_on_shapes(
    p: Array,
    sec_idx: NDArray[np.intp],
    islands: list[Island],
    shapes: list[dict],
    order: NDArray[np.intp],
    z_sorted: Array,
    h_sec: float,
    z_range: tuple[float, float],
    params: SupportParams,
    sc: Scales,
) -> list[dict]:
    """Shapes of the piers seen face-on in the section (:func:`face_on_piers`) that are
    no pieces of walls (:func:`wall_pieces`) and clear of every shape found, marked
    ``sparse`` (judged by the level the building's supports carry,
    :func:`low_carriers`).  The faces of one box are joined first
    (:func:`~pyheracles.supports.face_boxes.join_face_parts`): with each other, with a
    wall island (then judged with it) or with a pier shape found, which grows to the
    box (``shapes`` is updated)."""

    def band(z_lo: float, z_hi: float) -> NDArray[np.intp]:  # points between two heights
        a, b = np.searchsorted(z_sorted, [z_lo, z_hi])
        return order[a:b]

    xy = p[sec_idx, :2]
    faces = face_on_piers(xy, islands, band, p, z_range, h_sec, params, sc)
    if not faces:
        return []
    # the faces of one pier, and a face of a found pier or of a piece of a wall, are
    # joined into one box first (draws 11, 12, 19, 28)
    parts = section_parts(xy, islands, shapes, sc.tol)
    faces, grown = join_face_parts(xy, faces, parts, params.max_support_size_m, sc.tol)
    for k, (centre, angle, size) in grown.items():
        shapes[k].update(centre=centre, angle=angle, half=size / 2)
    known = [i for i in islands if i.kind != "noise"]
    pieces = wall_pieces(xy, known + faces, sc, set(range(len(known))))
    out = []
    for k, isl in enumerate(faces):
        if len(known) + k in pieces:
            continue
        sh = {
            "class": "pier", "centre": isl.center, "radius": isl.radius, "half": isl.size / 2,
            "angle": isl.angle, "circularity": isl.circularity, "sparse": True,
        }  # fmt: skip
        sh["buffer"] = max(
            params.buffer_min_m, params.pier_buffer_fraction * float(np.max(sh["half"]))
        )
        if clear_of(sh, shapes + out):
            out.append(sh)
    return out


def clear_of(sh: dict, shapes: list[dict]) -> bool:
    """Whether a shape's footprint overlaps no other's: the circle of its half size, or
    of a column's radius when larger (a column seen over a short arc of its ring reaches
    beyond the arc's extent: a ring of 0.28 m on a wall beside an engaged column, its
    arc 0.34 m long, was clear of the column by its half size; draw 0)."""

    def reach(k: dict) -> float:
        half = float(np.max(k["half"]))
        return max(half, float(k["radius"])) if k["class"] == "column" else half

    r = reach(sh)
    return all(np.hypot(*(sh["centre"] - k["centre"])) > r + reach(k) for k in shapes)


def wall_pieces(
    xy: Array, islands: list[Island], sc: Scales, keep: set[int] | None = None
) -> set[int]:
    """Indices of the pier islands that are pieces of walls (none of ``keep``: the
    responds, :func:`respond_islands`).

    A piece is in line with the wall beside it (:func:`wall_fragment`), lies on the
    line of a wall face (:func:`in_wall_line`) or has a wall face running alongside it
    (:func:`wall_alongside`); a piece found so joins the wall, so a
    run of pieces between openings is found from the wall at its end.
    """
    piers = [k for k, i in enumerate(islands) if i.kind == "pier" and k not in (keep or set())]
    if not piers:
        return set()
    tree = cKDTree(xy)
    pieces = {k for k in piers if wall_fragment(xy, islands[k], tree, sc.distance)}
    bin_m = max(0.05, 3.0 * sc.spacing)
    while True:  # a few rounds: each adds the pieces next to the wall found so far
        wall = [xy[i.index] for k, i in enumerate(islands) if i.kind == "wall" or k in pieces]
        if not wall:
            return pieces
        wall_xy = np.vstack(wall)
        new = {
            k
            for k in piers
            if k not in pieces
            and (
                in_wall_line(islands[k], wall_xy, sc.tol, bin_m)
                or wall_alongside(islands[k], wall_xy, bin_m)
            )
        }
        if not new:
            return pieces
        pieces |= new


def respond_islands(xy: Array, islands: list[Island], sc: Scales) -> dict[int, dict]:
    """The section shapes of the pier islands that are responds, by island index
    (:func:`~pyheracles.supports.responds.respond_island`: a bump out of the face of
    the wall that goes on beyond its ends, which otherwise makes it a piece of that
    wall)."""
    piers = [k for k, i in enumerate(islands) if i.kind == "pier"]
    if not piers:
        return {}
    tree = cKDTree(xy)
    bin_m = max(0.05, 3.0 * sc.spacing)
    out = {}
    for k in piers:
        isl = islands[k]
        near = tree.query_ball_point(isl.center, float(np.hypot(*isl.size)) + WALL_LINE_GAP_M)
        others = np.setdiff1d(np.asarray(near, dtype=np.intp), isl.index)
        sh = respond_island(
            xy[isl.index], isl.center, isl.angle, isl.size, xy[others], sc.tol, sc.distance,
            bin_m,
        )  # fmt: skip
        if sh is not None:
            out[k] = sh
    return out


def support_shapes(
    xy: Array,
    islands: list[Island],
    params: SupportParams,
    sc: Scales,
    rng: np.random.Generator,
    *,
    responds: bool = True,
    wall_tree: cKDTree | None = None,
) -> tuple[list[dict], int]:
    """Section shapes of the supports: column / pier islands, half-columns on walls and,
    with ``responds``, piers against walls (:func:`respond_islands`,
    :func:`~pyheracles.supports.responds.responds_on_wall`; in the main section only:
    the low and the thick ones hold more of the clutter and of the walls' openings).

    Also returns the number of pier islands left out as pieces of walls
    (:func:`wall_pieces`).  ``wall_tree``: the tree of the wall islands' points when the
    caller has built it already (built here otherwise).
    """
    shapes: list[dict] = []
    if not params.engaged:
        wall_tree = None
    elif wall_tree is None:
        wall_xy = [xy[i.index] for i in islands if i.kind == "wall"]
        wall_tree = cKDTree(np.vstack(wall_xy)) if wall_xy else None
    # the pieces of one pier outline broken at its corners are joined first: with their
    # rectangles along their faces, one piece beside the other looked like a wall
    # going on (draw 27); then the pieces of walls
    islands, _ = regroup_pier_pieces(xy, islands, set(), params, sc.distance)
    bumps = respond_islands(xy, islands, sc) if responds else {}
    # a pier ending a set-in wall (an anta) has the wall's stub in line beyond it (in the
    # main section only, as the responds: the low and thick ones hold more of the
    # clutter and of the walls' openings)
    bin_m = max(0.05, 3.0 * sc.spacing)
    antae = anta_islands(xy, islands, sc.tol, sc.distance, bin_m) if responds else set()
    pieces = wall_pieces(xy, islands, sc, set(bumps) | antae)
    fragments = len(pieces)
    on_wall: list[dict] = []  # responds on wall islands, after every other shape
    for k, isl in enumerate(islands):
        if k in pieces:
            continue
        if isl.kind == "column" and wall_tree is not None:
            eng = detached_half_column(xy[isl.index], isl, wall_tree, sc.distance)
            if eng is not None:
                shapes.append(eng)
                continue
        if k in bumps:
            shapes.append(bumps[k])
        elif isl.kind in ("column", "pier"):
            shapes.append(
                {
                    "class": isl.kind,
                    "centre": isl.center,
                    "radius": isl.radius,
                    # a column's shape is its circle: an arc seen from one side spans
                    # less than its diameter (supports draw 22: 1.52 of 2.12 m)
                    "half": np.array([isl.radius, isl.radius])
                    if isl.kind == "column"
                    else isl.size / 2,
                    "angle": isl.angle,
                    "circularity": isl.circularity,
                }
            )
        elif isl.kind == "wall" and params.engaged:
            faces = wall_face_lines(xy[isl.index], sc.tol, sc.distance, rng)
            if responds:  # after the half-columns: an arc is no rectangle
                on_wall += responds_on_wall(
                    xy[isl.index], faces, params, sc.tol, sc.distance, bin_m, xy
                )
            for c, r, nrm, d, face_rms in engaged_on_wall(
                xy[isl.index], params, sc.tol, sc.distance, rng, faces
            ):
                shapes.append(
                    {
                        "class": "engaged_column",
                        "centre": c,
                        "radius": r,
                        "half": np.array([r, r]),
                        "angle": 0.0,
                        "normal": nrm,
                        "d": d,
                        "face_gap": max(0.01, 3 * face_rms),
                        "circularity": float("nan"),
                    }
                )
    shapes = dedupe(shapes + on_wall)
    for sh in shapes:
        frac = params.pier_buffer_fraction if sh["class"] == "pier" else params.buffer_fraction
        sh["buffer"] = max(params.buffer_min_m, frac * float(np.max(sh["half"])))
    return shapes, fragments
