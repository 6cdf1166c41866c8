"""Members of the ``roof`` family's timber frames: true cuboids and how they are laid out.

A roof is drawn as one of four frame types:

``king_post``, ``queen_post``
    Principal trusses (tie beam, two principal rafters, king post or two
    queen posts with a straining beam, struts) every 2.5-4.5 m carrying
    purlins (on the principal rafters), a ridge (on the king post head or
    between the rafter heads) and common rafters (on the purlins), with X
    braces in the planes of the posts between trusses.
``collar``, ``simple_rafter``
    Couple roofs: a pair of rafters every 0.45-0.9 m standing on the wall
    plates, every few couples tied by a tie beam (the tied rafters reach the
    tie beam's end through the plate), collars on every couple (``collar``),
    an optional ridge, and X wind braces under the rafters between tied
    couples.

Every member is a :class:`Member` (centre, axis, up vector, length, width
along ``side = axis x up``, height along ``up``; optionally bent or
twisted).  Members of a truss lie in a vertical plane ``x = const`` and are
measured with their width across that plane; longitudinal members
(plates, purlins, ridge) run along ``x``.  Joints interpenetrate as halved,
tenoned and trenched joints do, and the scanner sees the union of surfaces.

Levels (``z`` up, floor at 0, eaves walls at ``|y| = half``):

- masonry wall top = tie beam bottom ``z_w``; tie top ``z_tt``;
- wall plate on the built-up wall head at ``z_tt``, top ``z_pt``;
- common rafters' bottom face ``B(eta)`` touches the plate top; boarding
  underside ``U(eta) = B + h_c / cos``; ``eta`` is the horizontal distance
  from the ridge line towards one side (signed: negative past the apex).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "FRAME_TYPES",
    "ROLES",
    "Member",
    "RoofLevels",
    "build_frame",
    "deform",
    "draw_sections",
]

Array = NDArray[np.float64]

#: Frame types of the family.
FRAME_TYPES = ("king_post", "queen_post", "collar", "simple_rafter")
#: Roles a member can have (``scene.objects[i]["role"]``).
ROLES = (
    "tie",
    "rafter",
    "post",
    "strut",
    "purlin",
    "ridge",
    "plate",
    "brace",
    "common_rafter",
    "collar",
)

X = np.array([1.0, 0.0, 0.0])
Y = np.array([0.0, 1.0, 0.0])
Z = np.array([0.0, 0.0, 1.0])

#: Nominal section ranges per role, metres: (width min, max), (height min, max).
SECTION_RANGES: dict[str, tuple[tuple[float, float], tuple[float, float]]] = {
    "tie": ((0.15, 0.30), (0.18, 0.32)),
    "rafter": ((0.14, 0.26), (0.16, 0.28)),
    "post": ((0.14, 0.26), (0.14, 0.26)),
    "strut": ((0.10, 0.20), (0.12, 0.22)),
    "purlin": ((0.12, 0.24), (0.14, 0.26)),
    "ridge": ((0.10, 0.22), (0.15, 0.30)),
    "plate": ((0.15, 0.30), (0.10, 0.20)),
    "brace": ((0.08, 0.15), (0.10, 0.16)),
    "common_rafter": ((0.08, 0.14), (0.10, 0.18)),
    "collar": ((0.10, 0.20), (0.12, 0.22)),
}
SECTION_MIN_M, SECTION_MAX_M = 0.08, 0.35


@dataclass(frozen=True)
class Member:
    """A true beam: an oriented cuboid, possibly bent (sag) or twisted.

    Attributes
    ----------
    name, role
        Unique name (``tie2``, ``common_rafter_l7`` ...) and role (:data:`ROLES`).
    centre
        ``(3,)`` centre of the straight (chord) cuboid, metres.
    axis, up
        Unit vectors along the length and the height; the width runs along
        ``side = cross(axis, up)``.
    length, width, height
        Edge lengths, metres.
    deflection_m
        Mid-length offset of a bent member along ``-up`` (sag; posts bow
        along ``up``), metres; the section centre follows ``4 t (1 - t)``.
    twist_deg
        End-to-end rotation of the section about the axis, degrees.
    group
        Members removed together when a chimney trims the frame (-1: never).
    """

    name: str
    role: str
    centre: Array
    axis: Array
    up: Array
    length: float
    width: float
    height: float
    deflection_m: float = 0.0
    twist_deg: float = 0.0
    group: int = -1

    @property
    def side(self) -> Array:
        """Unit vector along the width."""
        a, u = self.axis, self.up
        return np.array(
            [a[1] * u[2] - a[2] * u[1], a[2] * u[0] - a[0] * u[2], a[0] * u[1] - a[1] * u[0]]
        )

    @property
    def rows(self) -> Array:
        """``(3, 3)`` frame whose rows are ``axis``, ``side``, ``up``."""
        return np.vstack([self.axis, self.side, self.up])

    @property
    def half_extents(self) -> Array:
        """Half length, half width, half height, metres."""
        return 0.5 * np.array([self.length, self.width, self.height])

    @property
    def ends(self) -> tuple[Array, Array]:
        """The two ends of the centre line."""
        h = 0.5 * self.length * self.axis
        return self.centre - h, self.centre + h

    def bend_offset(self, t: ArrayLike) -> Array:
        """``(n, 3)`` offset of the section centre at normalised length ``t`` (0-1)."""
        t = np.asarray(t, float)
        vertical = abs(self.axis[2]) > 0.95
        direction = self.up if vertical else -self.up
        return (4.0 * self.deflection_m * t * (1.0 - t))[:, None] * direction

    def section_frame(self, t: ArrayLike) -> tuple[Array, Array]:
        """Side and up vectors ``(n, 3)`` of the (twisted) section at ``t``."""
        t = np.asarray(t, float)
        th = np.radians(self.twist_deg) * (t - 0.5)
        c, s = np.cos(th)[:, None], np.sin(th)[:, None]
        side, up = self.side, self.up
        return c * side + s * up, -s * side + c * up

    def triangles(self, rings: int = 16) -> Array:
        """Surface triangles ``(T, 3, 3)``: 4 lateral faces in ``rings`` slices + 2 ends."""
        straight = self.deflection_m == 0 and self.twist_deg == 0
        n = 1 if straight else rings
        t = np.linspace(0.0, 1.0, n + 1)
        ctr = self.centre + (t - 0.5)[:, None] * self.length * self.axis + self.bend_offset(t)
        sv, uv = self.section_frame(t)
        w, h = self.width / 2, self.height / 2
        # corners in order around the section: (+s,+u), (-s,+u), (-s,-u), (+s,-u)
        sgn = [(1, 1), (-1, 1), (-1, -1), (1, -1)]
        ring = np.stack([ctr + a * w * sv + b * h * uv for a, b in sgn], axis=1)  # (n+1, 4, 3)
        tris = []
        for k in range(4):
            k1 = (k + 1) % 4
            a, b = ring[:-1, k], ring[:-1, k1]
            c, d = ring[1:, k1], ring[1:, k]
            tris += [np.stack([a, b, c], 1), np.stack([a, c, d], 1)]
        for e in (0, -1):
            r = ring[e]
            tris.append(np.stack([r[[0, 1, 2]], r[[0, 2, 3]]]))
        return np.concatenate(tris)

    def to_object(self, instance: int) -> dict[str, Any]:
        """The member's entry of ``scene.objects`` (class ``beam``, its true cuboid)."""
        return {
            "instance": instance,
            "class": "beam",
            "role": self.role,
            "name": self.name,
            "cuboid": {
                "centre": self.centre.tolist(),
                "axis": self.axis.tolist(),
                "up": self.up.tolist(),
                "side": self.side.tolist(),
                "length": float(self.length),
                "width": float(self.width),
                "height": float(self.height),
            },
            "deflection_m": float(self.deflection_m),
            "twist_deg": float(self.twist_deg),
        }


