"""``heracles beams``: beams of a timber framework with their fitted cuboids."""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import numpy as np
import typer

if TYPE_CHECKING:  # pragma: no cover
    from pyheracles.beams import BeamResult

__all__ = ["plot_beams", "register"]

_HELP = "\n\n".join(
    [
        "Segment the beams of a timber roof framework and fit one cuboid per beam.",
        "Region growing finds the planar facets, L/T/X-shaped facets are cut into straight "
        "bands (beam width measured automatically), facets are grouped into beams by shared "
        "edges and parallel axes, and each beam gets an oriented cuboid (axis, length, width, "
        "height, RMS). Points near no cuboid stay in the remainder (instance 0).",
        "The frame as a structure: joints between the beams (which meet, where, type L, T, X, "
        "lap or foot), the connected components (beams joined to no frame are flagged "
        "'loose'), a role per beam guessed from geometry (tie, rafter, common_rafter, post, "
        "strut, collar, purlin, ridge, plate, brace) and per beam its deflection (largest "
        "deviation of the scanned centre line from straight, mm) and twist (degrees).",
        "Writes into OUTDIR: segmented.laz (all points in input order, extra dimensions "
        "instance and class_id; class 'beam'), objects.csv (one row per beam: axis, "
        "inclination, length, width, height, RMS, role, in_frame, deflection_mm, twist_deg), "
        "frame.json (members, joints, components), beams.png (plan and elevations of the "
        "beams and their cuboids) and run.json (parameters, inputs, timings, counts).",
        "Examples:",
        "  heracles beams roof.laz -o out/beams",
        "  heracles beams roof.e57 --angle 10 --min-width 0.06 -o out/beams --force",
        "  heracles beams big_roof.laz --voxel -o out/beams_fast",
    ]
)


def _raster_view(
    u: np.ndarray,
    v: np.ndarray,
    layers: list[tuple[np.ndarray, np.ndarray]],
    origin: tuple[float, float],
    cell: float,
    shape: tuple[int, int],
) -> np.ndarray:
    """Points painted into an RGBA image of ``shape`` (rows: ``v`` upwards) cells.

    Cell ``(0, 0)`` starts at ``origin``, cells are ``cell`` data units wide;
    points outside are clipped to the border cells.  ``layers`` are
    ``(index, rgba)`` pairs painted in turn (a later layer covers an earlier
    one in a cell shared by both; ``rgba`` is ``(4,)`` or one row per point);
    cells without points are transparent.
    """
    nv, nu = shape
    iu = np.clip(((u - origin[0]) / cell).astype(np.int64), 0, nu - 1)
    iv = np.clip(((v - origin[1]) / cell).astype(np.int64), 0, nv - 1)
    flat = iv * nu + iu
    img = np.zeros((nv * nu, 4), dtype=np.uint8)
    for index, rgba in layers:
        img[flat[index]] = np.round(255 * np.asarray(rgba)).astype(np.uint8)
    return img.reshape(nv, nu, 4)


