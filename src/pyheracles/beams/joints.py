"""Joints between the beams of a frame, from their fitted cuboids.

Two beams meet where their cuboids touch or interpenetrate: the separating
axis test of the two oriented boxes, each grown by a lateral ``contact_m``
(a fitted face is off by a few millimetres, a joint's faces do not quite
touch), and each end that touches no beam as fitted lengthened by
``end_slack_m`` (an end hidden in a joint, a wall or a shadow is fitted
short).  The joint point
is the midpoint of the closest points of the two centre lines (segments).
Its type, from where the joint lies on each beam and how the two sit:

``foot``
    the lower end of an inclined beam (a rafter) on a horizontal beam below
    it (tie beam or wall plate), the rafter's part past the joint shorter
    than ``foot_reach_m`` (its eaves overhang);
``L``
    both beams end there (rafter heads at the apex, a brace into a post end);
``T``
    one beam ends on the other's length (post on a tie beam, strut under a
    rafter);
``X``
    both run through (purlin over a rafter, braces crossing);
``lap``
    one or both end there, the two laid face to face instead of in one
    plane (a brace nailed under a rafter, a collar on a rafter's side).

The beams and joints make the frame's graph; its connected components say
which timbers hold together (:func:`components`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from pyheracles.beams.model import BeamCuboid
from pyheracles.errors import InputError

__all__ = [
    "JOINT_TYPES",
    "Joint",
    "JointParams",
    "closest_points",
    "components",
    "find_joints",
    "obb_gap",
]

Array = NDArray[np.float64]

#: Joint types, in the order they are tested.
JOINT_TYPES = ("foot", "L", "T", "X", "lap")


@dataclass(frozen=True)
class JointParams:
    """Parameters of the joint search.

    Attributes
    ----------
    contact_m
        Gap allowed between two cuboids that meet, metres: a fitted face is
        off by up to about 1 cm, so two fitted beams in contact can be 2 cm
        apart, and joints are rarely tight (chosen on a sweep of the ``roof``
        family: 4 cm finds 98-100 % of the joints between exact cuboids of
        every frame type with 92-98 % of them true).
    end_slack_m
        Extra length given to a beam's end that touches no other beam as
        fitted, metres: an end hidden in a joint, a wall or a shadow is fitted
        short (ends that rest on a beam keep their length).
    end_reach_m
        A free end is followed along its axis, in steps of ``end_slack_m``, up
        to this length to the first beam it meets (an end hidden in a wall
        head rests on the plate or tie beam there), metres.
    end_margin_m
        A joint lies at a beam's end when it is within half of both beams'
        largest section sides plus this margin of the end, metres.
    foot_reach_m
        Largest length of an inclined beam past the joint with the horizontal
        beam under it for a ``foot`` (the eaves overhang of a rafter), metres.
    horizontal_deg, inclined_deg, vertical_deg
        A beam is horizontal below ``horizontal_deg`` of inclination, inclined
        from ``inclined_deg`` and vertical (a post, no ``foot``) from
        ``vertical_deg``, degrees.
    stacked_share
        Two beams are laid face to face (``X`` or ``lap``) when their centre
        lines are at least this share of the sum of their half sections
        apart along the common normal; closer, they are in one plane (halved,
        tenoned, butted).
    """

    contact_m: float = 0.04
    end_slack_m: float = 0.2
    end_reach_m: float = 0.6
    end_margin_m: float = 0.05
    foot_reach_m: float = 1.2
    horizontal_deg: float = 5.0
    inclined_deg: float = 15.0
    vertical_deg: float = 70.0
    stacked_share: float = 0.7

    def validate(self) -> JointParams:
        for name in ("contact_m", "end_slack_m", "end_reach_m", "end_margin_m", "foot_reach_m"):
            v = getattr(self, name)
            if not 0 <= v <= 5.0:
                raise InputError(f"{name} must be in [0, 5] metres, got {v}")
        if not (0 < self.horizontal_deg < 45 and 0 < self.inclined_deg < self.vertical_deg <= 90):
            raise InputError(
                "need horizontal_deg in (0, 45) and 0 < inclined_deg < vertical_deg <= 90, got "
                f"{self.horizontal_deg}, {self.inclined_deg} and {self.vertical_deg}"
            )
        if not 0 < self.stacked_share <= 1.5:
            raise InputError(f"stacked_share must be in (0, 1.5], got {self.stacked_share}")
        return self


@dataclass(frozen=True)
class Joint:
    """Two beams that meet.

    Attributes
    ----------
    members
        The two beams, 1-based (as in the labels), smaller first.
    point
        ``(3,)`` midpoint of the closest points of the centre lines, metres.
    type
        One of :data:`JOINT_TYPES`.
    distance_m
        Distance between the centre lines there, metres.
    at
        Position of the joint along each beam, 0-1 from the end at
        ``centre - axis * length / 2``.
    """

    members: tuple[int, int]
    point: Array
    type: str
    distance_m: float
    at: tuple[float, float]


def closest_points(a0: Array, a1: Array, b0: Array, b1: Array) -> tuple[float, float]:
    """Parameters (0-1) of the closest points of segments ``a0-a1`` and ``b0-b1``."""
    u, v, w = a1 - a0, b1 - b0, a0 - b0
    a, b, c, d, e = u @ u, u @ v, v @ v, u @ w, v @ w
    den = a * c - b * b
    s = 0.5 if den <= 1e-12 * a * c else float(np.clip((b * e - c * d) / den, 0.0, 1.0))
    t = float(np.clip((b * s + e) / c, 0.0, 1.0)) if c > 0 else 0.0
    s = float(np.clip((b * t - d) / a, 0.0, 1.0)) if a > 0 else 0.0
    return s, t


def obb_gap(
    ca: Array, axes_a: Array, half_a: Array, cb: Array, axes_b: Array, half_b: Array
) -> float:
    """Largest separation of two oriented boxes over the 15 separating axes, metres.

    Negative or zero: the boxes overlap; positive: a lower bound of their distance
    (exact when a face axis separates them).  ``axes_*`` hold the box axes as
    columns, ``half_*`` the half extents along them.
    """
    cand = [axes_a[:, i] for i in range(3)] + [axes_b[:, i] for i in range(3)]
    for i in range(3):
        for j in range(3):
            c = np.cross(axes_a[:, i], axes_b[:, j])
            n = np.linalg.norm(c)
            if n > 1e-6:
                cand.append(c / n)
    d = cb - ca
    gap = -np.inf
    for n in cand:
        ra = float(np.abs(axes_a.T @ n) @ half_a)
        rb = float(np.abs(axes_b.T @ n) @ half_b)
        gap = max(gap, abs(float(d @ n)) - ra - rb)
    return float(gap)


def _ends(c: BeamCuboid) -> tuple[Array, Array]:
    h = 0.5 * c.length * c.axis
    return c.centre - h, c.centre + h


def _joint_type(
    a: BeamCuboid, s: float, b: BeamCuboid, t: float, stacked: bool, p: JointParams
) -> str:
    for m, u, o in ((a, s, b), (b, t, a)):
        if p.inclined_deg <= m.inclination_deg < p.vertical_deg and (
            o.inclination_deg <= p.horizontal_deg
        ):
            lower = u if m.axis[2] >= 0 else 1.0 - u  # 0 at the lower end
            above = float((m.centre - o.centre) @ np.array([0.0, 0.0, 1.0])) > 0
            if above and lower * m.length <= p.foot_reach_m:
                return "foot"
    reach = 0.5 * (max(a.width, a.height) + max(b.width, b.height)) + p.end_margin_m
    ea = min(s, 1.0 - s) * a.length <= reach
    eb = min(t, 1.0 - t) * b.length <= reach
    if not (ea or eb):
        return "X"
    if stacked:
        return "lap"
    return "L" if ea and eb else "T"


def find_joints(
    beams: list[BeamCuboid] | tuple[BeamCuboid, ...], params: JointParams | None = None
) -> list[Joint]:
    """Every pair of beams that meet, with the joint point and type.

    Parameters
    ----------
    beams
        Fitted cuboids (``beams[i]`` is beam ``i + 1``).
    params
        :class:`JointParams`.

    Returns
    -------
    list of Joint
        Sorted by the pair of beams; empty for fewer than two beams.
    """
    p = (params or JointParams()).validate()
    n = len(beams)
    if n < 2:
        return []
    # ends resting on nothing as fitted were fitted short: only those are lengthened,
    # up to the first beam their extension meets (in steps of end_slack_m)
    grown = []
    boxes = _aabbs(list(beams), 0.0)  # each beam's box, once (not once per end and step)
    for b in beams:
        ext = [_reach(b, sign, beams, p, boxes) for sign in (-1, 1)]
        grown.append(
            replace(
                b,
                centre=b.centre + b.axis * 0.5 * (ext[1] - ext[0]),
                length=b.length + ext[0] + ext[1],
            )
        )
    lo, hi = _aabbs(grown, p.contact_m)
    out: list[Joint] = []
    for i in range(n - 1):
        near = np.flatnonzero(
            np.all(lo[i + 1 :] <= hi[i], axis=1) & np.all(hi[i + 1 :] >= lo[i], axis=1)
        )
        for j in (near + i + 1).tolist():
            if not _touch(grown[i], grown[j], p.contact_m):
                continue
            a, b = beams[i], beams[j]
            (a0, a1), (b0, b1) = _ends(a), _ends(b)
            s, t = closest_points(a0, a1, b0, b1)
            pa, pb = a0 + s * (a1 - a0), b0 + t * (b1 - b0)
            out.append(
                Joint(
                    members=(i + 1, j + 1),
                    point=0.5 * (pa + pb),
                    type=_joint_type(a, s, b, t, _stacked(a, b, p), p),
                    distance_m=float(np.linalg.norm(pa - pb)),
                    at=(s, t),
                )
            )
    return out


def _aabbs(beams: list[BeamCuboid], margin: float) -> tuple[Array, Array]:
    corners = np.array([b.corners() for b in beams])
    return corners.min(axis=1) - margin, corners.max(axis=1) + margin


def _touch(a: BeamCuboid, b: BeamCuboid, contact: float) -> bool:
    """Whether two cuboids, each grown by ``contact / 2`` on every side, overlap."""
    g = 0.5 * contact
    return obb_gap(a.centre, a.axes, a.half_extents + g, b.centre, b.axes, b.half_extents + g) <= 0


def _reach(
    b: BeamCuboid,
    sign: int,
    beams: list[BeamCuboid] | tuple[BeamCuboid, ...],
    p: JointParams,
    boxes: tuple[Array, Array] | None = None,
) -> float:
    """Length to add at the end of ``b`` at ``sign``: 0 when seated, else up to the first beam.

    ``boxes``: the beams' axis-aligned boxes (``_aabbs(beams, 0)``), computed if not given.
    """
    if boxes is None:
        boxes = _aabbs(list(beams), 0.0)
    if _seated(b, sign, beams, p.contact_m, 0.0, boxes):
        return 0.0
    n_steps = max(1, int(np.ceil(p.end_reach_m / p.end_slack_m)))
    for k in range(1, n_steps + 1):
        ext = min(k * p.end_slack_m, p.end_reach_m)
        if _seated(b, sign, beams, p.contact_m, ext, boxes):
            return ext
    return p.end_slack_m


def _seated(
    b: BeamCuboid,
    sign: int,
    beams: list[BeamCuboid] | tuple[BeamCuboid, ...],
    contact: float,
    ext: float,
    boxes: tuple[Array, Array] | None = None,
) -> bool:
    """Whether the end of ``b`` at ``sign`` (its last section-size piece, ``ext`` longer) touches
    another beam.

    ``boxes``: the beams' axis-aligned boxes (``_aabbs(beams, 0)``); the beams whose box
    the piece's box (grown by ``contact``) misses are skipped in one vectorised test.
    """
    piece_len = min(b.length, max(b.width, b.height)) + ext
    piece = replace(
        b,
        centre=b.centre + sign * b.axis * (0.5 * b.length + ext - 0.5 * piece_len),
        length=piece_len,
    )
    (lo,), (hi,) = _aabbs([piece], contact)
    box_lo, box_hi = _aabbs(list(beams), 0.0) if boxes is None else boxes
    near = np.flatnonzero(~(np.any(box_hi < lo, axis=1) | np.any(box_lo > hi, axis=1)))
    for k in near.tolist():
        o = beams[k]
        if o is b:
            continue
        if _touch(piece, o, contact):
            return True
    return False


def _stacked(a: BeamCuboid, b: BeamCuboid, p: JointParams) -> bool:
    """Whether two beams lie face to face rather than in one plane."""
    n = np.cross(a.axis, b.axis)
    norm = np.linalg.norm(n)
    if norm < np.sin(np.radians(10.0)):  # near parallel: across both axes
        d = b.centre - a.centre
        n = d - (d @ a.axis) * a.axis
        norm = np.linalg.norm(n)
        if norm < 1e-9:
            return False
    n = n / norm
    sep = abs(float((b.centre - a.centre) @ n))
    ra = float(np.abs(a.axes.T @ n) @ a.half_extents)
    rb = float(np.abs(b.axes.T @ n) @ b.half_extents)
    return sep >= p.stacked_share * (ra + rb)


def components(n_beams: int, joints: list[Joint]) -> NDArray[np.int32]:
    """Connected component (1-based, largest first) of every beam in the joint graph."""
    if n_beams == 0:
        return np.zeros(0, np.int32)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from pyheracles.segment.euclidean import relabel_by_size

    pairs = np.array([jt.members for jt in joints], dtype=np.int64).reshape(-1, 2) - 1
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(n_beams, n_beams))  # fmt: skip
    # scipy numbers components by their lowest beam: ties in size go to the first beam
    return relabel_by_size(connected_components(graph, directed=False)[1], 1)
