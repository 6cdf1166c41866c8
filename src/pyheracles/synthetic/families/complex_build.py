"""Surfaces of a walled complex: terrain, buildings, pavilions, walls, gates, trees, clutter.

The shapes of the ``complex`` family (:mod:`pyheracles.synthetic.families.complex`)
and of the demo complex (:mod:`pyheracles.synthetic.complex_scene`), written
into a :class:`~pyheracles.synthetic.scene.Scene`.  Each shape is built in its
own plan frame (a :class:`Placement`: rotation about z and a translation), so
that rectangles, ridges and column grids stay axis-aligned in the code while
the complex takes any orientation.  Heights come from a terrain function
``ground(x, y)`` in the scene frame.

Tree crowns are clouds of small leaf triangles inside an ellipsoid
(:data:`~pyheracles.synthetic.scene.FOLIAGE`: an airborne pulse records a
return on each and goes on), mixed with a share of opaque twigs that stop
the pulse; that share sets the probability that a pulse reaches the ground
under the crown (:func:`add_crown`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from pyheracles.synthetic.scanner import AirborneSurvey
from pyheracles.synthetic.scene import FOLIAGE, GROUND, TIMBER, Material, Scene

__all__ = [
    "GroundFn",
    "Placement",
    "add_column_grid",
    "add_crown",
    "add_prism",
    "add_roof",
    "add_terrain",
    "add_trunk",
    "add_wall_line",
    "band",
    "fan",
    "plan_strips",
    "quads",
    "rect_ring",
    "ring_ground",
    "with_z",
]

Array = NDArray[np.float64]
#: Terrain height in the scene frame: ``ground(x, y) -> z``, metres.
GroundFn = Callable[[Array, Array], Array]

ROOF_STYLES = ("hipped", "gabled", "flat", "pyramid", "joglo")


# ----------------------------------------------------------------------------- triangles
def with_z(ring_xy: ArrayLike, z: float | ArrayLike) -> Array:
    """``(n, 2)`` plan points with heights ``z`` (a number or one per point)."""
    ring_xy = np.asarray(ring_xy, dtype=np.float64)
    zz = np.broadcast_to(np.asarray(z, dtype=np.float64), (len(ring_xy),))
    return np.column_stack([ring_xy, zz])


def band(lo: Array, hi: Array, *, closed: bool = True) -> Array:
    """Triangles joining two rings (or open polylines) of equal length."""
    lo1 = np.roll(lo, -1, axis=0)
    hi1 = np.roll(hi, -1, axis=0)
    t1 = np.stack([lo, lo1, hi1], axis=1)
    t2 = np.stack([lo, hi1, hi], axis=1)
    if not closed:
        t1, t2 = t1[:-1], t2[:-1]
    return np.concatenate([t1, t2])


def fan(ring: Array) -> Array:
    """Triangles of a convex planar ring."""
    n = len(ring)
    i = np.arange(1, n - 1)
    return np.stack([np.repeat(ring[:1], n - 2, axis=0), ring[i], ring[i + 1]], axis=1)


def quads(q: Array) -> Array:
    """Split ``(n, 4, 3)`` quads into ``(2n, 3, 3)`` triangles."""
    return np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])


def rect_ring(x0: float, y0: float, x1: float, y1: float) -> Array:
    """Counter-clockwise corners of an axis-aligned rectangle, ``(4, 2)``."""
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float64)


# ----------------------------------------------------------------------------- frames
@dataclass(frozen=True)
class Placement:
    """A plan frame: local ``(u, v)`` -> scene ``(x, y)`` by a rotation and a translation.

    Attributes
    ----------
    angle_deg
        Rotation of the local u axis from the scene x axis, degrees.
    origin
        Scene position of the local origin, metres.
    """

    angle_deg: float = 0.0
    origin: tuple[float, float] = (0.0, 0.0)

    @property
    def rotation(self) -> Array:
        """``(2, 2)`` rotation matrix (columns: local axes in the scene)."""
        a = np.deg2rad(self.angle_deg)
        return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])

    def xy(self, uv: ArrayLike) -> Array:
        """Local plan points to scene plan points."""
        uv = np.asarray(uv, dtype=np.float64)
        return uv @ self.rotation.T + np.asarray(self.origin)

    def local(self, xy: ArrayLike) -> Array:
        """Scene plan points to local plan points."""
        xy = np.asarray(xy, dtype=np.float64)
        return (xy - np.asarray(self.origin)) @ self.rotation

    def then(self, inner: Placement) -> Placement:
        """The placement of a frame given by ``inner`` inside this one."""
        return Placement(self.angle_deg + inner.angle_deg, tuple(self.xy(inner.origin)))

    def tris(self, tris: Array) -> Array:
        """Triangles ``(T, 3, 3)`` from the local frame to the scene frame."""
        out = np.array(tris, dtype=np.float64)
        out[..., :2] = self.xy(out[..., :2].reshape(-1, 2)).reshape(out.shape[:-1] + (2,))
        return out

    def geometry(self, geom: Any) -> Any:
        """A shapely geometry from the local frame to the scene frame."""
        return shapely.transform(geom, self.xy)


def ring_ground(ground: GroundFn, place: Placement, ring: Array) -> tuple[float, float, float]:
    """Lowest, central and highest terrain under a local ring (its corners and centre)."""
    pts = place.xy(np.vstack([ring, ring.mean(axis=0, keepdims=True)]))
    z = ground(pts[:, 0], pts[:, 1])
    return float(z.min()), float(z[-1]), float(z.max())


# ----------------------------------------------------------------------------- solids
def add_prism(
    scene: Scene,
    place: Placement,
    ring: Array,
    z_bottom: float | Array,
    z_top: float | Array,
    *,
    top: bool = True,
    scale_top: float = 1.0,
    top_part: str | None = None,
    **ref: Any,
) -> None:
    """Vertical (or tapered) sides of a convex local ring, optionally with its top."""
    c = ring.mean(axis=0)
    ring_top = c + (ring - c) * scale_top
    scene.add_triangles(place.tris(band(with_z(ring, z_bottom), with_z(ring_top, z_top))), **ref)
    if top:
        top_ref = dict(ref, part=top_part or ref.get("part", "none"))
        zt = np.broadcast_to(np.asarray(z_top, float), (len(ring),))
        scene.add_triangles(place.tris(fan(with_z(ring_top, zt))), **top_ref)


def ridge_ring(rect: Array, shrink: float) -> Array:
    """Inner ring of a hipped roof over an axis-aligned rectangle.

    ``shrink`` = 0 gives the ridge (a degenerate ring along the longer side);
    ``shrink`` > 0 a smaller rectangle (the base of an upper roof tier).
    """
    (x0, y0), (x1, y1) = rect[0], rect[2]
    cx, cy, a, b = (x0 + x1) / 2, (y0 + y1) / 2, (x1 - x0) / 2, (y1 - y0) / 2
    if shrink > 0:
        return rect_ring(cx - a * shrink, cy - b * shrink, cx + a * shrink, cy + b * shrink)
    if a >= b:
        r = a - b
        return np.array([[cx - r, cy], [cx + r, cy], [cx + r, cy], [cx - r, cy]])
    r = b - a
    return np.array([[cx, cy - r], [cx, cy - r], [cx, cy + r], [cx, cy + r]])


def half_min_side(rect: Array) -> float:
    """Half the shorter side of a ring's bounding box (a hipped roof's rise scale), metres."""
    span = rect.max(axis=0) - rect.min(axis=0)
    return float(span.min() / 2)


def add_roof(
    scene: Scene,
    place: Placement,
    rect: Array,
    z_eave: float,
    style: str,
    *,
    pitch_deg: float = 35.0,
    wall_rect: Array | None = None,
    parapet_m: float = 0.0,
    **ref: Any,
) -> float:
    """A roof over an axis-aligned local rectangle; returns the height of its top.

    Parameters
    ----------
    style
        ``hipped`` (ridge along the longer side; a pyramid over a square),
        ``pyramid`` (same surfaces), ``gabled`` (two slopes, triangular
        gables on ``wall_rect``), ``flat`` (a slab, with a parapet of
        ``parapet_m``) or ``joglo`` (a shallow lower tier and a steep upper
        hipped roof).
    pitch_deg
        Slope of the roof planes (the lower tier for ``joglo``).
    wall_rect
        The walls under the roof (gables stand on it); defaults to ``rect``.
    """
    half = half_min_side(rect)
    slope = np.tan(np.deg2rad(pitch_deg))
    roof_ref = dict(ref, part=ref.get("part", "roof"))
    if style in ("hipped", "pyramid"):
        z_top = z_eave + slope * half
        scene.add_triangles(
            place.tris(band(with_z(rect, z_eave), with_z(ridge_ring(rect, 0.0), z_top))), **roof_ref
        )
        return z_top
    if style == "joglo":
        mid = ridge_ring(rect, 0.5)
        z_mid = z_eave + 0.5 * half * slope * 0.8
        scene.add_triangles(place.tris(band(with_z(rect, z_eave), with_z(mid, z_mid))), **roof_ref)
        z_top = z_mid + 1.25 * half_min_side(mid) * max(slope, 1.0)
        scene.add_triangles(
            place.tris(band(with_z(mid, z_mid), with_z(ridge_ring(mid, 0.0), z_top))), **roof_ref
        )
        return z_top
    if style == "flat":
        scene.add_triangles(place.tris(fan(with_z(rect, z_eave))), **roof_ref)
        if parapet_m <= 0:
            return z_eave
        (x0, y0), (x1, y1) = rect[0], rect[2]
        t = min(0.25, 0.2 * half)
        inner = rect_ring(x0 + t, y0 + t, x1 - t, y1 - t)
        zp = z_eave + parapet_m
        par = dict(ref, part="parapet")
        scene.add_triangles(place.tris(band(with_z(rect, z_eave), with_z(rect, zp))), **par)
        scene.add_triangles(place.tris(band(with_z(inner, z_eave), with_z(inner, zp))), **par)
        scene.add_triangles(place.tris(band(with_z(rect, zp), with_z(inner, zp))), **par)
        return zp
    if style == "gabled":
        (x0, y0), (x1, y1) = rect[0], rect[2]
        along_x = (x1 - x0) >= (y1 - y0)
        z_top = z_eave + slope * half
        if along_x:
            cy = (y0 + y1) / 2
            q = np.array(
                [
                    [[x0, y0, z_eave], [x1, y0, z_eave], [x1, cy, z_top], [x0, cy, z_top]],
                    [[x0, y1, z_eave], [x1, y1, z_eave], [x1, cy, z_top], [x0, cy, z_top]],
                ]
            )
        else:
            cx = (x0 + x1) / 2
            q = np.array(
                [
                    [[x0, y0, z_eave], [x0, y1, z_eave], [cx, y1, z_top], [cx, y0, z_top]],
                    [[x1, y0, z_eave], [x1, y1, z_eave], [cx, y1, z_top], [cx, y0, z_top]],
                ]
            )
        scene.add_triangles(place.tris(quads(q)), **roof_ref)
        w = rect if wall_rect is None else wall_rect
        (a0, b0), (a1, b1) = w[0], w[2]
        if along_x:  # gable triangles on the short walls, up to the roof plane
            g = np.array(
                [[[x, b0, z_eave], [x, b1, z_eave], [x, (b0 + b1) / 2, z_top]] for x in (a0, a1)]
            )
        else:
            g = np.array(
                [[[a0, y, z_eave], [a1, y, z_eave], [(a0 + a1) / 2, y, z_top]] for y in (b0, b1)]
            )
        scene.add_triangles(place.tris(g), **dict(ref, part="gable"))
        return z_top
    raise ValueError(f"unknown roof style {style!r}; choose one of {', '.join(ROOF_STYLES)}")


def add_column_grid(
    scene: Scene,
    place: Placement,
    rect: Array,
    z_bottom: float,
    z_top: float,
    *,
    spacing_m: float = 2.5,
    radius_m: float = 0.15,
    inner: bool = False,
    **ref: Any,
) -> int:
    """Octagonal columns on the edge of a local rectangle (and 4 inner ones); returns the count."""
    (x0, y0), (x1, y1) = rect[0], rect[2]
    nx = max(2, round((x1 - x0) / spacing_m) + 1)
    ny = max(2, round((y1 - y0) / spacing_m) + 1)
    gx, gy = np.meshgrid(np.linspace(x0, x1, nx), np.linspace(y0, y1, ny))
    edge = (gx == x0) | (gx == x1) | (gy == y0) | (gy == y1)
    pts = np.column_stack([gx[edge], gy[edge]])
    if inner and nx >= 4 and ny >= 4:
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        dx, dy = (x1 - x0) / 6, (y1 - y0) / 6
        pts = np.vstack([pts, [[cx - dx, cy - dy], [cx + dx, cy - dy],
                               [cx + dx, cy + dy], [cx - dx, cy + dy]]])  # fmt: skip
    ang = np.arange(8) * np.pi / 4
    octagon = radius_m * np.column_stack([np.cos(ang), np.sin(ang)])
    cols = [band(with_z(octagon + p, z_bottom), with_z(octagon + p, z_top)) for p in pts]
    scene.add_triangles(place.tris(np.concatenate(cols)), **ref)
    return len(pts)


def add_wall_line(
    scene: Scene,
    place: Placement,
    line: Array,
    thickness_m: float,
    height_m: float,
    ground: GroundFn,
    *,
    bury_m: float = 0.3,
    caps: tuple[bool, bool] = (False, False),
    piece_m: float = 1.5,
    **ref: Any,
) -> None:
    """A wall of constant height above the terrain along a local polyline.

    Both faces and the top follow the terrain in pieces of ``piece_m``; corners
    are closed by extending the legs by half the thickness; end caps where the
    wall ends free (``caps`` at the first / last point), not where it abuts.
    """
    line = np.asarray(line, dtype=np.float64)
    n_legs = len(line) - 1
    for k in range(n_legs):  # a few wall legs, not points
        p, q = line[k].copy(), line[k + 1].copy()
        d = (q - p) / np.linalg.norm(q - p)
        if k > 0:
            p -= d * thickness_m / 2
        if k < n_legs - 1:
            q += d * thickness_m / 2
        n_pieces = max(1, int(np.ceil(np.linalg.norm(q - p) / piece_m)))
        s = np.linspace(0.0, 1.0, n_pieces + 1)[:, None]
        axis = p + s * (q - p)
        nrm = np.array([-d[1], d[0]]) * thickness_m / 2
        w = place.xy(axis)
        zg = ground(w[:, 0], w[:, 1])
        zb, zt = zg - bury_m, zg + height_m
        left, right = axis + nrm, axis - nrm
        tris = []
        for side in (left, right):
            lo, hi = with_z(side, zb), with_z(side, zt)
            tris.append(quads(np.stack([lo[:-1], lo[1:], hi[1:], hi[:-1]], axis=1)))
        tl, tr = with_z(left, zt), with_z(right, zt)
        tris.append(quads(np.stack([tl[:-1], tl[1:], tr[1:], tr[:-1]], axis=1)))
        for i, want in ((0, caps[0] and k == 0), (-1, caps[1] and k == n_legs - 1)):
            if want:
                cap = np.array([[*left[i], zb[i]], [*right[i], zb[i]],
                                [*right[i], zt[i]], [*left[i], zt[i]]])  # fmt: skip
                tris.append(quads(cap[None]))
        scene.add_triangles(place.tris(np.concatenate(tris)), **ref)


# ----------------------------------------------------------------------------- terrain
def add_terrain(
    scene: Scene,
    ground: GroundFn,
    bounds: tuple[float, float, float, float],
    *,
    cell_m: float = 0.5,
    holes: Any = None,
    steep_deg: float = 50.0,
) -> None:
    """The terrain as a height field over ``bounds``, class ``ground``.

    Cells steeper than ``steep_deg`` get the part ``riser`` (terrace edges),
    the others ``terrain``.  Cells whose centre lies in ``holes`` (a shapely
    geometry: open water) are left out, so no pulse returns there.
    """
    x0, y0, x1, y1 = bounds
    x = np.linspace(x0, x1, max(2, int(np.ceil((x1 - x0) / cell_m)) + 1))
    y = np.linspace(y0, y1, max(2, int(np.ceil((y1 - y0) / cell_m)) + 1))
    X, Y = np.meshgrid(x, y)
    P = np.stack([X, Y, ground(X.ravel(), Y.ravel()).reshape(X.shape)], -1)
    a, b, c, d = P[:-1, :-1], P[:-1, 1:], P[1:, 1:], P[1:, :-1]
    keep = np.ones(a.shape[:2], bool)
    if holes is not None and not holes.is_empty:
        cx, cy = (a[..., 0] + c[..., 0]) / 2, (a[..., 1] + c[..., 1]) / 2
        keep = ~shapely.contains_xy(holes, cx, cy)
    tris = np.concatenate([np.stack([a, b, c], -2)[keep], np.stack([a, c, d], -2)[keep]])
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    nz = np.abs(n[:, 2]) / np.maximum(np.linalg.norm(n, axis=1), 1e-12)
    steep = nz < np.cos(np.deg2rad(steep_deg))
    ref = {"instance": 0, "class_name": "ground", "material": GROUND}
    scene.add_triangles(tris[~steep], part="terrain", **ref)
    scene.add_triangles(tris[steep], part="riser", **ref)


# ----------------------------------------------------------------------------- vegetation
def add_crown(
    scene: Scene,
    centre: ArrayLike,
    radius_m: float,
    half_height_m: float,
    rng: np.random.Generator,
    *,
    leaf_area_density: float = 1.0,
    leaf_m: float = 0.5,
    penetration: float = 0.3,
    twig_material: Material = TIMBER,
) -> int:
    """A tree crown: leaf triangles filling an ellipsoid; returns their number.

    Leaves are :data:`FOLIAGE` (porous: an airborne pulse records a return and
    goes on); a share of them are opaque twigs that stop the pulse.  With
    random leaf orientations a vertical path of length ``L`` meets on average
    ``0.5 * leaf_area_density * L`` leaves; the share of twigs is set so that
    a pulse through the crown reaches what lies below with probability about
    ``penetration`` (over the mean vertical chord ``4/3 * half_height_m``).
    Crowns that let few pulses through get up to twice the leaf area density.
    """
    c = np.asarray(centre, dtype=np.float64)
    volume = 4.0 / 3.0 * np.pi * radius_m**2 * half_height_m
    # a crown that lets few pulses through is denser (up to twice the leaves), so that
    # at least about half of its leaves stay porous
    chord = 4.0 / 3.0 * half_height_m
    need = 2.0 * -np.log(max(penetration, 1e-3)) / (0.5 * chord)
    leaf_area_density = float(np.clip(need, leaf_area_density, 2.0 * leaf_area_density))
    leaf_area = np.sqrt(3.0) / 4.0 * leaf_m**2
    n = max(20, int(leaf_area_density * volume / leaf_area))
    # uniform points in the unit ball, scaled to the ellipsoid
    u = rng.normal(size=(n, 3))
    u *= (np.cbrt(rng.random(n)) / np.linalg.norm(u, axis=1))[:, None]
    pos = c + u * np.array([radius_m, radius_m, half_height_m])
    # equilateral leaves of side leaf_m in random planes
    a = rng.normal(size=(n, 3))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = np.cross(a, rng.normal(size=(n, 3)))
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    e = np.cross(a, b)
    r = leaf_m / np.sqrt(3.0)
    ang = rng.uniform(0, 2 * np.pi, n)
    verts = [
        pos + r * (np.cos(ang + k * 2 * np.pi / 3)[:, None] * b
                   + np.sin(ang + k * 2 * np.pi / 3)[:, None] * e)
        for k in range(3)
    ]  # fmt: skip
    tris = np.stack(verts, axis=1)
    hits = 0.5 * leaf_area_density * chord
    twig_share = float(np.clip(-np.log(max(penetration, 1e-3)) / max(hits, 1e-6), 0.0, 1.0))
    twig = rng.random(n) < twig_share
    ref = {"instance": 0, "class_name": "tree"}
    scene.add_triangles(tris[~twig], part="crown", material=FOLIAGE, **ref)
    scene.add_triangles(tris[twig], part="branch", material=twig_material, **ref)
    return n


def add_trunk(
    scene: Scene, base: ArrayLike, height_m: float, radius_m: float = 0.25, bury_m: float = 0.3
) -> None:
    """A tree trunk (an octagonal prism from below the ground to the crown)."""
    ang = np.arange(8) * np.pi / 4
    ring = np.asarray(base, float)[:2] + radius_m * np.column_stack([np.cos(ang), np.sin(ang)])
    z0 = float(np.asarray(base, float)[2])
    scene.add_triangles(
        band(with_z(ring, z0 - bury_m), with_z(ring, z0 + height_m)),
        instance=0, class_name="tree", part="trunk", material=TIMBER,
    )  # fmt: skip


# ----------------------------------------------------------------------------- survey
def plan_strips(
    bounds: tuple[float, float, float, float],
    *,
    density_per_m2: float,
    n_strips: int,
    overlap: float,
    heading_deg: float,
    half_fov_deg: float,
    noise_m: float = 0.03,
    speed_mps: float = 60.0,
    line_ratio: float = 1.0,
) -> tuple[AirborneSurvey, dict[str, float]]:
    """An airborne survey flying ``n_strips`` parallel strips over ``bounds``.

    The swath (hence the flying height for the field of view) is chosen so
    that ``n_strips`` strips with the side ``overlap`` cover the area; the
    pulse density of one strip so that the strips together give about
    ``density_per_m2`` first returns per m^2 on open ground; the scan line rate
    so that the along-track spacing is ``line_ratio`` times the across-track
    spacing.

    Returns
    -------
    survey, plan
        The :class:`AirborneSurvey` and the derived figures (``altitude_m``,
        ``swath_m``, ``strip_density_per_m2``, ``scan_rate_hz``, ``coverage``).
    """
    x0, y0, x1, y1 = bounds
    h = np.deg2rad(heading_deg)
    across = np.array([-np.sin(h), np.cos(h)])
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    c = corners @ across
    width = float(c.max() - c.min())
    swath = width / ((n_strips - 0.5) * (1 - overlap) - 0.2)
    altitude = swath / (2 * np.tan(np.deg2rad(half_fov_deg)))
    # mean number of strips covering a point of the area
    spacing = swath * (1 - overlap)
    centres = (c.min() + c.max()) / 2 + (np.arange(n_strips) - (n_strips - 1) / 2) * spacing
    s = np.linspace(c.min(), c.max(), 401)
    cover = (np.abs(s[:, None] - centres[None, :]) <= swath / 2).sum(axis=1).mean()
    strip_density = density_per_m2 / max(float(cover), 1.0)
    along_spacing = np.sqrt(line_ratio / strip_density)
    scan_rate = speed_mps / along_spacing
    survey = AirborneSurvey(
        bounds=(x0, y0, x1, y1), altitude_m=float(altitude), density_per_m2=float(strip_density),
        half_fov_deg=float(half_fov_deg), overlap=float(overlap), heading_deg=float(heading_deg),
        noise_m=float(noise_m), scan_rate_hz=float(scan_rate), speed_mps=float(speed_mps),
    )  # fmt: skip
    plan = {
        "altitude_m": float(altitude),
        "swath_m": float(swath),
        "strip_density_per_m2": float(strip_density),
        "scan_rate_hz": float(scan_rate),
        "coverage": float(cover),
    }
    return survey, plan
