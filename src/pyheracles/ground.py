"""Ground filtering: an automatic filter, CSF and SMRF; a DTM and heights above ground.

The public face of :mod:`pyheracles.groundfilters`. One call, :func:`extract_ground`,
returns a :class:`GroundResult` whose ``mask`` is aligned with the input points.

Methods
-------
``"auto"``
    Parameters measured on the cloud (point spacing, largest building size), SMRF seeds,
    then a surface refinement whose threshold comes from the measured roughness of the
    ground (:func:`auto_params`, :func:`refine_ground`). The most accurate setting on the
    ISPRS samples and on AHN3 (see ``benchmarks/bench_ground.py``).
``"csf"``
    The Cloth Simulation Filter (Zhang et al. 2016) with :class:`CSFParams`; the
    package defaults, or parameters measured on the cloud with
    ``auto_csf_params(measure_scene(xyz))`` (cloth resolution from the spacing,
    rigidness and threshold from the terrain slope, low outliers kept out of the cloth).
    CSF alone is clearly less accurate than ``"auto"`` on the ISPRS samples (steep slopes,
    discontinuities); it is kept as the thesis's filter and for comparison.
``"smrf"``
    The Simple Morphological Filter (Pingel et al. 2013) with :class:`SMRFParams`.
``"none"``
    No ground (every point is off-ground).

Examples
--------
>>> import numpy as np
>>> from pyheracles.ground import extract_ground
>>> rng = np.random.default_rng(0)
>>> xy = rng.uniform(0, 50, (5000, 2))
>>> roof = (np.abs(xy - 25) < 6).all(axis=1)
>>> xyz = np.c_[xy, np.where(roof, 8.0, 0.0)]
>>> result = extract_ground(xyz, method="smrf")
>>> bool(result.mask[~roof].all()), bool(result.mask[roof].any())
(True, False)
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from pyheracles.errors import InputError
from pyheracles.groundfilters.auto import (
    DEFAULT_MAX_OBJECT_SIZE_M,
    AutoParams,
    SceneMeasures,
    auto_csf_params,
    auto_params,
    measure_scene,
    point_spacing_m,
)
from pyheracles.groundfilters.csf import CSFParams, csf
from pyheracles.groundfilters.refine import RefineParams, refine_ground
from pyheracles.groundfilters.smrf import SMRFParams, smrf
from pyheracles.groundfilters.surface import (
    DTM,
    Grid,
    RasterSampler,
    dtm_from_ground,
    height_above_ground,
    rasterise_cells,
)
from pyheracles.resources import check_grid_memory, check_spread, smallest_cell_m

__all__ = [
    "DEFAULT_MAX_OBJECT_SIZE_M",
    "DTM",
    "GROUND_METHODS",
    "AutoParams",
    "CSFParams",
    "GroundResult",
    "RefineParams",
    "SMRFParams",
    "SceneMeasures",
    "aligned_grid",
    "auto_csf_params",
    "auto_params",
    "dtm_from_ground",
    "extract_ground",
    "height_above_ground",
    "measure_scene",
    "pass_through_of",
    "pass_through_returns",
    "refine_ground",
]

GROUND_METHODS = ("auto", "csf", "smrf", "none")
"""Values accepted by ``extract_ground(method=...)``."""

#: A pass-through return this close to the terrain model (either side) is ground: the
#: refinement's smallest noise threshold (:attr:`RefineParams.min_threshold_m`), metres.
PASS_THROUGH_ON_GROUND_M = RefineParams().min_threshold_m

_CEILING_HEIGHT_M = 2.0
_CEILING_COVER = 0.97

#: Fewest points a ground filter works with (three points span a plane).
MIN_GROUND_POINTS = 3

# Bytes held per raster cell at once, estimated from the arrays each stage allocates:
# SMRF / refinement (minimum surface, openings, slopes, masks: ~8 float64 rasters), a DTM
# (mean surface and its work arrays, the membrane inpainting's sparse system over empty
# cells, the float32 GeoTIFF bands) and a CSF cloth particle (C++ object with positions,
# displacement and neighbour lists).
#: Cell edges lie this far east / north of the multiples of the cell size: LAS coordinates
#: are quantised (often to 1 mm), so many points sit exactly on a multiple of a 1 m cell,
#: and the float64 rounding of ``world - offset`` (about 1e-7 m at 10^9 m) must not move
#: them across an edge from one cloud's offset to another's.
_EDGE_GUARD_M = 1e-6

_FILTER_BYTES_PER_CELL = 64
_DTM_BYTES_PER_CELL = 96
_CLOTH_BYTES_PER_PARTICLE = 200


@dataclass(frozen=True, eq=False)
class GroundResult:
    """Result of :func:`extract_ground`.

    Attributes
    ----------
    mask
        (N,) bool aligned with the input points; True = ground.
    method
        The method that ran: ``"auto"``, ``"csf"``, ``"smrf"`` or ``"none"``.
    params
        The parameters it ran with (:class:`AutoParams`, :class:`CSFParams`,
        :class:`SMRFParams` or None).
    dtm
        Terrain model from the ground points (:class:`DTM`), None when there is no ground
        (``"auto"``: the surface of the last refinement pass, the one the ground was
        tested against; otherwise :func:`dtm_from_ground` of the mask).
    scene
        What the automatic mode measured (:class:`SceneMeasures`), None otherwise.
    note
        Why the result holds no ground (or other caveats), empty when nothing to say.
    """

    mask: NDArray[np.bool_]
    method: str
    params: AutoParams | CSFParams | SMRFParams | None
    dtm: DTM | None
    scene: SceneMeasures | None = None
    note: str = ""

    @property
    def n_ground(self) -> int:
        """Number of ground points."""
        return int(self.mask.sum())

    def counts(self) -> dict[str, int]:
        """``{"ground": ..., "off_ground": ..., "total": ...}``."""
        n = int(self.mask.size)
        return {"ground": self.n_ground, "off_ground": n - self.n_ground, "total": n}


def pass_through_returns(
    return_number: ArrayLike | None, number_of_returns: ArrayLike | None
) -> NDArray[np.bool_] | None:
    """The returns a pulse went on beyond (not its last), from the LAS echo fields.

    ``None`` when either field is missing.  Return number 0 is invalid in LAS: such a
    point says nothing about its pulse and counts as a last return.
    """
    if return_number is None or number_of_returns is None:
        return None
    rn = np.asarray(return_number)
    return (rn >= 1) & (rn < np.asarray(number_of_returns))


def pass_through_of(attributes: Any) -> NDArray[np.bool_] | None:
    """:func:`pass_through_returns` from a cloud's attributes (a LAS's dimensions), or
    ``None`` when it has no echoes."""
    return pass_through_returns(
        attributes.get("return_number"), attributes.get("number_of_returns")
    )


def aligned_grid(xy: NDArray[np.float64], cell_m: float, origin_m: ArrayLike | None = None) -> Grid:
    """The smallest grid holding ``xy`` whose cell edges are world-aligned.

    The edges lie on the multiples of ``cell_m`` in world coordinates (plus
    ``_EDGE_GUARD_M``, 1 µm, so that quantised points exactly on a multiple fall in the
    same cell whatever the offset), so two clouds cut from one survey (tiles, crops) get
    the same cells where they overlap and a tiled run rasterises exactly as the
    single-cloud run.

    Parameters
    ----------
    xy
        (N, 2) points in the local frame, metres.
    cell_m
        Cell size, metres.
    origin_m
        World x, y of the local frame's origin (``PointCloud.offset[:2]``); None = no
        alignment, the grid starts at the points' west and north edges
        (:meth:`Grid.covering`).

    Examples
    --------
    >>> g = aligned_grid(np.array([[0.2, 0.3], [2.7, 1.9]]), 1.0, origin_m=(100.5, 0.0))
    >>> round(g.x0_m + 100.5, 3), round(g.y0_m, 3), g.shape
    (100.0, 2.0, (2, 4))
    """
    if not np.isfinite(cell_m) or cell_m <= 0:
        raise InputError(f"cell size must be a positive number of metres, got {cell_m!r}")
    if origin_m is None:
        return Grid.covering(xy, cell_m)
    c = float(cell_m)
    o = np.asarray(origin_m, dtype=np.float64).ravel()[:2]
    if o.shape != (2,) or not np.isfinite(o).all():
        raise InputError(f"origin_m must be two finite world coordinates, got {origin_m!r}")
    # the origin's remainder on the cell lattice, in [0, c): small local numbers from here on
    r = o - np.floor(o / c) * c - _EDGE_GUARD_M
    lo = np.array([xy[:, 0].min(), xy[:, 1].min()])
    hi = np.array([xy[:, 0].max(), xy[:, 1].max()])
    x0 = float(np.floor((lo[0] + r[0]) / c) * c - r[0])
    y0 = float(np.ceil((hi[1] + r[1]) / c) * c - r[1])
    if y0 < hi[1]:  # exactly on the north edge: one more row keeps the point inside
        y0 += c
    cols = int(np.floor((hi[0] - x0) / c)) + 1
    rows = int(np.floor((y0 - lo[1]) / c)) + 1
    return Grid(x0, y0, c, (rows, cols))


def _check_xyz(xyz: ArrayLike) -> NDArray[np.float64]:
    arr = np.asarray(xyz, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise InputError(f"points must be an (N, 3) array, got shape {arr.shape}")
    if arr.shape[0] == 0:
        raise InputError("the point cloud is empty", hint="check the input file and any crop")
    if not np.isfinite(arr).all():
        raise InputError(
            f"{int((~np.isfinite(arr)).any(axis=1).sum())} points have NaN or infinite coordinates",
            hint="remove them (PointCloud.validate names them) before ground filtering",
        )
    return arr


def _resolve_params(method: str, params: Any, scene: SceneMeasures | None) -> Any:
    if method == "none":
        if params is not None:
            raise InputError("method='none' takes no parameters")
        return None
    expected = {"auto": AutoParams, "csf": CSFParams, "smrf": SMRFParams}[method]
    if params is None:
        return auto_params(scene) if scene is not None else expected()
    if not isinstance(params, expected):
        raise InputError(
            f"method={method!r} needs {expected.__name__} parameters, got {type(params).__name__}",
            hint="pass None for the defaults (measured ones with 'auto')",
        )
    return params


def _surface_note(
    xyz: NDArray[np.float64],
    mask: NDArray[np.bool_],
    cell_m: float,
    sampler: RasterSampler | None = None,
    origin_m: ArrayLike | None = None,
) -> str:
    """Why the ground found is not terrain, or '' when it looks like terrain.

    - line-like ground (wall feet, a single scan line): no ground cell has all eight
      neighbours occupied by ground, so the ground is not a surface;
    - covered ground (a floor under a ceiling): at least 97 % of the ground cells hold a
      point more than 2 m above the ground.
    """
    if sampler is not None and sampler.grid.cell_m == cell_m:
        grid, flat = sampler.grid, sampler.flat
    else:
        grid = aligned_grid(xyz[:, :2], cell_m, origin_m)
        flat = grid.flat_index(xyz[:, :2])
    size = grid.shape[0] * grid.shape[1]
    ground_flat = flat[mask]
    occupied = np.zeros(size, dtype=bool)
    occupied[ground_flat] = True
    occupied = occupied.reshape(grid.shape)
    interior = ndimage.binary_erosion(occupied, structure=np.ones((3, 3), bool))
    if not interior.any():
        return (
            "no ground surface: the lowest points form lines (wall feet, a single scan "
            "line), not an area of terrain"
        )
    low = rasterise_cells(grid, ground_flat, xyz[mask, 2], "min").ravel()
    high = rasterise_cells(grid, flat, xyz[:, 2], "max").ravel()
    ground_cells = occupied.ravel()
    covered = (high - low)[ground_cells] > _CEILING_HEIGHT_M
    if ground_cells.sum() >= 9 and covered.mean() >= _CEILING_COVER:
        return (
            f"no terrain: {100 * covered.mean():.0f} % of the lowest surface lies under points "
            f"more than {_CEILING_HEIGHT_M:g} m above it (a floor under a ceiling: a building "
            "interior)"
        )
    return ""


def _check_rasters(
    span: NDArray[np.float64], used: Any, dtm_cell_m: float | None, source: str | None
) -> None:
    """Refuse before any work a filter grid or DTM too large for the free memory.

    ``span`` is the extent of the points in x and y (metres)."""
    ext = np.asarray(span[:2], dtype=np.float64)
    rasters: list[tuple[float, int, str, str]] = []
    if isinstance(used, AutoParams):
        for cell in sorted({used.seed.cell_m, used.refine.cell_m}):
            rasters.append((cell, _FILTER_BYTES_PER_CELL, "the ground filter's raster",
                            "the cell is measured from the point spacing: check the cloud's "
                            "units, or tile the site"))  # fmt: skip
    elif isinstance(used, SMRFParams):
        rasters.append((used.cell_m, _FILTER_BYTES_PER_CELL, "an SMRF raster",
                        "a coarser cell, in Python: SMRFParams(cell_m={cell}) "
                        "or larger"))  # fmt: skip
    elif isinstance(used, CSFParams):
        rasters.append((used.cloth_resolution_m, _CLOTH_BYTES_PER_PARTICLE, "a CSF cloth",
                        "a coarser cloth, in Python: CSFParams(cloth_resolution_m={cell}) "
                        "or larger"))  # fmt: skip
    if dtm_cell_m is not None:
        rasters.append((dtm_cell_m, _DTM_BYTES_PER_CELL, "a DTM", "--dtm-cell {cell} or larger"))
    for cell, per_cell, what, hint in rasters:
        shape = (int(ext[1] // cell) + 1, int(ext[0] // cell) + 1)
        suggest = smallest_cell_m(np.maximum(ext, cell), per_cell)
        check_grid_memory(
            shape, per_cell,
            f"{what} at {cell:g} m cells over {ext[0]:.0f} x {ext[1]:.0f} m "
            f"({shape[1]:,} x {shape[0]:,} cells)",
            hint.format(cell=f"{suggest:g}"), path=source,
        )  # fmt: skip


def extract_ground(
    xyz: ArrayLike,
    method: str = "auto",
    params: AutoParams | CSFParams | SMRFParams | None = None,
    *,
    max_object_size_m: float | None = None,
    dtm_cell_m: float | None = None,
    rng: np.random.Generator | int | None = None,
    source: str | None = None,
    origin_m: ArrayLike | None = None,
    pass_through: ArrayLike | None = None,
) -> GroundResult:
    """Classify the ground points of a cloud.

    Parameters
    ----------
    xyz
        (N, 3) float64 points in the LOCAL frame (``PointCloud.xyz``), z up, metres.
    method
        One of ``"auto"``, ``"csf"``, ``"smrf"``, ``"none"`` (see the module docstring).
        Keeping an existing ASPRS classification (``"class"``) is the caller's business.
    params
        :class:`AutoParams` for ``"auto"``, :class:`CSFParams` for ``"csf"``,
        :class:`SMRFParams` for ``"smrf"``; None = measured on the cloud (``"auto"``) or
        the published defaults. To override some measured values:
        ``dataclasses.replace(auto_params(measure_scene(xyz)), ...)``.
    max_object_size_m
        Size of the largest building, metres (e.g. the largest footprint diameter of the
        GIS layer given to step 1); used by ``"auto"``. None = 34 m.
    dtm_cell_m
        Cell size of the returned DTM, metres; None = the filter's cell (SMRF cell or
        cloth resolution).
    rng
        Unused: every filter here is deterministic. Accepted for a uniform API.
    source
        File name of the cloud, for error messages.
    origin_m
        World x, y of the local frame's origin (``PointCloud.offset[:2]``). The rasters of
        ``"auto"`` and ``"smrf"`` and the DTM have their cell edges on the multiples of the
        cell size in world coordinates (:func:`aligned_grid`), so tiles of one survey get
        the cells of the single-cloud run (step 1 passes its cloud's offset); None = the
        grids start at the points' west and north edges. (CSF's cloth is its own grid.)
    pass_through
        (N,) bool, the returns that are not the last of their pulse (LAS
        ``return_number < number_of_returns``, see :func:`pass_through_returns`), or None.
        The pulse went on below such a point: it is ground only where it lies on the
        terrain (within :data:`PASS_THROUGH_ON_GROUND_M` of the DTM: a pulse split on a
        curb or a step).  They are kept out of the filter (its rasters, measured spacing
        and surfaces come from the last and only returns).  Low vegetation is the first
        error of the filter on sparse surveys (27 of 30 terrain-family draws); 43 % of
        its returns pass through, none of the ground's.

    Returns
    -------
    GroundResult
        ``mask`` (N,) bool aligned with ``xyz``; ``dtm`` None when there is no ground,
        with ``note`` saying why (walls only, a single scan line, a building interior).

    Raises
    ------
    InputError
        Unknown method, wrong parameter type, empty cloud, NaN coordinates, fewer than
        :data:`MIN_GROUND_POINTS` points or all of them on one vertical line, a filter
        raster or DTM larger than the free memory (refused before any work).
    """
    del rng  # deterministic filters
    if pass_through is not None:
        through = np.asarray(pass_through, dtype=bool).ravel()
        pts_all = _check_xyz(xyz)
        if through.shape != (len(pts_all),):
            raise InputError(
                f"pass_through has {through.size} values for {len(pts_all)} points",
                path=source,
            )
        last = np.flatnonzero(~through)
        if through.any() and len(last) >= MIN_GROUND_POINTS:
            res = extract_ground(
                pts_all[last], method, params, max_object_size_m=max_object_size_m,
                dtm_cell_m=dtm_cell_m, source=source, origin_m=origin_m,
            )  # fmt: skip
            mask = np.zeros(len(pts_all), dtype=bool)
            mask[last] = res.mask
            if res.dtm is not None:
                # a pulse split on the ground itself (a curb, a step, a field edge) leaves
                # pass-through returns on the surface: 0.25 % of AHN3 tile 1's ground
                on = np.flatnonzero(through)
                h = height_above_ground(pts_all[on], res.dtm)
                mask[on] = np.abs(np.nan_to_num(h, nan=np.inf)) <= PASS_THROUGH_ON_GROUND_M
            return replace(res, mask=mask)
    if method not in GROUND_METHODS:
        raise InputError(
            f"unknown ground method {method!r}; expected one of {', '.join(GROUND_METHODS)}"
        )
    if max_object_size_m is not None and not (
        np.isfinite(max_object_size_m) and max_object_size_m > 0
    ):
        raise InputError(f"max_object_size_m must be > 0 metres, got {max_object_size_m!r}")
    if dtm_cell_m is not None and not (np.isfinite(dtm_cell_m) and dtm_cell_m > 0):
        raise InputError(f"dtm_cell_m must be > 0 metres, got {dtm_cell_m!r}")
    pts = _check_xyz(xyz)
    n = pts.shape[0]
    if method == "none":
        _resolve_params(method, params, None)
        return GroundResult(np.zeros(n, dtype=bool), "none", None, None, None, "")
    span = check_spread(pts, step="ground filters", min_points=MIN_GROUND_POINTS, path=source)
    scene = None
    if method == "auto":
        scene = measure_scene(pts, max_object_size_m=max_object_size_m, slope=False)
    used = _resolve_params(method, params, scene)
    _check_rasters(span, used, dtm_cell_m, source)
    dtm: DTM | None = None
    # the cells of the points on the filter's grid, computed once for the filter, the
    # refinement, the surface checks and the DTM
    sampler: RasterSampler | None = None
    if isinstance(used, AutoParams):
        sampler = RasterSampler(
            aligned_grid(pts[:, :2], used.seed.cell_m, origin_m), pts[:, :2], dtype=np.float32
        )
        seeds, _ = smrf(pts, used.seed, sampler=sampler)
        mask = seeds
        if seeds.any():
            mask, dtm, _ = refine_ground(pts, seeds, used.refine, sampler=sampler)
        cell = used.refine.cell_m
    elif isinstance(used, CSFParams):
        mask = csf(pts, used)
        cell = used.cloth_resolution_m
    else:
        sampler = RasterSampler(
            aligned_grid(pts[:, :2], used.cell_m, origin_m), pts[:, :2], dtype=np.float32
        )
        mask, _ = smrf(pts, used, sampler=sampler)
        cell = used.cell_m
    if dtm_cell_m is not None and dtm_cell_m != cell:
        cell, dtm = float(dtm_cell_m), None
    note = "" if mask.any() else "the filter found no ground point"
    if not note:
        spacing = scene.spacing_m if scene is not None else point_spacing_m(pts[:, :2])
        # the ground's own spacing: on sparse clouds (0.1-0.3 points/m^2, half of them
        # under vegetation) cells of the cloud's spacing rarely have eight ground
        # neighbours even where the ground is an area (issue 17, terrain seed 3)
        note = _surface_note(pts, mask, max(cell, spacing), sampler, origin_m)
        if note.startswith("no ground surface") and mask.sum() >= 3:
            coarse = 2.0 * point_spacing_m(pts[mask, :2])
            if coarse > max(cell, spacing):
                # only the area test is repeated on the coarser cells: the ceiling test
                # is for building interiors, dense clouds whose cells hold their points
                retry = _surface_note(pts, mask, coarse, origin_m=origin_m)
                note = retry if retry.startswith("no ground surface") else ""
    if note:
        return GroundResult(np.zeros(n, dtype=bool), method, used, None, scene, note)
    if dtm is None:
        if sampler is None or sampler.grid.cell_m != cell:
            sampler = RasterSampler(aligned_grid(pts[:, :2], cell, origin_m), pts[:, :2])
        dtm = dtm_from_ground(pts, mask, cell, sampler=sampler)
    if scene is not None:
        slope = dtm.slope()[dtm.observed]
        scene = replace(scene, slope=float(np.percentile(slope, 90)))
    return GroundResult(mask, method, used, dtm, scene, "")
