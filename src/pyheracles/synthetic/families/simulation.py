"""What a family draw gives (:class:`Simulation`) and how it is written to a folder."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.errors import InputError
from pyheracles.io.atomic import atomic_path, atomic_write_json
from pyheracles.synthetic.scanner import ScanResult
from pyheracles.synthetic.scene import Scene

__all__ = ["Simulation", "apply_overrides", "write_simulation"]


@dataclass(frozen=True)
class Simulation:
    """One drawn member of a scene family, scanned.

    Attributes
    ----------
    family, seed
        Which draw this is.
    scene
        The labelled surfaces (with ``scene.objects``: each object's true primitive).
    clouds
        Name -> scan (``{"cloud": ...}``; the church has ``interior`` and ``exterior``).
        Coordinates are in each cloud's own frame (see ``transforms``).
    transforms
        Name -> ``T_scene_cloud`` (4 x 4): maps the cloud's coordinates into the
        scene frame (identity for clouds given in the scene frame).
    params
        The drawn parameters (JSON-able), so that a draw can be described and redone.
    extras
        Family-specific reference data (GIS layers as GeoDataFrames, control and
        check points, reference tables); written by the family's ``write_extras``.
    """

    family: str
    seed: int
    scene: Scene
    clouds: dict[str, ScanResult]
    transforms: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    extras: dict[str, Any] = field(default_factory=dict)
    crs: str | None = None
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)


def apply_overrides(params: Any, overrides: Mapping[str, Any], family: str) -> Any:
    """Replace fields of a frozen parameter dataclass, refusing unknown names."""
    names = {f.name for f in fields(params)}
    bad = sorted(set(overrides) - names)
    if bad:
        import difflib

        near = difflib.get_close_matches(bad[0], sorted(names), n=1)
        hint = f"did you mean {near[0]!r}?" if near else f"known: {', '.join(sorted(names))}"
        raise InputError(f"family {family!r} has no parameter {bad[0]!r}", hint=hint)
    return replace(params, **overrides)


#: Stream tag of the scan generator of a rescan (``noise_draw`` > 0): the bytes "nois".
NOISE_STREAM = 0x6E6F6973


def scan_generator(
    seed: int, noise_draw: Any, own: np.random.Generator, family: str
) -> np.random.Generator:
    """The generator of a draw's scan: its own, or the ``noise_draw``-th other one.

    A family's ``noise_draw`` parameter rescans the same scene (geometry, stations,
    targets) with other random numbers: detection, range noise, mixed pixels, glass,
    matching and outliers.  A rule of the segmentation must hold over the noise draws of
    its scene, not only over the one noise draw each scene had (the lesson of the
    per-ray simulator: rules fitted to one draw's noise failed on another's).

    Parameters
    ----------
    seed
        Draw number.
    noise_draw
        0: the draw's own scan (``own``, the cloud the benchmarks always used); k > 0:
        the k-th other scan of the same scene.
    own
        The generator the draw scans with when ``noise_draw`` is 0.
    family
        Family name, for the error message.

    Raises
    ------
    InputError
        ``noise_draw`` not a whole number >= 0.
    """
    check_noise_draw(noise_draw, family)
    if noise_draw == 0:
        return own
    return np.random.default_rng([seed, NOISE_STREAM, int(noise_draw)])


def check_noise_draw(noise_draw: Any, family: str) -> None:
    """Refuse a ``noise_draw`` that is not a whole number >= 0."""
    whole = isinstance(noise_draw, int | np.integer) and not isinstance(noise_draw, bool)
    if not whole or noise_draw < 0:
        raise InputError(
            f"{family} noise_draw must be a whole number >= 0, got {noise_draw!r}",
            hint="0 is the draw's own scan; 1, 2, ... rescan the same scene with other noise",
        )


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


def _write_laz(
    res: ScanResult, path: Path, offset: tuple[float, float, float], crs: str | None
) -> None:
    """A LAS 1.4 point format 6 file with the scanner's attributes and no reference labels."""
    import laspy

    header = laspy.LasHeader(point_format=6, version="1.4")
    xyz = res.xyz + np.asarray(offset)
    lo = xyz.min(0) if len(xyz) else np.zeros(3)
    header.offsets = np.floor(lo)
    header.scales = np.array([0.0001, 0.0001, 0.0001])
    if crs:
        from pyproj import CRS

        header.add_crs(CRS.from_user_input(crs))
    las = laspy.LasData(header)
    las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    las.intensity = res.intensity
    las.point_source_id = res.point_source_id
    las.return_number = res.return_number
    las.number_of_returns = res.number_of_returns
    las.scan_angle = np.round(res.scan_angle_deg / 0.006).astype(np.int16)
    las.gps_time = res.gps_time
    las.scan_direction_flag = res.scan_direction_flag
    las.edge_of_flight_line = res.edge_of_flight_line
    with atomic_path(path) as tmp:
        las.write(tmp)