def plot_beams(xyz: np.ndarray, result: BeamResult, path: Path, *, dpi: int = 110):
    """Plan and two elevations of the beams (coloured) and their cuboids (black edges).

    Every point is drawn, painted into an image of one cell per pixel of each
    view (beams over the grey remainder) after the layout is fixed, so a
    point shows as one pixel, as a marker would, and the time grows with the
    points only through one pass over them.  Written atomically; matplotlib
    is imported here only.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    from pyheracles.io.atomic import atomic_path

    xyz = np.asarray(xyz, dtype=np.float64)
    lab = np.asarray(result.labels)
    cmap = plt.get_cmap("tab20")
    on_beam = np.flatnonzero(lab != 0)
    # the grey remainder first, the beams over it
    layers = [(np.flatnonzero(lab == 0), np.array([0.75, 0.75, 0.75, 1.0])),
              (on_beam, cmap((lab[on_beam] - 1) % 20))]  # fmt: skip
    edges = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]
    corners = [cub.corners() for cub in result.beams]
    views = (("plan (x, y)", 0, 1), ("elevation (x, z)", 0, 2), ("elevation (y, z)", 1, 2))
    fig, axes = plt.subplots(1, 3, figsize=(18, 6.5), dpi=dpi)
    for ax, (title, i, j) in zip(axes, views, strict=True):
        segs = [[(c[a, i], c[a, j]), (c[b, i], c[b, j])] for c in corners for a, b in edges]
        if segs:
            ax.add_collection(LineCollection(segs, colors="k", linewidths=0.6))
        if len(xyz):
            lo, hi = xyz[:, [i, j]].min(axis=0), xyz[:, [i, j]].max(axis=0)
            ax.update_datalim(np.array([lo, hi]))
        for k, cub in enumerate(result.beams):
            ax.annotate(str(k + 1), (cub.centre[i], cub.centre[j]), fontsize=7, ha="center")
        ax.autoscale_view()
        ax.set_aspect("equal")
        ax.set_title(title)
        ax.set_xlabel("metres (local frame)")
    fig.suptitle(f"{len(result.beams)} beams; grey: remainder")
    fig.tight_layout()
    width_px, height_px = fig.get_size_inches() * fig.dpi
    for ax, (_, i, j) in zip(axes, views, strict=True):
        if not len(xyz):
            continue
        ax.apply_aspect()
        pos = ax.get_position()
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        cell = max((x1 - x0) / (pos.width * width_px), (y1 - y0) / (pos.height * height_px))
        shape = (max(int(np.ceil((y1 - y0) / cell)), 1), max(int(np.ceil((x1 - x0) / cell)), 1))
        img = _raster_view(xyz[:, i], xyz[:, j], layers, (x0, y0), cell, shape)
        extent = (x0, x0 + shape[1] * cell, y0, y0 + shape[0] * cell)
        ax.set_autoscale_on(False)
        ax.imshow(img, extent=extent, origin="lower", interpolation="nearest", zorder=0)
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
    plt.close(fig)
    return path


def register(app: typer.Typer) -> None:
    """Add the ``beams`` subcommand to ``app``."""

    @app.command("beams", help=_HELP)
    def beams_command(
        cloud_path: Annotated[Path, typer.Argument(metavar="CLOUD", help="Point cloud file.")],
        outdir: Annotated[Path, typer.Option("-o", "--out", "--outdir", help="Output folder.")],
        angle_deg: Annotated[
            float | None,
            typer.Option("--angle", help="Region growing normal angle, degrees (auto)."),
        ] = None,
        k: Annotated[int, typer.Option("--k", help="Neighbours for normals.")] = 24,
        min_width_m: Annotated[
            float, typer.Option("--min-width", help="Smallest beam section, metres.")
        ] = 0.04,
        max_width_m: Annotated[
            float, typer.Option("--max-width", help="Largest beam section, metres.")
        ] = 0.6,
        voxel: Annotated[
            bool, typer.Option("--voxel", help="Voxel-level region growing (faster, coarser).")
        ] = False,
        no_picture: Annotated[
            bool, typer.Option("--no-picture", help="Do not draw beams.png.")
        ] = False,
        ifc: Annotated[
            bool, typer.Option("--ifc", help="Also write model.ifc (IFC 4; needs the bim extra).")
        ] = False,
        no_frame: Annotated[
            bool,
            typer.Option(
                "--no-frame", help="Skip joints, roles, deflection and twist (no frame.json)."
            ),
        ] = False,
        force: Annotated[
            bool, typer.Option("--force", help="Write into a non-empty output folder.")
        ] = False,
    ) -> None:
        from pyheracles import progress
        from pyheracles.beams import BeamParams, segment_beams
        from pyheracles.beams.frame import analyse_frame
        from pyheracles.cli.common import (
            console,
            output_dir,
            print_counts,
            print_objects,
            print_run_warnings,
            write_model_ifc,
        )
        from pyheracles.io import read_cloud
        from pyheracles.io.atomic import atomic_write_json
        from pyheracles.io.results import write_segmentation
        from pyheracles.resources import one_blas_thread
        from pyheracles.segment.regiongrow import RegionGrowingParams

        params = BeamParams(
            region=RegionGrowingParams(
                k=k, angle_deg=angle_deg, min_points=100, level="voxel" if voxel else "point"
            ),
            min_beam_width_m=min_width_m,
            max_beam_width_m=max_width_m,
        ).validate()
        with output_dir(outdir, force=force) as stage, progress.enabled(console):
            timings: dict[str, float] = {}
            t = time.perf_counter()
            with progress.stage(f"reading {cloud_path.name}"):
                cloud = read_cloud(cloud_path).validate(what=f"point cloud {cloud_path}")
            timings["read"] = time.perf_counter() - t
            t = time.perf_counter()
            with progress.stage("beams: facets, bands, cuboids"), one_blas_thread():
                result = segment_beams(cloud, params)
            timings["beams"] = time.perf_counter() - t
            # The picture is drawn on a second thread while the frame is analysed and
            # the cloud written: matplotlib's import and drawing are mostly Python,
            # the frame and the LAZ compression mostly numpy and Rust that release
            # the interpreter, so on two cores they overlap (about 1 s of the 1 M-point
            # run).  Only that thread touches matplotlib.
            pool = ThreadPoolExecutor(max_workers=1)
            try:
                picture = None
                if not no_picture:
                    picture = pool.submit(plot_beams, cloud.xyz, result, stage / "beams.png")
                frame = None
                if not no_frame:
                    t = time.perf_counter()
                    with (
                        progress.stage("frame: joints, roles, deflection, twist"),
                        one_blas_thread(),
                    ):
                        frame = analyse_frame(cloud.xyz, result)
                    timings["frame"] = time.perf_counter() - t
                t = time.perf_counter()
                with progress.stage("writing segmented.laz, objects, frame.json, beams.png"):
                    seg = result.to_segmentation(cloud.offset)
                    extra = {"n_beams": len(result.beams)}
                    if frame is not None:
                        for name, column in frame.member_columns().items():
                            seg.objects[name] = column
                        extra.update(
                            n_joints=len(frame.joints), n_in_frame=int(frame.in_frame.sum())
                        )
                    paths = write_segmentation(
                        cloud,
                        seg,
                        stage,
                        step="beams",
                        parameters=result.params,
                        inputs=[cloud_path],
                        timings={**timings, **{f"beams.{k}": v for k, v in result.timings.items()}},
                        extra=extra,
                    )
                    if frame is not None:
                        paths["frame"] = atomic_write_json(
                            stage / "frame.json",
                            frame.to_json(result, cloud.offset, n_points=len(cloud.xyz)),
                        )
                    if picture is not None:
                        paths["picture"] = picture.result()
            finally:
                pool.shutdown()
            if ifc:
                with progress.stage("IFC model"):
                    paths["ifc"] = write_model_ifc(stage)
            timings["write"] = time.perf_counter() - t
            counts = seg.counts()
            print_run_warnings(stage)
        columns = ["instance", "n_points", "inclination_deg", "length_m", "width_m", "height_m"]
        columns += ["role", "deflection_mm", "twist_deg"] if frame is not None else ["rms_m"]
        print_objects(seg.objects, columns)
        print_counts(counts, timings, {k: outdir / v.name for k, v in paths.items()})
        joints = "" if frame is None else f", {len(frame.joints)} joints"
        console.print(f"{len(result.beams)} beams{joints} written to {outdir}")