def member_between(
    name: str,
    role: str,
    a: ArrayLike,
    b: ArrayLike,
    width: float,
    height: float,
    up_hint: ArrayLike,
    group: int = -1,
) -> Member:
    """Member whose centre line runs from ``a`` to ``b``; ``up`` from ``up_hint`` (upwards)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    axis = b - a
    length = float(np.linalg.norm(axis))
    axis = axis / length
    up = np.asarray(up_hint, float)
    up = up - (up @ axis) * axis
    up = up / np.linalg.norm(up)
    if up[2] < -1e-9:
        up = -up
    return Member(
        name, role, 0.5 * (a + b), axis, up, length, float(width), float(height), group=group
    )


def in_plane(
    name: str, role: str, a: ArrayLike, b: ArrayLike, width: float, height: float, group: int = -1
) -> Member:
    """A member of a truss plane (``x = const``): its width runs along ``x``."""
    axis = np.asarray(b, float) - np.asarray(a, float)
    return member_between(name, role, a, b, width, height, np.cross(X, axis), group)


# ----------------------------------------------------------------------------- levels
@dataclass(frozen=True)
class RoofLevels:
    """Heights and planes of one roof (see the module docstring)."""

    frame_type: str
    half: float
    wall_t: float
    z_w: float
    length: float
    pitch_deg: float
    sections: dict[str, tuple[float, float]]
    plate_inset: float
    overhang: float
    boarding_t: float
    has_ridge: bool
    has_commons: bool = True
    bird: float = 0.01

    @property
    def tan(self) -> float:
        return float(np.tan(np.radians(self.pitch_deg)))

    @property
    def cos(self) -> float:
        return float(np.cos(np.radians(self.pitch_deg)))

    @property
    def sin(self) -> float:
        return float(np.sin(np.radians(self.pitch_deg)))

    @property
    def z_tt(self) -> float:
        """Top of the tie beams (and of the built-up wall head)."""
        return self.z_w + self.sections["tie"][1]

    @property
    def z_pt(self) -> float:
        """Top of the wall plates."""
        return self.z_tt + self.sections["plate"][1]

    @property
    def y_plate(self) -> float:
        """``|y|`` of the wall plates' centre lines."""
        return self.half + self.wall_t - self.sections["plate"][0] / 2 - self.plate_inset

    @property
    def eta_eave(self) -> float:
        """``|y|`` of the eaves (lower end of the common rafters and boarding)."""
        return self.half + self.wall_t + self.overhang

    def bottom(self, eta: ArrayLike) -> Array:
        """Height of the common rafters' bottom face at ``eta``."""
        return self.z_pt - self.bird + (self.y_plate - np.asarray(eta, float)) * self.tan

    def underside(self, eta: ArrayLike) -> Array:
        """Height of the boarding's underside (common rafters' or purlins' top) at ``eta``."""
        h_c = self.sections["common_rafter"][1] if self.has_commons else 0.0
        return self.bottom(eta) + h_c / self.cos

    def normal(self, sgn: float) -> Array:
        """Upward unit normal of the roof plane on side ``sgn`` (+1: ``y > 0``)."""
        return np.array([0.0, sgn * self.sin, self.cos])

    def upslope(self, sgn: float) -> Array:
        """Unit vector up the slope on side ``sgn``."""
        return np.array([0.0, -sgn * self.cos, self.sin])

    def eta_at(self, top_of_line: float, z: float) -> float:
        """``eta`` where a line ``z = top_of_line - eta tan`` reaches height ``z``."""
        return (top_of_line - z) / self.tan

    @property
    def ridge_top(self) -> float:
        """Top of the ridge: flush with the common rafters' upper ends."""
        w = self.sections["ridge"][0]
        return float(self.underside(w / 2)) if self.has_ridge else float(self.underside(0.0))

    @property
    def eta_top_common(self) -> float:
        """``eta`` of the common rafters' upper ends (ridge face, or past the apex)."""
        return self.sections["ridge"][0] / 2 if self.has_ridge else -0.03


