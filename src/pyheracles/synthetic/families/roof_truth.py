"""Reference data of the ``roof`` family derived from the members: joints and faces seen.

Joints are found from the true cuboids: two members meet where their boxes
touch or interpenetrate (within 1 cm).  The joint point is the midpoint of
the closest points of the two centre lines; its type is

``foot``
    the lower end of a rafter or common rafter on a tie beam or wall plate;
``L``
    both members end there (rafter heads at the apex, brace into a post end);
``T``
    one member ends on the other's length (post on a tie, strut under a rafter);
``X``
    both run through (purlin over a rafter, common rafter over a plate, braces crossing).

Faces seen are counted from the scan: the points of a member are given to
the nearest of its six faces (in the member's own bent and twisted frame),
and a lateral face counts as seen with at least :data:`FACE_MIN_POINTS`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.beams.joints import closest_points
from pyheracles.synthetic.families.boxes import obb_overlap_many
from pyheracles.synthetic.families.roof_frame import Member

__all__ = ["FACE_MIN_POINTS", "JOINT_TOL_M", "faces_seen", "find_joints"]

#: Points a lateral face needs to count as seen.
FACE_MIN_POINTS = 50
#: Boxes closer than this (metres) meet in a joint.
JOINT_TOL_M = 0.01
#: Face names in the order of :func:`faces_seen`'s counts.
FACES = ("+side", "-side", "+up", "-up", "+end", "-end")

Array = NDArray[np.float64]


def _near_end(m: Member, s: float, other: Member) -> bool:
    """Whether parameter ``s`` along ``m`` is at one of its ends (within the other's section)."""
    reach = 0.5 * max(other.width, other.height) + 0.5 * max(m.width, m.height) + 0.05
    return min(s, 1 - s) * m.length <= reach


def find_joints(members: list[Member], tol: float = JOINT_TOL_M) -> list[dict[str, Any]]:
    """Every pair of members that meet, with the joint point and type (1-based instances)."""
    out: list[dict[str, Any]] = []
    ctr = np.array([m.centre for m in members])
    rows = np.array([m.rows for m in members])
    half = np.array([m.half_extents for m in members])
    rad = np.linalg.norm(half, axis=1)
    for i, a in enumerate(members):
        near = (
            np.flatnonzero(
                np.linalg.norm(ctr[i + 1 :] - ctr[i], axis=1) <= rad[i + 1 :] + rad[i] + tol
            )
            + i
            + 1
        )
        meet = near[
            obb_overlap_many(ctr[i], rows[i], half[i], ctr[near], rows[near], half[near], tol)
        ]
        for j in meet:
            b = members[j]
            (a0, a1), (b0, b1) = a.ends, b.ends
            s, t = closest_points(a0, a1, b0, b1)
            p = 0.5 * (a0 + s * (a1 - a0) + b0 + t * (b1 - b0))
            out.append(
                {
                    "members": [i + 1, int(j) + 1],
                    "names": [a.name, b.name],
                    "roles": [a.role, b.role],
                    "point": [round(float(v), 4) for v in p],
                    "type": _joint_type(a, s, b, t),
                }
            )
    return out


def _joint_type(a: Member, s: float, b: Member, t: float) -> str:
    for m, u, o in ((a, s, b), (b, t, a)):
        lower = u if m.axis[2] >= 0 else 1 - u  # 0 at the lower end
        if (
            m.role in ("rafter", "common_rafter")
            and o.role in ("tie", "plate")
            and lower * m.length < 1.2
        ):
            return "foot"
    ea, eb = _near_end(a, s, b), _near_end(b, t, a)
    if ea and eb:
        return "L"
    if ea or eb:
        return "T"
    return "X"


def faces_seen(
    member: Member, pts: Array, min_points: int = FACE_MIN_POINTS
) -> tuple[int, dict[str, int]]:
    """Lateral faces of ``member`` holding at least ``min_points`` of ``pts``, and all counts."""
    if len(pts) == 0:
        return 0, dict.fromkeys(FACES, 0)
    rel = pts - member.centre
    a = rel @ member.axis
    t = np.clip(a / member.length + 0.5, 0.0, 1.0)
    rel = rel - member.bend_offset(t)
    side, up = member.section_frame(t)
    s = np.einsum("ij,ij->i", rel, side)
    u = np.einsum("ij,ij->i", rel, up)
    L, w, h = member.length / 2, member.width / 2, member.height / 2
    q = np.column_stack([np.abs(s) - w, np.abs(u) - h, np.abs(a) - L])
    k = q.argmax(axis=1)
    sign = np.where(k == 0, s, np.where(k == 1, u, a)) >= 0
    code = 2 * k + (~sign).astype(int)
    counts = np.bincount(code, minlength=6)
    per = {name: int(counts[c]) for c, name in enumerate(FACES)}
    n_seen = int(sum(counts[c] >= min_points for c in range(4)))
    return n_seen, per
