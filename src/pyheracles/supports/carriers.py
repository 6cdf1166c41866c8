"""Which supports carry the building: the checks that drop a candidate by what it
carries, once every candidate of a building has been extracted.

A column carrying nothing much thinner than those that carry (a post, a pulpit's
stem), one that carries something far below where the building's supports carry (a
pulpit's tub, a sign board), and one carrying nothing under something resting over
it are no supports (issue 12, mode 8: clutter is no support).  Moved out of
:mod:`pyheracles.supports.detect` as it grew past 800 lines.
"""

from __future__ import annotations

import numpy as np

#: A column that carries nothing (a broken column, one under the open sky) is one of the
#: building's columns: at least this share of the radius of the thickest column that
#: carries something (the groups of a building differ by 0.45-0.85 in radius; a post,
#: the stem of a pulpit or a lamp stand beside 1 m columns is a tenth of theirs).
THIN_FREE_SHARE = 0.3


def thin_free_columns(rows: list[dict], carries: list[bool]) -> set[int]:
    """Indices of the columns carrying nothing thinner than ``THIN_FREE_SHARE`` x the
    radius of the thickest column that carries, or, when fewer than
    :data:`MIN_CARRYING` carry (a roofless ruin), of the thickest column (draw 17: the
    stems of pulpits, 0.12 m, among broken columns of 1.2 m; draw 19: a pulpit's post
    carrying its tub was the only column carrying something).  Radii of the cylinders
    of the section's shaft points (``cylinder_radius_m``) where the rows have them: the
    rule was set on those."""
    radius = [r.get("cylinder_radius_m", r["radius_m"]) for r in rows]
    carried = [x for r, x, c in zip(rows, radius, carries, strict=True)
               if c and r["class"] == "column" and np.isfinite(x)]  # fmt: skip
    if len(carried) < MIN_CARRYING:  # a roofless ruin: the thickest column standing
        # (draw 19: the one column carrying something was a pulpit's post under its tub)
        carried = [x for r, x in zip(rows, radius, strict=True)
                   if r["class"] == "column" and np.isfinite(x)]  # fmt: skip
    if not carried:
        return set()
    limit = THIN_FREE_SHARE * max(carried)
    return {
        k
        for k, (r, x, c) in enumerate(zip(rows, radius, carries, strict=True))
        if not c and r["class"] == "column" and x < limit
    }


#: A column that carries something carries the building where its supports carry it:
#: its top (the underside of what it carries) lies at least this share of the way from
#: its own floor up to the level the supports carry over it (the median top of those
#: that carry something, or what its nearest ones carry where lower:
#: :func:`neighbour_levels`).  Supports on a dais or a step reach the same level from a
#: higher floor; the post of a pulpit carries its tub at 0.25-0.75 of the way (supports
#: family: posts 1.2-2.6 m under supports 2.5-15 m tall), a sign post its board.
LOW_CARRY_SHARE = 0.8
#: The carried level is a median of at least this many supports that carry.
MIN_CARRYING = 3
#: A candidate ending under what it "carries", the plan of its top empty up to it
#: (:func:`~pyheracles.supports.shaft_above.ends_short`), is judged by its own top with
#: a margin: its top must lie at least this share of the way up to the carried level.
#: The top of a column may be unseen, not absent (draw 36: a column seen from 1.34 to
#: 2.76 m under a ceiling at 3.15 m, its capital unseen, 0.77 of the way); the posts of
#: pulpits and the bars of fences end 0.50-0.59 of the way (draws 7, 8, 12, 16, 25).
SHORT_TOP_SHARE = 0.7