def draw_sections(
    rng: np.random.Generator, scale: float, frame_type: str
) -> dict[str, tuple[float, float]]:
    """Width and height per role, metres (``SECTION_RANGES`` x ``scale``, kept in 8-35 cm)."""
    out: dict[str, tuple[float, float]] = {}
    for role, ((w0, w1), (h0, h1)) in SECTION_RANGES.items():
        w = float(np.clip(rng.uniform(w0, w1) * scale, SECTION_MIN_M, SECTION_MAX_M))
        h = float(np.clip(rng.uniform(h0, h1) * scale, SECTION_MIN_M, SECTION_MAX_M))
        out[role] = (round(w, 3), round(h, 3))
    if rng.random() < 0.5:  # king / queen posts as thick as the tie: coplanar faces
        out["post"] = (out["tie"][0], out["post"][1])
    out["strut"] = (min(out["strut"][0], out["rafter"][0]), out["strut"][1])
    # braces no wider than the posts they are tenoned into
    out["brace"] = (min(out["brace"][0], out["post"][1]), out["brace"][1])
    if frame_type in ("collar", "simple_rafter"):
        # tied rafters: top flush with the commons, deep enough to take the wind braces
        wc, hc = out["common_rafter"]
        hb = out["brace"][1]
        out["rafter"] = (
            max(wc, out["rafter"][0] * 0.8),
            round(min(SECTION_MAX_M, hc + hb + rng.uniform(0.0, 0.04)), 3),
        )
        out["collar"] = (min(out["collar"][0], wc + 0.04), out["collar"][1])
    return out


