"""The timber frame as a structure: joints, graph, roles, deflection and twist.

:func:`analyse_frame` reads top-down from a :class:`~pyheracles.beams.model.BeamResult`:

1. joints between the fitted cuboids (:func:`~pyheracles.beams.joints.find_joints`);
2. the graph's connected components: a component of at least
   ``min_frame_members`` beams (or the largest one) is the frame, and so is a
   smaller one that rises above the frame's bottom (a couple of rafters), or a
   horizontal beam joined to nothing that spans the frame (a tie beam whose
   joints are hidden in the walls, ``span_share``; not a chimney) or lies
   across the plane of a couple of rafters between their feet, off the floor
   (a tie found in a piece, :func:`~pyheracles.beams.couples.ties_couple`);
   timber lying below the frame's
   bottom and joined to none of it (loose timber on the floor) is flagged as
   not a member of the frame, and so is an inclined beam of a small group
   apart from the frame whose foot stands below the frame's bottom
   (:func:`leaning_apart`: a ladder joined to nothing), and so is a beam
   that only leans on it (one joint, at its upper half, its foot below the
   frame's bottom: a ladder against a post) or lies under it touching it (one
   joint, wholly below the frame's bottom: timber on the floor), and so is a
   horizontal timber at the frame's bottom joined to no inclined or vertical
   beam and shorter than most of the frame along it (:func:`loose`: timber
   stored on the floor next to a tie beam), and so is a plumb beam standing
   on the floor apart from the main frame and joined at its lower half only
   (:func:`idle_standing`: a chimney; what only it held is judged without
   it), and so is the strip of a wall
   head a plate rests on (:func:`bearing`: its top level with the underside
   of a parallel beam laid along it);
3. a role per beam from orientation, height, place and joints
   (:func:`~pyheracles.beams.roles.guess_roles`);
4. per beam its deflection and twist from its own points
   (:func:`~pyheracles.beams.deflection.member_shapes`).

:meth:`FrameResult.to_json` is what ``heracles beams`` writes as ``frame.json``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pyheracles.beams.couples import ties_couple
from pyheracles.beams.deflection import MemberShape, ShapeParams, member_shapes
from pyheracles.beams.joints import Joint, JointParams, components, find_joints
from pyheracles.beams.model import BeamCuboid, BeamResult
from pyheracles.beams.roles import RoleParams, frame_levels, guess_roles
from pyheracles.errors import InputError

__all__ = [
    "FrameParams",
    "FrameResult",
    "analyse_frame",
    "bearing",
    "frame_members",
    "idle_standing",
    "leaning",
    "leaning_apart",
    "loose",
    "section_half_height",
]


@dataclass(frozen=True)
class FrameParams:
    """Parameters of the frame analysis.

    Attributes
    ----------
    joints, roles, shape
        :class:`JointParams`, :class:`RoleParams`, :class:`ShapeParams`.
    min_frame_members
        A connected component of at least this many beams is (part of) the
        frame; the largest component always is; smaller ones are when they
        rise above its bottom.
    leaning_below_m
        An inclined beam of the frame with one joint only, at its upper half,
        whose lower end reaches this far below the frame's bottom (metres)
        leans on the frame (a ladder, a prop stored against a post): not a
        member.
    plumb_deg
        A beam at least this steep stands (a post on the floor), it does not
        lean, degrees (ladders lean at 65-80 degrees).
    span_share
        A horizontal beam lying at the frame's bottom (its underside within
        one of its sections of it) that is joined to no inclined or vertical
        beam and is shorter than this share of the frame's extent along it is
        loose timber on the floor, not a member: the tie beams and plates of
        the bottom carry the rafters and posts, or span the frame from wall
        to wall (their joints hidden in the masonry).
    bearing_reach_m
        How far beside a horizontal beam the bearing it rests on may reach,
        metres (:func:`bearing`): the strip of a wall head runs from the
        room's face of the wall to the plate, up to a wall's thickness, and
        the boxes of a strip seen at a grazing angle and of a plate seen on
        one face are narrower than they are, so they need not touch.
    bearing_skew_deg
        Largest angle in plan between a bearing and the beam lying on it,
        degrees (:func:`bearing`): the strip of a wall head is seen at a
        grazing angle over a part of its width that shifts along it, so its
        band's direction can be several degrees off the plate's (roof seed 11:
        6.4 degrees); horizontal members laid along one another are parallel,
        crossing ones are square.
    couple_skew_deg
        Largest angle in plan between a horizontal beam and each inclined beam
        of a couple it ties, degrees
        (:func:`~pyheracles.beams.couples.ties_couple`): a horizontal beam
        joined to nothing is a member when it lies across the plane of a
        couple of rafters, between their feet, off the floor (a tie whose ends
        are hidden in the wall heads or shadowed may be found shorter than
        ``span_share`` of the frame; a strip of the floor beside a tie sunk in
        it lies in the couple's plane too).
    """

    joints: JointParams = field(default_factory=JointParams)
    roles: RoleParams = field(default_factory=RoleParams)
    shape: ShapeParams = field(default_factory=ShapeParams)
    min_frame_members: int = 3
    leaning_below_m: float = 0.3
    plumb_deg: float = 85.0
    span_share: float = 0.8
    bearing_reach_m: float = 1.0
    bearing_skew_deg: float = 10.0
    couple_skew_deg: float = 10.0

    def validate(self) -> FrameParams:
        self.joints.validate()
        self.roles.validate()
        self.shape.validate()
        if not 45 < self.plumb_deg <= 90:
            raise InputError(f"plumb_deg must be in (45, 90], got {self.plumb_deg}")
        if not 0 <= self.leaning_below_m <= 10:
            raise InputError(
                f"leaning_below_m must be in [0, 10] metres, got {self.leaning_below_m}"
            )
        if not 0 < self.span_share <= 1:
            raise InputError(f"span_share must be in (0, 1], got {self.span_share}")
        if not 0 <= self.bearing_reach_m <= 5:
            raise InputError(
                f"bearing_reach_m must be in [0, 5] metres, got {self.bearing_reach_m}"
            )
        if not 0 <= self.bearing_skew_deg < 45:
            raise InputError(
                f"bearing_skew_deg must be in [0, 45) degrees, got {self.bearing_skew_deg}"
            )
        if not 0 <= self.couple_skew_deg < 45:
            raise InputError(
                f"couple_skew_deg must be in [0, 45) degrees, got {self.couple_skew_deg}"
            )
        if self.min_frame_members < 2:
            raise InputError(f"min_frame_members must be >= 2, got {self.min_frame_members}")
        return self


@dataclass(frozen=True)
class FrameResult:
    """The frame's graph and its members' condition.

    Attributes
    ----------
    joints
        Every joint (:class:`~pyheracles.beams.joints.Joint`).
    component
        ``(B,)`` connected component per beam (1 = largest).
    in_frame
        ``(B,)`` whether each beam is a member of the frame.
    roles
        Role per beam (:data:`~pyheracles.beams.roles.ROLES`).
    shapes
        Deflection and twist per beam.
    timings
        Seconds per stage.
    """

    joints: tuple[Joint, ...]
    component: NDArray[np.int32]
    in_frame: NDArray[np.bool_]
    roles: tuple[str, ...]
    shapes: tuple[MemberShape, ...]
    timings: dict[str, float] = field(default_factory=dict)

    def member_columns(self) -> dict[str, list[Any]]:
        """Per-beam columns for the objects table (role, frame, deflection, twist)."""
        return {
            "role": list(self.roles),
            "in_frame": [bool(v) for v in self.in_frame],
            "component": [int(v) for v in self.component],
            "n_joints": [
                sum(i + 1 in jt.members for jt in self.joints) for i in range(len(self.roles))
            ],
            "deflection_mm": [_mm(s.deflection_m) for s in self.shapes],
            "twist_deg": [_round(s.twist_deg, 2) for s in self.shapes],
        }

    def to_json(
        self, result: BeamResult, offset: ArrayLike | None = None, n_points: int | None = None
    ) -> dict[str, Any]:
        """The frame as a JSON-ready dict (coordinates with ``offset`` added; NaN -> null)."""
        off = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64)
        counts = np.bincount(result.labels, minlength=len(result.beams) + 1)
        members = []
        for i, (b, s) in enumerate(zip(result.beams, self.shapes, strict=True)):
            members.append(
                {
                    "id": i + 1,
                    "role": self.roles[i],
                    "in_frame": bool(self.in_frame[i]),
                    "component": int(self.component[i]),
                    "centre": _xyz(b.centre + off),
                    "axis": [round(float(v), 6) for v in b.axis],
                    "ends": [
                        _xyz(b.centre + off - 0.5 * b.length * b.axis),
                        _xyz(b.centre + off + 0.5 * b.length * b.axis),
                    ],
                    "length_m": round(b.length, 4),
                    "width_m": round(b.width, 4),
                    "height_m": round(b.height, 4),
                    "inclination_deg": round(b.inclination_deg, 2),
                    "n_points": int(counts[i + 1]),
                    "deflection_mm": _mm(s.deflection_m),
                    "deflection_direction": [round(float(v), 4) for v in s.direction],
                    "max_deviation_mm": _mm(s.deviation_m),
                    "centreline_rms_mm": _mm(s.centreline_rms_m),
                    "twist_deg": _round(s.twist_deg, 2),
                    "measured_length_m": _round(s.measured_length_m, 3),
                    "shape_note": s.note,
                    "joints": [k + 1 for k, jt in enumerate(self.joints) if i + 1 in jt.members],
                }
            )
        joints = [
            {
                "id": k + 1,
                "members": list(jt.members),
                "type": jt.type,
                "point": _xyz(jt.point + off),
                "axis_distance_m": round(jt.distance_m, 4),
                "at": [round(v, 4) for v in jt.at],
            }
            for k, jt in enumerate(self.joints)
        ]
        comps = []
        for c in range(1, int(self.component.max(initial=0)) + 1):
            ids = (np.flatnonzero(self.component == c) + 1).tolist()
            comps.append({"id": c, "members": ids, "in_frame": bool(self.in_frame[ids[0] - 1])})
        by_type: dict[str, int] = {}
        for jt in self.joints:
            by_type[jt.type] = by_type.get(jt.type, 0) + 1
        by_role: dict[str, int] = {}
        for r in self.roles:
            by_role[r] = by_role.get(r, 0) + 1
        return {
            "units": {"length": "m", "deflection": "mm", "angle": "deg"},
            "n_points": n_points,
            "n_members": len(members),
            "n_in_frame": int(self.in_frame.sum()),
            "n_joints": len(joints),
            "joints_by_type": by_type,
            "members_by_role": by_role,
            "members": members,
            "joints": joints,
            "components": comps,
        }


def _round(v: float, nd: int) -> float | None:
    return None if not math.isfinite(v) else round(float(v), nd)


def _mm(v: float) -> float | None:
    return None if not math.isfinite(v) else round(1000.0 * float(v), 1)


def _xyz(v: NDArray[np.float64]) -> list[float]:
    return [round(float(x), 4) for x in v]


def _half_height(b: BeamCuboid) -> float:
    return 0.5 * float(np.abs(b.axes[2]) @ [b.length, b.width, b.height])


def _axis_foot(b: BeamCuboid) -> float:
    """Height of the lower end of a beam's axis, metres."""
    return float(b.centre[2] - 0.5 * b.length * abs(b.axis[2]))


def _ties_couple(
    beams: list[BeamCuboid], i: int, others: NDArray[np.bool_], p: FrameParams
) -> bool:
    """:func:`~pyheracles.beams.couples.ties_couple` with the frame's parameters."""
    return ties_couple(
        beams,
        i,
        others,
        inclined_deg=p.joints.inclined_deg,
        vertical_deg=p.roles.vertical_deg,
        skew_deg=p.couple_skew_deg,
    )


def _on_floor(beams: list[BeamCuboid], b: BeamCuboid, p: FrameParams) -> bool:
    """Whether ``b``'s underside lies within one of its sections of the floor.

    The floor is read as :func:`loose` reads it: the bottom of all the
    horizontal beams (timber lying on it, ties sunk in it).
    """
    flat = np.array([c.inclination_deg <= p.roles.horizontal_deg for c in beams])
    floor = frame_levels(beams, flat, p.roles)[0]
    underside = float(b.centre[2]) - _half_height(b)
    return underside <= floor + max(b.width, b.height)


def leaning(
    beams: list[BeamCuboid], joints: list[Joint], in_frame: NDArray[np.bool_], p: FrameParams
) -> NDArray[np.bool_]:
    """Beams that lean on the frame, or lie below it touching it, rather than belong to it.

    Not plumb, and either every joint in its upper half with its foot
    ``leaning_below_m`` below the frame's bottom (a ladder against a post, its
    side touching a strut or a rafter it passes as well: roof seed 16), or one
    joint only and wholly lower than one section under the frame's bottom (a
    timber on the floor against a post's foot).  A member of the frame is
    joined at its foot: a rafter to the plate or tie, a strut or a brace to
    the tie or post it springs from.
    """
    out = np.zeros(len(beams), bool)
    if not in_frame.any():
        return out
    group = components(len(beams), joints)
    for i, b in enumerate(beams):
        mine = [jt for jt in joints if i + 1 in jt.members]
        plumb = b.inclination_deg >= p.plumb_deg
        if not in_frame[i] or not mine or plumb:  # posts stand plumb, ladders lean
            continue
        low_end = 0.0 if b.axis[2] >= 0 else 1.0  # parameter of the lower end
        upper = all(abs(jt.at[jt.members.index(i + 1)] - low_end) > 0.5 for jt in mine)
        lowest = _axis_foot(b)
        # the bottom of the frame it is joined to, without it: another group (a pile
        # of loose timber on the floor) does not lower it
        rest = in_frame & (group == group[i])
        rest[i] = False
        if not rest.any():
            continue
        bottom, _ = frame_levels(beams, rest, p.roles)
        top = float(b.centre[2]) + _half_height(b)
        leans = upper and lowest < bottom - p.leaning_below_m
        # on the floor, touching the frame
        lies = len(mine) == 1 and top < bottom - max(b.width, b.height)
        out[i] = leans or lies
    return out


def leaning_apart(beams: list[BeamCuboid], bottom: float, p: FrameParams) -> NDArray[np.bool_]:
    """Beams of a group apart from the frame that stand below its bottom, leaning.

    Not plumb (below ``plumb_deg``) and the lower end more than
    ``leaning_below_m`` under the frame's ``bottom`` (metres): the group
    reaches up beside the frame from the floor but is joined to none of its
    members (roof seed 15: a ladder whose top touches nothing as fitted, its
    rails two boxes joined to each other only, 1.3 m below the tie beams).  A
    couple of rafters apart from the frame has its feet at the eaves, at the
    frame's bottom; a post stands plumb (:func:`idle_standing` judges those).
    """
    out = np.zeros(len(beams), bool)
    for i, b in enumerate(beams):
        lowest = _axis_foot(b)
        out[i] = b.inclination_deg < p.plumb_deg and lowest < bottom - p.leaning_below_m
    return out


def loose(
    beams: list[BeamCuboid], joints: list[Joint], in_frame: NDArray[np.bool_], p: FrameParams
) -> NDArray[np.bool_]:
    """Beams of the frame that are timber lying loose at its bottom (see ``span_share``).

    Horizontal (below ``roles.horizontal_deg``), the underside within one of
    its sections of the floor, joined to no beam inclined more than
    ``joints.inclined_deg``, and shorter than ``span_share`` of the extent of
    the frame's other beams along its axis.  The floor is the lower of the
    bottoms of the frame's horizontal beams and of all the horizontal beams:
    timber the frame no longer holds still lies on it (roof seed 5: planks at
    a chimney's foot; the tie beams, 1.1 m up, are no floor).
    """
    out = np.zeros(len(beams), bool)
    incl = np.array([b.inclination_deg for b in beams])
    flat = in_frame & (incl <= p.roles.horizontal_deg)
    if in_frame.sum() < 2 or not flat.any():
        return out
    # the bottom of the horizontal beams (a post's or a chimney's foot is lower): the
    # floor where timber lies, whether the frame holds it or it was left out already
    # (over a tie beam high above the floor, the ties are not where loose timber lies)
    bottom = min(
        frame_levels(beams, flat, p.roles)[0],
        frame_levels(beams, incl <= p.roles.horizontal_deg, p.roles)[0],
    )
    rising = incl >= p.joints.inclined_deg
    corners = np.array([b.corners() for b in beams])
    for i, b in enumerate(beams):
        if not in_frame[i] or incl[i] > p.roles.horizontal_deg:
            continue
        underside = float(b.centre[2]) - _half_height(b)
        if underside > bottom + max(b.width, b.height):
            continue
        if any(rising[k - 1] for jt in joints if i + 1 in jt.members for k in jt.members):
            continue
        others = in_frame.copy()
        others[i] = False
        if not others.any():
            continue
        along = corners[others].reshape(-1, 3) @ b.axis
        out[i] = b.length < p.span_share * float(np.ptp(along))
    return out


def section_half_height(b: BeamCuboid) -> float:
    """Half the vertical extent of a beam's cross-section (not of its box), metres.

    The box's own half height adds ``length / 2`` times the axis's slope: a
    plate 4 m long tilted by a third of a degree reaches a centimetre lower at
    one end than its underside lies at its middle.
    """
    return 0.5 * float(np.abs(b.axes[2, 1:]) @ [b.width, b.height])


def bearing(beams: list[BeamCuboid], p: FrameParams) -> NDArray[np.bool_]:
    """Boxes that are the bearing of a horizontal beam lying on them: masonry, not timber.

    A wall plate rests on the head of a wall, inset from the room's side: the
    strip of the wall head between the plate and the room, with the wall's
    face under it, is a straight horizontal band on a convex edge, as long
    as the plate, and comes out as a beam.  What gives it away is the plate:
    the box's top is level (within ``joints.contact_m``) with the underside
    of a horizontal beam laid along it (within ``bearing_skew_deg`` in plan:
    a strip seen at a grazing angle comes out skewed) beside it or on it, along at least half of
    the shorter one, i.e. the surface the plate rests on goes on under the
    plate.  Both levels are the sections' at the middle of the overlap, not
    the boxes' lowest and highest corners (which a tilt of the long axis
    moves by centimetres).  The two need not touch: the strip reaches from
    the room's face of the wall to the plate, and the box of a strip seen at
    a grazing angle or of a plate seen on one face is narrower than it is;
    their sides lie within ``bearing_reach_m`` when they overlap along half
    the longer one (a short piece whose underside happens to be level with a
    long beam's top some way off is no plate on it).  A timber lying beside a
    plate has its top above the plate's underside (or the plate would
    float); a member carrying another is crossed by it, not laid along it.
    """
    n = len(beams)
    out = np.zeros(n, bool)
    flat = [i for i, b in enumerate(beams) if b.inclination_deg <= p.roles.horizontal_deg]
    cos_par = math.cos(math.radians(p.bearing_skew_deg))
    contact = p.joints.contact_m
    for i in flat:
        low = beams[i]
        for k in flat:
            up = beams[k]
            if k == i or abs(float(up.axis @ low.axis)) < cos_par:
                continue
            d = up.centre - low.centre
            t = float(d @ low.axis)
            lo = max(t - 0.5 * up.length, -0.5 * low.length)
            hi = min(t + 0.5 * up.length, 0.5 * low.length)
            if hi - lo < 0.5 * min(up.length, low.length):
                continue
            # apart, the strip and its plate run together along the wall: a short
            # piece level with a long beam's top some way off is no plate on it
            run_together = hi - lo >= 0.5 * max(up.length, low.length)
            # the levels at the middle of the overlap
            mid = low.centre + 0.5 * (lo + hi) * low.axis
            top = float(mid[2]) + section_half_height(low)
            s = float((mid - up.centre) @ up.axis)
            under = float(up.centre[2] + s * up.axis[2]) - section_half_height(up)
            if abs(under - top) > contact:
                continue
            lat = d - t * low.axis
            lat[2] = 0.0
            dist = float(np.linalg.norm(lat))
            if dist > 1e-9:
                u = lat / dist
                reach = sum(
                    0.5 * float(np.abs(b.axes[:, 1:].T @ u) @ [b.width, b.height])
                    for b in (low, up)
                )
                gap = dist - reach
                if gap > contact and not (run_together and gap <= p.bearing_reach_m):
                    continue
            out[i] = True
            break
    return out


def idle_standing(
    beams: list[BeamCuboid],
    joints: list[Joint],
    apart: NDArray[np.bool_],
    bottom: float,
    p: FrameParams,
) -> NDArray[np.bool_]:
    """Plumb beams apart from the frame, standing on its bottom and carrying nothing.

    A post carries what is joined at its head (a tie, a collar, a purlin, the
    ridge); one that stands (at least ``plumb_deg``) with its foot no higher
    than the frame's bottom (within ``joints.contact_m``), is not joined to
    the frame (``apart``) and has no joint in its upper half is a stack of
    masonry from the floor (a chimney; roof seed 5: a 0.49 m stack with a
    pile of planks lying against its foot, the two a group of their own) or a
    prop stored upright, not a member.
    """
    out = np.zeros(len(beams), bool)
    for i, b in enumerate(beams):
        if not apart[i] or b.inclination_deg < p.plumb_deg:
            continue
        foot = _axis_foot(b)
        if foot > bottom + p.joints.contact_m:
            continue
        low_end = 0.0 if b.axis[2] >= 0 else 1.0
        out[i] = all(
            abs(jt.at[jt.members.index(i + 1)] - low_end) <= 0.5
            for jt in joints
            if i + 1 in jt.members
        )
    return out


def frame_members(
    beams: list[BeamCuboid], joints: list[Joint], p: FrameParams
) -> tuple[NDArray[np.int32], NDArray[np.bool_]]:
    """The connected component of each beam and whether it is a member of the frame.

    See the module's step 2.  Without any joint nothing holds together and no
    beam is a member.
    """
    comp = components(len(beams), joints)
    sizes = np.bincount(comp, minlength=2)
    core = (sizes[comp] >= p.min_frame_members) | (comp == 1)
    if len(beams) and sizes[1] < 2:  # no joint anywhere: nothing holds together
        core[:] = False
    lean = leaning(beams, joints, core, p)
    core &= ~lean
    idle = np.zeros(len(beams), bool)
    group, g_sizes = comp, sizes
    if core.any():
        # what stands on the floor apart from the main frame and carries nothing is
        # no member, nor holds together what only it touches: the groups without it
        bottom, _ = frame_levels(beams, core, p.roles)
        idle = idle_standing(beams, joints, comp != 1, bottom, p)
        if idle.any():
            kept = [jt for jt in joints if not any(idle[k - 1] for k in jt.members)]
            group = components(len(beams), kept)
            g_sizes = np.bincount(group, minlength=2)
            core = ((g_sizes[group] >= p.min_frame_members) | (group == 1)) & ~lean & ~idle
    in_frame = core.copy()
    if core.any():
        # a small group counts when it reaches the frame's bottom (a couple of rafters,
        # a tie whose joints are hidden in the walls: its top within one section of
        # the bottom); timber lying lower is loose
        bottom, _ = frame_levels(beams, core, p.roles)
        corners = np.array([b.corners() for b in beams])[core].reshape(-1, 3)
        for c in np.unique(group[(~core) & (g_sizes[group] < p.min_frame_members) & ~idle]):
            ids = np.flatnonzero(group == c)
            top = max(float(beams[i].centre[2]) + _half_height(beams[i]) for i in ids)
            section = max(max(beams[i].width, beams[i].height) for i in ids)
            in_frame[ids] = top > bottom - section  # level with the frame's bottom beams
            # a group apart from the frame whose inclined beams stand on the floor
            # below the frame's bottom is a ladder or a prop, not part of it
            in_frame[ids] &= ~leaning_apart([beams[i] for i in ids], bottom, p)
            if len(ids) == 1:
                # joined to nothing: only a beam spanning the frame (a tie from wall to
                # wall, its joints hidden in the masonry), not a chimney or a stray piece
                b = beams[ids[0]]
                flat = b.inclination_deg <= p.roles.horizontal_deg
                spans = b.length >= p.span_share * float(np.ptp(corners @ b.axis))
                # or a tie of a couple of rafters, its ends hidden or shadowed, lying
                # off the floor (a strip of the floor beside a tie sunk in it lies in
                # the couple's plane too)
                ties = _ties_couple(beams, int(ids[0]), core, p) and not _on_floor(beams, b, p)
                in_frame[ids] &= flat and (spans or ties)
        in_frame &= ~loose(beams, joints, in_frame, p)
    in_frame &= ~bearing(beams, p)
    return comp, in_frame


def analyse_frame(
    xyz: ArrayLike, result: BeamResult, params: FrameParams | None = None
) -> FrameResult:
    """Joints, graph, roles, deflection and twist of the beams of ``result``.

    Parameters
    ----------
    xyz
        ``(N, 3)`` the coordinates ``result`` was computed on, metres (local frame).
    result
        Output of :func:`~pyheracles.beams.segment_beams` on ``xyz``.
    params
        :class:`FrameParams`.

    Returns
    -------
    FrameResult
        Empty joints and components for a result without beams.

    Raises
    ------
    InputError
        ``xyz`` and ``result.labels`` of different lengths.
    """
    p = (params or FrameParams()).validate()
    arr = np.asarray(xyz, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3 or len(arr) != len(result.labels):
        raise InputError(
            f"the cloud has shape {arr.shape} but the beam labels cover {len(result.labels)} "
            "points; give the cloud the beams were segmented on"
        )
    beams = list(result.beams)
    timings: dict[str, float] = {}
    t = time.perf_counter()
    joints = find_joints(beams, p.joints)
    comp, in_frame = frame_members(beams, joints, p)
    roles = guess_roles(beams, joints, in_frame, p.roles)
    timings["joints_roles"] = time.perf_counter() - t
    t = time.perf_counter()
    shapes = member_shapes(arr, result.labels, beams, p.shape)
    timings["deflection"] = time.perf_counter() - t
    return FrameResult(
        joints=tuple(joints),
        component=comp,
        in_frame=in_frame,
        roles=tuple(roles),
        shapes=tuple(shapes),
        timings=timings,
    )