def _preview(sim: Simulation, path: Path) -> None:
    """Plan and side view of the first cloud, coloured by class."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    name, res = next(iter(sim.clouds.items()))
    xyz = res.xyz
    g = np.random.default_rng(0)
    take = g.choice(len(xyz), min(len(xyz), 200_000), replace=False) if len(xyz) else []
    p, c = xyz[take], res.class_id[take]
    fig, ax = plt.subplots(1, 2, figsize=(12, 5.5))
    cmap = plt.get_cmap("tab20")
    for code in np.unique(c):
        m = c == code
        label = sim.scene.class_names.get(int(code), str(code))
        col = (0.6, 0.6, 0.6, 1.0) if code == 0 else cmap(int(code) % 20)
        ax[0].scatter(p[m, 0], p[m, 1], s=0.3, color=col, label=label, rasterized=True)
        ax[1].scatter(p[m, 0], p[m, 2], s=0.3, color=col, rasterized=True)
    out = res.outlier[take]
    ax[0].scatter(p[out, 0], p[out, 1], s=2, color="red", label="outlier")
    ax[0].set_aspect("equal")
    ax[1].set_aspect("equal")
    ax[0].set_title(f"{sim.family} seed {sim.seed}: {name}, {len(xyz):,} points (plan)")
    ax[1].set_title("side view (x, z)")
    ax[0].legend(markerscale=12, fontsize=7, loc="upper right")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=90)
    plt.close(fig)


def write_simulation(
    sim: Simulation, outdir: str | Path, *, preview: bool = True
) -> dict[str, Path]:
    """Write a draw: clouds without labels, the reference apart, the scene description.

    One cloud is written as ``cloud.laz`` + ``truth.npz``; several clouds
    (church) as ``<name>.laz`` + ``truth_<name>.npz``.  ``truth*.npz`` holds
    int arrays ``instance``, ``class_id``, ``part`` and bool ``outlier``,
    aligned with the cloud, plus ``T_scene_cloud``.  ``scene.json`` gives the
    classes, parts, objects with their true primitives, the acquisitions and
    the drawn parameters; ``preview.png`` a plan and a side view.
    """
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    written: dict[str, Path] = {}
    single = len(sim.clouds) == 1
    for name, res in sim.clouds.items():
        if len(res) == 0:
            raise InputError(
                f"the draw produced no points for {name!r}",
                hint="choose another seed or other parameters",
            )
        laz = out / ("cloud.laz" if single else f"{name}.laz")
        _write_laz(res, laz, sim.offset, sim.crs)
        written[laz.stem] = laz
        truth = out / ("truth.npz" if single else f"truth_{name}.npz")
        T = sim.transforms.get(name, np.eye(4))
        with atomic_path(truth) as tmp:
            with open(tmp, "wb") as fh:
                np.savez_compressed(
                    fh,
                    instance=res.instance.astype(np.int32),
                    class_id=res.class_id.astype(np.int32),
                    part=res.part.astype(np.int32),
                    outlier=res.outlier.astype(bool),
                    T_scene_cloud=np.asarray(T, float),
                )
        written[truth.stem] = truth
    desc = {
        "family": sim.family,
        "seed": sim.seed,
        "crs": sim.crs,
        "offset": list(sim.offset),
        "params": sim.params,
        **sim.scene.to_json(),
        "clouds": {
            n: {
                "points": len(r),
                "acquisitions": r.acquisitions,
                "T_scene_cloud": np.asarray(sim.transforms.get(n, np.eye(4))).tolist(),
            }
            for n, r in sim.clouds.items()
        },
    }
    written["scene"] = atomic_write_json(out / "scene.json", _jsonable(desc))
    writer = sim.extras.get("write_extras")
    if callable(writer):
        written.update(writer(out))
    if preview:
        _preview(sim, out / "preview.png")
        written["preview"] = out / "preview.png"
    return written