# ----------------------------------------------------------------------------- trusses
def _principal_line(lv: RoofLevels) -> tuple[float, float]:
    """Top of the principal rafters' centre line at eta = 0, and the foot's eta."""
    h_pu = lv.sections["purlin"][1]
    h_r = lv.sections["rafter"][1]
    c0 = float(lv.bottom(0.0)) - (h_pu + h_r / 2) / lv.cos
    return c0, lv.eta_at(c0, lv.z_tt)


def _tie(lv: RoofLevels, x: float, name: str, eta_foot: float, group: int = -1) -> Member:
    w, h = lv.sections["tie"]
    y_end = max(lv.half + lv.wall_t - 0.05, eta_foot + 0.2)
    zc = lv.z_w + h / 2
    return member_between(name, "tie", [x, -y_end, zc], [x, y_end, zc], w, h, Z, group)


def king_post_truss(lv: RoofLevels, x: float, i: int, rng: np.random.Generator) -> list[Member]:
    """Tie, two principal rafters, king post (carrying the ridge), two struts."""
    s = lv.sections
    w_r, h_r = s["rafter"]
    w_kp, h_kp = s["post"]
    c0, eta_f = _principal_line(lv)
    out = [_tie(lv, x, f"tie{i}", eta_f)]
    kp_top = lv.ridge_top - s["ridge"][1]
    out.append(
        in_plane(f"king_post{i}", "post", [x, 0, lv.z_tt - 0.02], [x, 0, kp_top], w_kp, h_kp)
    )
    eta_head = h_kp / 2 - 0.02
    frac = rng.uniform(0.38, 0.55)
    z_low = lv.z_tt + rng.uniform(0.25, 0.45)
    for side, sgn in (("l", -1.0), ("r", 1.0)):
        foot = [x, sgn * eta_f, lv.z_tt]
        head = [x, sgn * eta_head, c0 - eta_head * lv.tan]
        out.append(in_plane(f"rafter{i}{side}", "rafter", foot, head, w_r, h_r))
        eta_s = frac * eta_f
        z_top = c0 - eta_s * lv.tan - h_r / (2 * lv.cos) + 0.03
        if z_top - z_low > 0.6:
            out.append(
                in_plane(
                    f"strut{i}{side}",
                    "strut",
                    [x, sgn * (h_kp / 2 - 0.02), z_low],
                    [x, sgn * eta_s, z_top],
                    *s["strut"],
                )
            )
    return out


def queen_post_truss(
    lv: RoofLevels, x: float, i: int, rng: np.random.Generator, q: float
) -> list[Member]:
    """Tie, two principal rafters, two queen posts, straining beam, two struts."""
    s = lv.sections
    w_r, h_r = s["rafter"]
    w_qp, h_qp = s["post"]
    c0, eta_f = _principal_line(lv)
    out = [_tie(lv, x, f"tie{i}", eta_f)]
    z_q = c0 - q * lv.tan  # rafter centre line over the queen posts
    sb_top = z_q - h_r / (2 * lv.cos) - 0.03
    w_sb, h_sb = s["collar"]
    out.append(
        in_plane(
            f"straining_beam{i}",
            "collar",
            [x, -(q - h_qp / 2 + 0.02), sb_top - h_sb / 2],
            [x, q - h_qp / 2 + 0.02, sb_top - h_sb / 2],
            w_sb,
            h_sb,
        )
    )
    frac = rng.uniform(0.4, 0.6)
    z_low = lv.z_tt + rng.uniform(0.25, 0.4)
    for side, sgn in (("l", -1.0), ("r", 1.0)):
        out.append(
            in_plane(
                f"rafter{i}{side}",
                "rafter",
                [x, sgn * eta_f, lv.z_tt],
                [x, -sgn * 0.04, c0 + 0.04 * lv.tan],
                w_r,
                h_r,
            )
        )
        out.append(
            in_plane(
                f"queen_post{i}{side}",
                "post",
                [x, sgn * q, lv.z_tt - 0.02],
                [x, sgn * q, z_q],
                w_qp,
                h_qp,
            )
        )
        eta_s = q + frac * (eta_f - q)
        z_top = c0 - eta_s * lv.tan - h_r / (2 * lv.cos) + 0.03
        if z_top - z_low > 0.6:
            out.append(
                in_plane(
                    f"strut{i}{side}",
                    "strut",
                    [x, sgn * (q + h_qp / 2 - 0.02), z_low],
                    [x, sgn * eta_s, z_top],
                    *s["strut"],
                )
            )
    return out