def neighbour_levels(xy: np.ndarray, levels: np.ndarray, carrying: np.ndarray) -> np.ndarray:
    """The level of the surface carried over each support: the median of what its
    :data:`MIN_CARRYING` nearest other supports that carry carry (metres).

    Parameters
    ----------
    xy : ndarray
        ``(N, 2)`` plan positions of the supports (metres).
    levels : ndarray
        ``(N,)`` the underside of what each carries (``carried_z``, metres).
    carrying : ndarray
        ``(N,)`` whether each carries the building at a finite level (not a pulpit's
        tub: ``LOW_CARRY_SHARE`` of the way up to the median level); at least
        :data:`MIN_CARRYING` + 1 do.

    Returns
    -------
    ndarray
        ``(N,)`` per support the median level carried by its plan neighbours.

    Notes
    -----
    A flat ceiling or an attic is carried at one level; a vault or a ceiling over
    aisles and nave at several: each support carries it where it springs over its
    top, and the surface found over a support's cookie lies up the vault's rise the
    farther the cookie reaches in under it.  Draw 32 of the supports family (a nave
    under a vault springing at 2.68 m and rising 1.8 m): its supports carried it at
    2.68-4.03 m, their median 3.32 m; the engaged column carrying the springing at
    2.68 m reached 0.799 of the way up to the median, 0.93 of the way up to what its
    three nearest supports carry (2.88 m).  A pulpit's post stands beside columns
    carrying the ceiling: its neighbours carry the building's level, not the tubs of
    other pulpits, which are no neighbours.
    """
    cand = np.flatnonzero(carrying)
    d = np.hypot(xy[:, None, 0] - xy[None, cand, 0], xy[:, None, 1] - xy[None, cand, 1])
    d[cand, np.arange(len(cand))] = np.inf  # not itself
    near = np.argsort(d, axis=1, kind="stable")[:, :MIN_CARRYING]
    return np.median(levels[cand][near], axis=1)


