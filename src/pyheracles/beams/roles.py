"""The role of every beam in a roof frame, guessed from geometry and joints.

Roles (what a surveyor of historic roofs names them): ``tie`` (tie beam),
``rafter`` (principal rafter: tied into a tie beam), ``common_rafter``,
``post`` (king or queen post), ``strut``, ``collar`` (collar or straining
beam), ``purlin``, ``ridge``, ``plate`` (wall plate), ``brace``; beams not
joined to the frame are ``loose``.  The guess reads, for every beam of the
frame:

- its **orientation**: vertical (a post), horizontal or inclined, and for
  horizontal and inclined beams whether it runs along the roof (the ridge
  direction) or across it.  The roof's length direction is perpendicular to
  the horizontal run of the inclined beams that lie in vertical planes
  (rafters, struts), weighted by length; without inclined beams it is the
  direction of the longest horizontal beams;
- its **height in the frame** (0 at the frame's bottom, 1 at the highest
  top) and its **place across** the roof (0 on the ridge line, 1 at the
  eaves);
- **what it joins**: an inclined beam across the roof that is tied into a
  tie beam (joined to one, or in a tie beam's vertical plane: a truss) is a
  principal rafter, one that is not is a common rafter; a short one (not
  spanning the frame's height) is a strut in a truss's plane (a tie beam's
  or a post's), a piece of a common rafter elsewhere.

Thresholds are shares of the frame's own height and width, not metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.beams.joints import Joint
from pyheracles.beams.model import BeamCuboid
from pyheracles.errors import InputError

__all__ = ["ROLES", "RoleParams", "frame_levels", "guess_roles", "roof_directions"]

Array = NDArray[np.float64]

#: Roles a beam can be given.
ROLES = (
    "tie",
    "rafter",
    "common_rafter",
    "post",
    "strut",
    "collar",
    "purlin",
    "ridge",
    "plate",
    "brace",
    "loose",
)

Z = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class RoleParams:
    """Parameters of the role guess.

    Attributes
    ----------
    vertical_deg, horizontal_deg
        Inclination from which a beam is vertical, and below which it is
        horizontal, degrees.
    along_deg
        A beam runs along (or across) the roof within this angle of its
        length (or width) direction in plan, degrees.
    low_share
        Tie beams and wall plates lie in the lowest ``low_share`` of the
        frame's height (their centre).
    eaves_share
        Wall plates lie at least this share of the half width from the ridge
        line.
    ridge_share
        A ridge lies within this share of the half width from the ridge line.
    span_low, span_high
        An inclined beam across the roof is a rafter (principal or common)
        when its lower end is below ``span_low`` and its upper end above
        ``span_high`` of the frame's height; otherwise a strut.
    bottom_share
        The frame's bottom is the lowest beam bottom once this share of the
        frame's beam length lies below it (a short piece on the floor that
        touches the frame does not lower it).
    """

    vertical_deg: float = 70.0
    horizontal_deg: float = 5.0
    along_deg: float = 25.0
    low_share: float = 0.25
    eaves_share: float = 0.6
    ridge_share: float = 0.15
    span_low: float = 0.35
    span_high: float = 0.65
    bottom_share: float = 0.05

    def validate(self) -> RoleParams:
        if not 0 < self.horizontal_deg < self.vertical_deg < 90:
            raise InputError(
                "need 0 < horizontal_deg < vertical_deg < 90, got "
                f"{self.horizontal_deg} and {self.vertical_deg}"
            )
        if not 0 < self.along_deg < 45:
            raise InputError(f"along_deg must be in (0, 45), got {self.along_deg}")
        names = ("low_share", "eaves_share", "ridge_share", "span_low", "span_high", "bottom_share")
        for name in names:
            v = getattr(self, name)
            if not 0 < v < 1:
                raise InputError(f"{name} must be in (0, 1), got {v}")
        if self.span_low >= self.span_high:
            raise InputError(f"need span_low < span_high, got {self.span_low} and {self.span_high}")
        return self


def _plan(v: Array) -> Array:
    h = np.array([v[0], v[1], 0.0])
    n = np.linalg.norm(h)
    return h / n if n > 1e-9 else h


def roof_directions(
    beams: list[BeamCuboid] | tuple[BeamCuboid, ...], p: RoleParams | None = None
) -> tuple[Array, Array]:
    """Unit horizontal vectors along the roof's length (ridge) and across it.

    The mean doubled angle of the inclined beams' plan directions (weighted by
    plan length) is the across direction; with no inclined beam, the mean of
    the horizontal beams' directions (weighted by length) is the length.
    """
    p = (p or RoleParams()).validate()
    incl = np.array([b.inclination_deg for b in beams])
    ang = np.array([np.arctan2(b.axis[1], b.axis[0]) for b in beams])
    plan_len = np.array([b.length * np.hypot(b.axis[0], b.axis[1]) for b in beams])
    sloped = (incl > p.horizontal_deg) & (incl < p.vertical_deg)
    flat = incl <= p.horizontal_deg
    if sloped.any():
        w, across_first = plan_len * sloped, True
    elif flat.any():
        w, across_first = plan_len * flat, False
    else:
        return np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    mean = 0.5 * np.arctan2(np.sum(w * np.sin(2 * ang)), np.sum(w * np.cos(2 * ang)))
    d = np.array([np.cos(mean), np.sin(mean), 0.0])
    perp = np.array([-d[1], d[0], 0.0])
    return (perp, d) if across_first else (d, perp)


def frame_levels(
    beams: list[BeamCuboid] | tuple[BeamCuboid, ...],
    in_frame: NDArray[np.bool_],
    params: RoleParams | None = None,
) -> tuple[float, float]:
    """The frame's bottom and top heights, metres.

    The top is the highest beam top; the bottom the lowest beam bottom once
    ``bottom_share`` of the frame's beam length lies below it (a short piece on
    the floor that touches the frame does not lower it).
    """
    p = (params or RoleParams()).validate()
    frame = np.flatnonzero(in_frame)
    if len(frame) == 0:
        return float("nan"), float("nan")
    half_z = np.array(
        [0.5 * (np.abs(beams[i].axes[2]) @ [beams[i].length, beams[i].width, beams[i].height])
         for i in frame]
    )  # fmt: skip
    z = np.array([beams[i].centre[2] for i in frame])
    bottoms = z - half_z
    weights = np.array([beams[i].length for i in frame])
    order = np.argsort(bottoms)
    cum = np.cumsum(weights[order])
    k = min(int(np.searchsorted(cum, p.bottom_share * cum[-1])), len(frame) - 1)
    return float(bottoms[order][k]), float(np.max(z + half_z))


def guess_roles(
    beams: list[BeamCuboid] | tuple[BeamCuboid, ...],
    joints: list[Joint],
    in_frame: NDArray[np.bool_],
    params: RoleParams | None = None,
) -> list[str]:
    """Role of every beam (:data:`ROLES`; ``loose`` where ``in_frame`` is false).

    Parameters
    ----------
    beams
        Fitted cuboids (``beams[i]`` is beam ``i + 1``).
    joints
        Joints between them (:func:`~pyheracles.beams.joints.find_joints`).
    in_frame
        ``(B,)`` whether each beam is a member of the frame.
    params
        :class:`RoleParams`.
    """
    p = (params or RoleParams()).validate()
    n = len(beams)
    roles = ["loose"] * n
    frame = [i for i in range(n) if in_frame[i]]
    if not frame:
        return roles
    fb = [beams[i] for i in frame]
    along, across = roof_directions(fb, p)
    ends = np.array(
        [[c.centre - 0.5 * c.length * c.axis, c.centre + 0.5 * c.length * c.axis] for c in beams]
    )  # (B, 2, 3)
    z_lo, z_hi = frame_levels(beams, in_frame, p)
    height = max(z_hi - z_lo, 1e-6)
    c_across = ends[frame] @ across
    mid = 0.5 * (c_across.min() + c_across.max())
    half_w = max(0.5 * (c_across.max() - c_across.min()), 1e-6)
    cos_along = np.cos(np.radians(p.along_deg))
    neighbours: dict[int, set[int]] = {i: set() for i in range(n)}
    for jt in joints:
        a, b = jt.members[0] - 1, jt.members[1] - 1
        neighbours[a].add(b)
        neighbours[b].add(a)
    level = {i: (float(beams[i].centre[2]) - z_lo) / height for i in frame}
    sloped_across: list[int] = []
    for i in frame:
        c = beams[i]
        incl = c.inclination_deg
        plan = _plan(c.axis)
        runs_along = abs(float(plan @ along)) >= cos_along
        runs_across = abs(float(plan @ across)) >= cos_along
        place = abs(float(c.centre @ across) - mid) / half_w
        if incl >= p.vertical_deg:
            roles[i] = "post"
        elif incl <= p.horizontal_deg and runs_along:
            if place <= p.ridge_share and level[i] > 0.5:
                roles[i] = "ridge"
            elif level[i] <= p.low_share and place >= p.eaves_share:
                roles[i] = "plate"
            else:
                roles[i] = "purlin"
        elif incl <= p.horizontal_deg:
            roles[i] = "tie" if level[i] <= p.low_share else "collar"
        elif runs_across:
            sloped_across.append(i)
        else:
            roles[i] = "brace"

    def in_truss(i: int, kinds: tuple[str, ...]) -> bool:
        """Whether a beam of ``kinds`` lies in the vertical plane across the roof of ``i``.

        Within half the sum of the larger section sides (a beam seen on one face
        is a slab on that face, off its true centre).
        """
        pos = float(beams[i].centre @ along)
        side = max(beams[i].width, beams[i].height)
        return any(
            roles[j] in kinds
            and abs(float(beams[j].centre @ along) - pos)
            <= 0.5 * (side + max(beams[j].width, beams[j].height))
            for j in frame
        )

    for i in sloped_across:
        zs = (ends[i, :, 2] - z_lo) / height
        if zs.min() <= p.span_low and zs.max() >= p.span_high:
            # a principal rafter is tied: joined to a tie beam, or in a tie beam's
            # vertical plane (a truss; the foot joint may be hidden in the wall head)
            tied = any(roles[j] == "tie" for j in neighbours[i]) or in_truss(i, ("tie",))
            roles[i] = "rafter" if tied else "common_rafter"
        elif in_truss(i, ("tie", "post")):
            roles[i] = "strut"  # short, in the plane of a truss
        else:
            roles[i] = "common_rafter"  # a piece of one, between the trusses
    return roles