def couple(
    lv: RoofLevels, x: float, j: int, tied: bool, with_collar: bool, collar_frac: float
) -> list[Member]:
    """A pair of rafters (tied couples: principal rafters and a tie beam), maybe a collar."""
    s = lv.sections
    role = "rafter" if tied else "common_rafter"
    w, h = s[role]
    top0 = float(lv.underside(0.0)) - h / (2 * lv.cos)  # centre line at eta = 0
    eta_low = lv.eta_at(top0, lv.z_tt) if tied else lv.eta_eave
    eta_high = lv.eta_top_common
    out: list[Member] = []
    if tied:
        out.append(_tie(lv, x, f"tie_c{j}", eta_low, group=j))
    for side, sgn in (("l", -1.0), ("r", 1.0)):
        out.append(
            in_plane(
                f"{role}_c{j}{side}",
                role,
                [x, sgn * eta_low, top0 - eta_low * lv.tan],
                [x, sgn * eta_high, top0 - eta_high * lv.tan],
                w,
                h,
                group=j,
            )
        )
    if with_collar:
        w_co, h_co = s["collar"]
        z_co = lv.z_tt + collar_frac * (top0 - lv.z_tt)
        eta_co = lv.eta_at(top0, z_co)
        out.append(
            in_plane(
                f"collar_c{j}", "collar", [x, -eta_co, z_co], [x, eta_co, z_co], w_co, h_co, group=j
            )
        )
    return out


# ----------------------------------------------------------------------------- longitudinals
def plates(lv: RoofLevels) -> list[Member]:
    """The two wall plates on the built-up wall heads, gable to gable."""
    w, h = lv.sections["plate"]
    zc = lv.z_tt + h / 2
    return [
        member_between(
            f"plate_{side}",
            "plate",
            [0.0, sgn * lv.y_plate, zc],
            [lv.length, sgn * lv.y_plate, zc],
            w,
            h,
            Z,
        )
        for side, sgn in (("l", -1.0), ("r", 1.0))
    ]


def ridge(lv: RoofLevels) -> Member:
    """The ridge, its top flush with the common rafters' heads."""
    w, h = lv.sections["ridge"]
    zc = lv.ridge_top - h / 2
    return member_between("ridge", "ridge", [0.0, 0.0, zc], [lv.length, 0.0, zc], w, h, Z)


def purlins(lv: RoofLevels, etas: list[float]) -> list[Member]:
    """Purlins on the principal rafters' backs at the given ``eta`` (both sides)."""
    w, h = lv.sections["purlin"]
    h_r = lv.sections["rafter"][1]
    c0, _ = _principal_line(lv)
    p0 = c0 + h_r / (2 * lv.cos)  # principal rafters' top face at eta = 0
    out = []
    for k, eta in enumerate(etas):
        for side, sgn in (("l", -1.0), ("r", 1.0)):
            n = lv.normal(sgn)
            c = np.array([0.0, sgn * eta, p0 - eta * lv.tan]) + n * h / 2
            out.append(member_between(f"purlin{k}{side}", "purlin", c, c + lv.length * X, w, h, n))
    return out


def commons(lv: RoofLevels, xs: Array, start: int) -> list[Member]:
    """Common rafters on the purlins, from the eaves to the ridge (each its own group)."""
    w, h = lv.sections["common_rafter"]
    top0 = float(lv.underside(0.0)) - h / (2 * lv.cos)
    e0, e1 = lv.eta_eave, lv.eta_top_common
    out = []
    for j, x in enumerate(xs):
        for side, sgn in (("l", -1.0), ("r", 1.0)):
            out.append(
                in_plane(
                    f"common_rafter{j}{side}",
                    "common_rafter",
                    [x, sgn * e0, top0 - e0 * lv.tan],
                    [x, sgn * e1, top0 - e1 * lv.tan],
                    w,
                    h,
                    group=start + 2 * j + int(sgn > 0),
                )
            )
    return out