def low_carriers(
    rows: list[dict],
    carries: list[bool],
    carried_z: list[float],
    sparse: list[bool] | None = None,
    short: list[bool] | None = None,
) -> set[int]:
    """Indices of the columns, of the piers found in the thick section only
    (``sparse``) and, in a ruin, of the piers that carry something, that end below the
    building's carried level (in a ruin where fewer than :data:`MIN_CARRYING` supports
    carry, the median top of those carrying nothing, and only those that carry are
    judged: a post carrying its rail among broken columns).

    ``rows``: objects-table rows (``class``, ``z_min``, ``z_max``; ``x``, ``y`` for the
    levels of the neighbours, else the median alone); ``carries``: whether each carries
    something; ``carried_z``: the underside of what it carries (metres).  The carried
    level is the median ``carried_z`` of the supports that carry (at least
    :data:`MIN_CARRYING` of them), or for each candidate what its :data:`MIN_CARRYING`
    nearest supports that carry carry where that is lower (:func:`neighbour_levels`: a
    vault is carried low at its springing, high up its rise; draw 32); a column whose
    top (``carried_z`` if it carries, else its highest point ``z_max``) is lower than
    ``LOW_CARRY_SHARE`` of the way from its lowest point ``z_min`` up to that level is
    an object standing in the room (draws 8 and 25 of the supports family: pulpit posts
    1.2-1.8 m tall "carrying" their tubs beside supports carrying the ceiling at 2.6 m).
    Where most supports carry (the building stands), a column so low carrying nothing is
    one too (a post whose tub's underside, level with the scanner, went unseen); in a
    ruin, where most carry nothing, it is a broken column and stays.  A column whose foot
    or top the scan missed is judged by what it carries, not by its points (draw 36: a
    column seen from 1.35 to 2.58 m under a ceiling at 2.8 m).  A pier found in the thick
    section only is judged alike (draw 1: a scaffold's standard 8 m tall beside a
    column, under a roof carried at 14.7 m); one the thin section found only in a ruin,
    by what it carries (draw 3: a fence post 1.6 m tall carried its rail among broken
    columns 3.9 m tall), not by its points when it carries nothing: its top may be
    shadowed (draw 8: two piers seen up to 1.6 m under a ceiling at 2.56 m); in a
    standing building a gallery or a deck against it may cut it low (held-out draw 44: a
    pier 15 m tall cut at 4.1 m).

    ``short``: whether each ends short of what it carries, the plan of its top empty
    from there up to it (:func:`~pyheracles.supports.shaft_above.ends_short`).  In a
    standing building such a column (or sparse pier) is judged by its own top against
    :data:`SHORT_TOP_SHARE` of the way, not by what it "carries": the post of a
    pulpit, its tub's underside unseen, "carries" the ceiling 1-3 m above (supports
    draws 12 and 16: posts 1.9-2.4 m tall, 0.51-0.56 of the way up to the attic or the
    ceiling), a fence's bars the attic over its top rail (draw 25: 0.50 of the way).
    A column cut short by its cookie (a scaffold's deck round it: held-out draw 46)
    shows its shaft above its points and is judged by what it carries."""
    levels = [t for t, c in zip(carried_z, carries, strict=True) if c and np.isfinite(t)]
    if len(levels) >= MIN_CARRYING:
        level = float(np.median(levels))
        standing = 2 * len(levels) >= len(rows)
    else:  # a ruin: its supports stand to the median top of those carrying nothing
        free_tops = [float(r["z_max"]) for r, c in zip(rows, carries, strict=True) if not c]
        if len(free_tops) < MIN_CARRYING or 2 * len(levels) >= len(rows):
            return set()
        level, standing = float(np.median(free_tops)), False
    local = np.full(len(rows), np.inf)
    tz = np.asarray(carried_z, dtype=np.float64)
    floor = np.array([float(r["z_min"]) for r in rows], dtype=np.float64)
    carrying = np.asarray(carries, dtype=bool) & np.isfinite(tz)
    carrying &= tz - floor >= LOW_CARRY_SHARE * (level - floor)  # not a pulpit's tub
    xy = np.array([[r.get("x", np.nan), r.get("y", np.nan)] for r in rows], dtype=np.float64)
    if carrying.sum() > MIN_CARRYING and np.isfinite(xy).all():  # in plan: the surface
        local = neighbour_levels(xy, tz, carrying)  # over each, what its neighbours carry
    out = set()
    for k, (r, c, t) in enumerate(zip(rows, carries, carried_z, strict=True)):
        judged = (
            r["class"] == "column"
            or (sparse is not None and sparse[k])
            or (r["class"] == "pier" and c and not standing)  # a post under its rail
        )
        if not judged or not (c or standing):
            continue
        ends = standing and short is not None and short[k]  # under what it "carries"
        top = t if c and np.isfinite(t) and not ends else float(r["z_max"])
        need = SHORT_TOP_SHARE if ends else LOW_CARRY_SHARE
        here = min(level, float(local[k]))  # never above the building's median
        if top - float(r["z_min"]) < need * (here - float(r["z_min"])):
            out.add(k)
    return out


#: Something rests over a column carrying nothing when it covers at least this share
#: of the sectors round it just above its top.
OVERHEAD_SHARE = 0.5


def covered_free_columns(rows: list[dict], carries: list[bool], overhead: list[float]) -> set[int]:
    """Indices of the columns that carry nothing with something resting over them, in a
    ruin (where fewer than half the supports carry; in a standing building
    :func:`low_carriers` judges them by their height).  ``carries``: whether each
    carries what it reaches (:func:`~pyheracles.supports.cookies.reaches_carried`): a
    post ending 1 m under its pulpit's tub, whose rim was found over it, carries
    nothing (draw 26).

    A broken column's top is open to the sky; a column carrying nothing whose top has
    something round it in ``OVERHEAD_SHARE`` of the sectors just above
    (``overhead``, :func:`~pyheracles.supports.profile.overhead_cover`) stands under
    what it does not carry: the post of a pulpit under its tub (draws 10, 24 and 26 of
    the supports family: roofless ruins whose pulpit posts, 0.12 m in radius beside
    columns of 0.17-0.23 m, were broken columns)."""
    if 2 * sum(carries) >= len(rows):
        return set()
    return {
        k
        for k, (r, c, o) in enumerate(zip(rows, carries, overhead, strict=True))
        if r["class"] == "column" and not c and o >= OVERHEAD_SHARE
    }