def post_braces(
    lv: RoofLevels, posts: list[Member], i: str, z_range: tuple[float, float]
) -> list[Member]:
    """Two braces crossing in X (halved) between two posts in the same plane ``y``."""
    a, b = posts
    w, h = lv.sections["brace"]
    y = a.centre[1]
    xa = a.centre[0] + a.width / 2 - 0.02
    xb = b.centre[0] - b.width / 2 + 0.02
    lo, hi = z_range
    return [
        member_between(f"brace{i}a", "brace", [xa, y, lo], [xb, y, hi], w, h, Z),
        member_between(f"brace{i}b", "brace", [xa, y, hi], [xb, y, lo], w, h, Z),
    ]


def slope_braces(
    lv: RoofLevels, xa: float, xb: float, sgn: float, i: int, eta_range: tuple[float, float]
) -> list[Member]:
    """Two wind braces crossing in X under the rafters of one slope, between tied couples."""
    w, h = lv.sections["brace"]
    n = lv.normal(sgn)
    e_lo, e_hi = eta_range  # e_lo > e_hi: lower on the slope = larger eta

    def pt(x: float, eta: float) -> Array:
        return np.array([x, sgn * eta, float(lv.bottom(eta))]) - n * h / 2

    side = "l" if sgn < 0 else "r"
    return [
        member_between(f"wind_brace{i}{side}a", "brace", pt(xa, e_lo), pt(xb, e_hi), w, h, n),
        member_between(f"wind_brace{i}{side}b", "brace", pt(xa, e_hi), pt(xb, e_lo), w, h, n),
    ]


# ----------------------------------------------------------------------------- the frame
def build_frame(
    lv: RoofLevels,
    rng: np.random.Generator,
    *,
    truss_spacing: float,
    rafter_spacing: float,
    n_purlins: int,
    brace_share: float,
) -> tuple[list[Member], dict[str, Any]]:
    """All members of the roof, and a description (truss positions, counts).

    Parameters
    ----------
    lv
        Levels and sections.
    rng
        Geometry generator (strut angles, brace bays, collar heights).
    truss_spacing
        Distance between principal trusses (king / queen post) or tied
        couples (couple roofs, rounded to a whole number of couples), metres.
    rafter_spacing
        Distance between common rafters / couples, metres.
    n_purlins
        Purlins per side (king / queen post roofs).
    brace_share
        Share of bays (and slopes) with X braces (at least one).
    """
    L = lv.length
    if not lv.has_commons:
        n_purlins = 2  # boards span from purlin to purlin
    members: list[Member] = []
    info: dict[str, Any] = {}
    if lv.frame_type in ("king_post", "queen_post"):
        n_tr = max(2, int(np.floor((L - 1.2) / truss_spacing)) + 1)
        n_tr = min(n_tr, max(2, int(np.floor(L / 1.2))))
        spacing = min(truss_spacing, (L - 1.2) / (n_tr - 1))
        x_tr = L / 2 + (np.arange(n_tr) - (n_tr - 1) / 2) * spacing
        _, eta_f = _principal_line(lv)
        q = rng.uniform(0.3, 0.45) * eta_f
        posts_by_plane: dict[float, list[Member]] = {}
        for i, x in enumerate(x_tr):
            if lv.frame_type == "king_post":
                tr = king_post_truss(lv, float(x), i, rng)
            else:
                tr = queen_post_truss(lv, float(x), i, rng, q)
            members += tr
            for m in tr:
                if m.role == "post":
                    posts_by_plane.setdefault(round(float(m.centre[1]), 3), []).append(m)
        if lv.frame_type == "king_post":
            etas = [0.5 * eta_f] if n_purlins == 1 else [0.36 * eta_f, 0.7 * eta_f]
        else:
            etas = [q] if n_purlins == 1 else [q, q + 0.5 * (eta_f - q)]
        members += purlins(lv, etas)
        members.append(ridge(lv))
        # common rafters between the trusses
        w_c = lv.sections["common_rafter"][0]
        keep_off = lv.sections["rafter"][0] / 2 + w_c / 2 + 0.05
        n_c = int(np.floor((L - w_c - 0.1) / rafter_spacing)) + 1
        xc = L / 2 + (np.arange(n_c) - (n_c - 1) / 2) * rafter_spacing
        xc = xc[np.min(np.abs(xc[:, None] - x_tr[None]), axis=1) > keep_off]
        if not lv.has_commons:  # boarding laid on the purlins
            xc = xc[:0]
        members += commons(lv, xc, start=1000)
        # X braces between the posts, in some bays
        bays = _pick(rng, n_tr - 1, brace_share)
        for plane_posts in posts_by_plane.values():
            plane_posts.sort(key=lambda m: m.centre[0])
            for b in bays:
                a, c = plane_posts[b], plane_posts[b + 1]
                if lv.frame_type == "king_post":
                    hi = a.centre[2] + a.length / 2 - 0.3
                else:
                    sb = next(m for m in members if m.name == f"straining_beam{b}")
                    hi = sb.centre[2] - sb.height / 2 - 0.12
                lo = lv.z_tt + 0.3 + lv.sections["brace"][1]
                if hi - lo > 0.6:
                    tag = (
                        f"{b}"
                        if lv.frame_type == "king_post"
                        else f"{b}{'l' if a.centre[1] < 0 else 'r'}"
                    )
                    members += post_braces(lv, [a, c], tag, (lo, hi))
        info.update(
            n_trusses=int(n_tr),
            truss_x_m=[float(v) for v in x_tr],
            n_common_rafters=int(2 * len(xc)),
            purlin_eta_m=[float(e) for e in etas],
        )
    else:
        tie_every = max(2, round(truss_spacing / rafter_spacing))
        n_c = int(np.floor((L - 0.3) / rafter_spacing)) + 1
        xc = L / 2 + (np.arange(n_c) - (n_c - 1) / 2) * rafter_spacing
        offset = int(rng.integers(0, tie_every))
        tied = [(j - offset) % tie_every == 0 for j in range(n_c)]
        if sum(tied) < 2:
            tied = [j in (0, n_c - 1) for j in range(n_c)]
        collar_frac = rng.uniform(0.5, 0.72)
        for j, x in enumerate(xc):
            members += couple(lv, float(x), j, tied[j], lv.frame_type == "collar", collar_frac)
        if lv.has_ridge:
            members.append(ridge(lv))
        members += plates(lv)
        # wind braces under the rafters between consecutive tied couples
        xt = [float(x) for x, t in zip(xc, tied, strict=True) if t]
        w_r = lv.sections["rafter"][0]
        top0 = float(lv.underside(0.0))
        e_low = lv.y_plate - 0.25
        z_lim = lv.z_tt + (collar_frac - 0.08) * (top0 - lv.z_tt)
        e_high = max(lv.eta_at(top0, z_lim), 0.35 * e_low)
        k = 0
        for side_sgn in (-1.0, 1.0):
            for b in _pick(rng, len(xt) - 1, brace_share):
                if e_low - e_high > 0.5:
                    members += slope_braces(
                        lv,
                        xt[b] + w_r / 2 - 0.02,
                        xt[b + 1] - w_r / 2 + 0.02,
                        side_sgn,
                        k,
                        (e_low, e_high),
                    )
                    k += 1
        info.update(
            n_couples=int(n_c),
            tie_every=int(tie_every),
            n_tied=int(sum(tied)),
            truss_x_m=xt,
            collar_frac=float(collar_frac),
        )
    if lv.frame_type in ("king_post", "queen_post"):
        members += plates(lv)
    return members, info


def _pick(rng: np.random.Generator, n: int, share: float) -> list[int]:
    """At least one of ``n`` bays, each kept with probability ``share``."""
    if n <= 0:
        return []
    keep = [b for b in range(n) if rng.random() < share]
    return keep or [int(rng.integers(0, n))]


def deform(
    members: list[Member], rng: np.random.Generator, bent_share: float, twisted_share: float
) -> list[Member]:
    """Bend (5-30 mm sag) or twist (1-4 degrees) a share of the members (not the plates)."""
    out = []
    for m in members:
        u = rng.random()
        d, tw = rng.uniform(0.005, 0.03), rng.uniform(1.0, 4.0) * rng.choice([-1.0, 1.0])
        if m.role != "plate" and m.length > 1.0 and u < bent_share:
            m = replace(m, deflection_m=float(round(d, 4)))
        elif m.role != "plate" and u < bent_share + twisted_share:
            m = replace(m, twist_deg=float(round(tw, 2)))
        out.append(m)
    return out
