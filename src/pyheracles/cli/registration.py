"""``heracles register``, ``heracles georef``, ``heracles checkpoints``: QC of integration."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import typer
from rich.table import Table

from pyheracles import progress
from pyheracles.cli.common import console, err_console, output_dir, print_run_warnings
from pyheracles.cli.ground import parse_crs_option
from pyheracles.errors import InputError

MODELS = ("similarity", "rigid")
STRATEGIES = ("independent", "free", "block")
METHODS = ("auto", "panes", "global")


def _check_choice(value: str, choices: tuple[str, ...], option: str) -> str:
    if value not in choices:
        raise InputError(f"{option} {value!r} is not one of {', '.join(choices)}")
    return value


def _parameter_table(title: str, result: Any) -> Table:
    """Parameters with standard deviations of a SimilarityResult."""
    table = Table(title=title)
    for col in ("parameter", "value", "std dev"):
        table.add_column(col, justify="right" if col != "parameter" else "left")
    for name in result.parameter_names:
        v, s = result.parameters[name], result.std[name]
        if name in ("omega", "phi", "kappa"):
            table.add_row(f"{name} (deg)", f"{np.degrees(v):.6f}", f"{np.degrees(s):.6f}")
        elif name == "scale":
            table.add_row(name, f"{v:.8f}", f"{s * 1e6:.1f} ppm")
        else:
            table.add_row(f"{name} (m)", f"{v:.4f}", f"{s * 1000:.1f} mm")
    rms = result.rms()
    table.add_row("sigma0", f"{result.sigma0:.3f}", "")
    table.add_row("redundancy", str(result.redundancy), "")
    table.add_row("pairs used / given", f"{result.n_used} / {result.n_pairs}", "")
    table.add_row("RMS 3D (m)", f"{rms['3d']:.4f}", "")
    return table


def _crs_text(crs: Any) -> str | None:
    return None if crs is None else crs.to_string()


def _output_crs(given: Any, known: Any, what: str) -> tuple[Any, list[str]]:
    """The CRS written into the outputs (``--crs`` or the input's) and notes about it."""
    if given is None:
        if known is None:
            return None, [f"{what} and --crs give no CRS: the outputs have none (use --crs)"]
        return known, []
    if known is not None and not given.equals(known):
        return given, [
            f"--crs {given.to_string()} replaces the CRS {known.to_string()} of {what} "
            "(a label only: nothing is reprojected)"
        ]
    return given, []


def _pairs_for(tiepoints: list[Path], source: Path, target: Path):
    from pyheracles.registration.points import pair_points, read_point_groups, read_points

    if len(tiepoints) == 2:
        return pair_points(read_points(tiepoints[0]), read_points(tiepoints[1]))
    if len(tiepoints) != 1:
        raise InputError("give --tiepoints once (file with a 'cloud' column) or twice")
    groups = read_point_groups(tiepoints[0])
    src_key = next((k for k in ("source", source.stem, source.name) if k in groups), None)
    tgt_key = next((k for k in ("target", target.stem, target.name) if k in groups), None)
    if src_key is None or tgt_key is None:
        raise InputError(
            f"the 'cloud' column has {sorted(groups)}; expected source/target or "
            f"{source.stem}/{target.stem}",
            path=tiepoints[0],
        )
    return pair_points(groups[src_key], groups[tgt_key])


def _auto_panes(
    src: Any, tgt: Any, method: str, pane_thickness: float, sp: Any
) -> tuple[Any, str | None]:
    """Pane tie points (``None`` when ``method`` is global or no pane hypothesis
    verifies with ``method`` auto) and why the panes failed."""
    from pyheracles.errors import EstimationError
    from pyheracles.registration.tiepoints import TiePointParams, find_tie_points

    if method == "global":
        return None, None
    try:
        with progress.enabled(console), progress.stage("automatic tie points (panes)"):
            tp = find_tie_points(
                src, tgt, TiePointParams(pane_thickness_m=pane_thickness), similarity=sp
            )
    except (InputError, EstimationError) as exc:
        if method == "panes":
            raise
        return None, str(exc).split(". Fix:")[0]
    return tp, None


def _global(src: Any, tgt: Any, source: Path, target: Path) -> Any:
    """Markerless global registration; "no overlap" (InputError, exit 2) when it fails."""
    from pyheracles.registration.global_registration import global_registration

    with progress.enabled(console):
        g = global_registration(src, tgt)
    if not g.ok:
        raise InputError(
            f"{g.status}: {source.name} and {target.name} cannot be registered "
            f"automatically ({g.reason}); no transform written",
            hint="check that the clouds show the same part of the object, or give "
            "--tiepoints or --init with --icp",
        )
    return g


def _summary_line(method: str, summary: dict[str, Any]) -> str:
    """``method global: overlap 57.4 %, 863 inliers, confidence 1.00``."""
    parts = []
    if summary.get("overlap") is not None:
        parts.append(f"overlap {summary['overlap']:.1%}")
    if summary.get("inliers") is not None:
        parts.append(f"{summary['inliers']} inliers")
    if summary.get("confidence") is not None:
        parts.append(f"confidence {summary['confidence']:.2f}")
    return f"method {method}" + (": " + ", ".join(parts) if parts else "")


def _summary(res: Any, gres: Any, icp_res: Any) -> dict[str, Any]:
    """Overlap, inliers and confidence of the registration (run.json and the printout)."""
    out: dict[str, Any] = {"overlap": None, "inliers": None, "confidence": None}
    if gres is not None:
        out.update(overlap=gres.overlap, inliers=gres.inliers, confidence=gres.confidence)
    elif res is not None:
        out["inliers"] = int(res.n_used)
    if icp_res is not None:
        out["overlap"] = icp_res.overlap_fraction if gres is None else out["overlap"]
        out["icp_rms_point_to_plane_m"] = icp_res.rms_point_to_plane_m
    return out


def register(app: typer.Typer) -> None:
    """Add ``heracles register``, ``georef`` and ``checkpoints``."""

    @app.command("register")
    def register_cmd(
        source: Path = typer.Argument(
            ..., metavar="SOURCE", help="Cloud to move (LAS/LAZ/PLY/E57)."
        ),
        target: Path = typer.Argument(..., metavar="TARGET", help="Reference cloud."),
        out: Path = typer.Option(..., "-o", "--out", "--outdir", help="Output folder."),
        tiepoints: list[Path] = typer.Option(
            None,
            "--tiepoints",
            help="Tie points: one CSV with columns id,cloud,X,Y,Z (cloud = source/target) "
            "or two CSVs (source frame, target frame) with id,X,Y,Z[,sX,sY,sZ].",
        ),
        auto: bool = typer.Option(
            False, "--auto", help="Automatic registration (see --method), no tie points."
        ),
        method: str = typer.Option(
            None,
            "--method",
            help="Automatic method (implies --auto): auto (window panes, else markerless "
            "global registration), panes, or global.",
        ),
        init: Path = typer.Option(
            None, "--init", help="Initial transform (transform.json) for --icp, no tie points."
        ),
        model: str = typer.Option("similarity", help="similarity (7 p) or rigid (6 p)."),
        estimator: str = typer.Option("danish", help="lsq, danish, l1, huber or tukey."),
        icp: bool = typer.Option(
            False,
            "--icp",
            help="Refine with point-to-plane ICP (from the tie points, the "
            "automatic solution or --init).",
        ),
        pane_thickness: float = typer.Option(0.02, help="Glass thickness for --auto, m."),
        crs: str = typer.Option(
            None, "--crs", help="CRS of the target frame (default: TARGET's), e.g. EPSG:2154."
        ),
        force: bool = typer.Option(False, help="Write into a non-empty output folder."),
    ) -> None:
        """Register SOURCE onto TARGET: tie points, automatic, or ICP from --init.

        --auto first looks for window-pane tie points; when no pane hypothesis
        verifies it falls back to markerless global registration (FPFH features,
        robust consensus, ICP), which needs no initial pose.  Clouds that do not
        overlap enough stop with "no overlap" (exit code 2) and nothing is written.

        Writes into OUT: transform.json (4x4 T_target_source with parameters and
        standard deviations or the global registration report, target CRS),
        SOURCE_registered.laz (the source cloud in the target frame, with TARGET's
        CRS or --crs), tiepoints.csv (tie points with their residuals, when tie
        points were used) and run.json.

        Examples:

            heracles register interior.laz exterior.laz --tiepoints ties.csv -o reg/

            heracles register interior.laz exterior.laz --auto --icp -o reg/

            heracles register scan2.laz scan1.laz --method global -o reg/

            heracles register scan2.laz scan1.laz --init reg/transform.json --icp -o reg2/
        """
        from dataclasses import replace

        from pyheracles.io import read_cloud, write_cloud
        from pyheracles.io.atomic import atomic_write_text
        from pyheracles.provenance import write_run_json
        from pyheracles.registration.icp import icp as run_icp
        from pyheracles.registration.similarity import SimilarityParams, estimate_similarity
        from pyheracles.registration.transform import (
            apply_to_cloud,
            read_transform_json,
            write_transform_json,
        )

        _check_choice(model, MODELS, "--model")
        if method is not None:
            _check_choice(method, METHODS, "--method")
            auto = True
        if sum((bool(tiepoints), auto, init is not None)) != 1:
            raise InputError(
                "give exactly one of --tiepoints CSV, --auto (or --method) and --init T.json"
            )
        if init is not None and not icp:
            raise InputError("--init gives the start of ICP: add --icp")
        T_init = read_transform_json(init) if init is not None else None
        given_crs = parse_crs_option(crs)
        sp = SimilarityParams(with_scale=model == "similarity", estimator=estimator)
        timings: dict[str, float] = {}
        t = time.perf_counter()
        with progress.enabled(console), progress.stage("reading the clouds"):
            src = read_cloud(source)
            tgt = read_cloud(target)
        timings["read"] = time.perf_counter() - t
        out_crs, notes = _output_crs(given_crs, tgt.crs, f"TARGET {target.name}")
        t = time.perf_counter()
        extra: dict[str, Any] = {}
        res = gres = None
        used = "tie points" if tiepoints else "init" if init is not None else "panes"
        ids: list[str] = []
        if auto:
            tp, pane_failure = _auto_panes(src, tgt, method or "auto", pane_thickness, sp)
            if tp is not None:
                ids, a, b = tp.source.ids, tp.source.xyz, tp.target.xyz
                sa = sb = None
                extra["automatic_tie_points"] = {
                    k: v for k, v in tp.to_dict().items() if k != "similarity"
                }
            else:
                used = "global"
                if pane_failure:
                    extra["panes_failed"] = pane_failure
                    err_console.print(
                        f"[yellow]note:[/] no verified window panes ({pane_failure}); "
                        "trying markerless global registration", highlight=False
                    )  # fmt: skip
                gres = _global(src, tgt, source, target)
                extra["global_registration"] = gres.to_dict()
        elif tiepoints:
            pairs = _pairs_for(tiepoints, source, target)
            ids, a, b, sa, sb = pairs.ids, pairs.a, pairs.b, pairs.sigma_a, pairs.sigma_b
        if used in ("tie points", "panes"):
            res = estimate_similarity(a, b, sp, source_sigma=sa, target_sigma=sb, ids=ids)
            T = res.T_target_source
        elif gres is not None:
            T = gres.T_target_source
        else:
            T = T_init
        timings["tie_points" if res is not None else used] = time.perf_counter() - t
        icp_res = None
        if icp and gres is not None and gres.icp is not None:
            icp_res = gres.icp  # the global solution is already refined by the same ICP
            extra["icp"] = icp_res.to_dict()
        elif icp:
            t = time.perf_counter()
            with progress.enabled(console), progress.stage("ICP refinement"):
                icp_res = run_icp(src, tgt, T)
            T = icp_res.T_target_source
            extra["icp"] = icp_res.to_dict()
            timings["icp"] = time.perf_counter() - t
        t = time.perf_counter()
        with output_dir(out, force=force) as stage, progress.enabled(console):
            write_transform_json(
                stage / "transform.json", T, source=str(source), target=str(target),
                result=res if res is not None else gres,
                extra={**extra, "method": used, "target_crs": _crs_text(out_crs)},
            )  # fmt: skip
            moved = replace(apply_to_cloud(src, T, crs=out_crs), source=str(source))
            suffix = source.suffix.lower() if source.suffix.lower() in (".las", ".laz") else ".laz"
            with progress.stage("writing the registered cloud"):
                write_cloud(moved, stage / f"{source.stem}_registered{suffix}")
            if res is not None:
                rows = ["id,X_source,Y_source,Z_source,X_target,Y_target,Z_target,vx,vy,vz,outlier"]
                for i in range(len(ids)):
                    v = res.residuals[i]
                    rows.append(
                        f"{ids[i]},{a[i, 0]:.4f},{a[i, 1]:.4f},{a[i, 2]:.4f},{b[i, 0]:.4f},"
                        f"{b[i, 1]:.4f},{b[i, 2]:.4f},{v[0]:.4f},{v[1]:.4f},{v[2]:.4f},"
                        f"{int(res.outliers[i])}"
                    )
                atomic_write_text(stage / "tiepoints.csv", "\n".join(rows) + "\n")
            timings["write"] = time.perf_counter() - t
            summary = _summary(res, gres, icp_res)
            write_run_json(
                stage, step="register", parameters=sp,
                inputs=[source, target, *(tiepoints or []), *([init] if init else [])],
                timings=timings,
                counts={"points_source": len(src), "points_target": len(tgt),
                        "tie_points": len(ids),
                        "outliers": int(res.outliers.sum()) if res is not None else 0},
                extra={"method": used, **summary, "crs": _crs_text(out_crs), "notes": notes,
                       **({"sigma0": res.sigma0, "rms_m": res.rms()} if res is not None else {})},
            )  # fmt: skip
            print_run_warnings(stage)
        if res is not None:
            console.print(_parameter_table(f"{source.name} -> {target.name}", res))
        console.print(_summary_line(used, summary))
        if icp_res is not None:
            console.print(
                f"ICP: converged={icp_res.converged}, {icp_res.iterations} iterations, "
                f"overlap {icp_res.overlap_fraction:.1%}, RMS point-to-plane "
                f"{icp_res.rms_point_to_plane_m * 1000:.1f} mm"
            )
        for i in np.flatnonzero(res.outliers) if res is not None else []:
            console.print(f"[yellow]outlier:[/] tie point {ids[i]} ({res.residual_3d[i]:.3f} m)")
        console.print(f"[green]wrote[/] {out}")

    @app.command("georef")
    def georef_cmd(
        clouds: list[Path] = typer.Argument(..., metavar="CLOUDS", help="Clouds to georeference."),
        control: Path = typer.Option(..., "--control", help="Control points CSV (world)."),
        measured: list[Path] = typer.Option(
            ...,
            "--measured",
            help="Points measured in each cloud (CSV id,X,Y,Z, cloud frame), one per cloud "
            "in the same order. Ids shared by two clouds are tie points.",
        ),
        out: Path = typer.Option(..., "-o", "--out", "--outdir", help="Output folder."),
        strategy: str = typer.Option(
            "independent", help="independent, free (first cloud is the base) or block."
        ),
        model: str = typer.Option("similarity", help="similarity (7 p) or rigid (6 p)."),
        rigid: list[str] = typer.Option(
            None, "--rigid", help="Cloud (file stem) with a rigid 6 p model, e.g. a TLS scan."
        ),
        estimator: str = typer.Option("danish", help="lsq, danish, l1, huber or tukey."),
        sphere_radius: float = typer.Option(
            None, help="Refine measured points as sphere target centres of this radius, m."
        ),
        crs: str = typer.Option(
            None, "--crs", help="CRS of the control points, e.g. EPSG:2154 (into the outputs)."
        ),
        force: bool = typer.Option(False, help="Write into a non-empty output folder."),
    ) -> None:
        """Georeference one or more clouds on control points (thesis ch. 3 strategies).

        Writes into OUT: one NAME_georef.laz and transform_NAME.json per cloud,
        georef.json (strategy, parameters, residuals) and run.json; with --crs (the
        control points' CRS) the clouds and JSON files carry it.

        Example:

            heracles georef exterior.laz interior.laz --control gcp.csv
            --measured ext_targets.csv --measured int_targets.csv --rigid interior
            --strategy block -o geo/
        """
        from dataclasses import replace

        from pyheracles.io import read_cloud, write_cloud
        from pyheracles.io.atomic import atomic_write_json
        from pyheracles.provenance import write_run_json
        from pyheracles.registration.points import read_points
        from pyheracles.registration.similarity import SimilarityParams
        from pyheracles.registration.strategies import (
            CloudMeasurements,
            block_adjustment,
            free_network,
            georeference_independent,
        )
        from pyheracles.registration.targets import measure_spheres
        from pyheracles.registration.transform import apply_to_cloud, write_transform_json

        _check_choice(strategy, STRATEGIES, "--strategy")
        _check_choice(model, MODELS, "--model")
        out_crs, notes = _output_crs(parse_crs_option(crs), None, "the control points")
        if len(measured) != len(clouds):
            raise InputError(
                f"{len(clouds)} clouds but {len(measured)} --measured files",
                hint="give one --measured CSV per cloud, in the same order",
            )
        names = [c.stem for c in clouds]
        if len(set(names)) != len(names):
            raise InputError("cloud file names must differ (they name the outputs)")
        t0 = time.perf_counter()
        ctrl = read_points(control)
        with progress.enabled(console), progress.stage("reading the clouds"):
            pcs = [read_cloud(c) for c in clouds]
        meas = []
        for pc, m in zip(pcs, measured, strict=True):
            pts = read_points(m)
            if sphere_radius:
                pts = measure_spheres(pc, pts, sphere_radius)
            meas.append(pts)
        with_scale = model == "similarity"
        unknown = sorted(set(rigid or []) - set(names))
        if unknown:
            raise InputError(f"--rigid {', '.join(unknown)} is not one of the clouds {names}")
        cm = [
            CloudMeasurements(n, p, with_scale=with_scale and n not in (rigid or []))
            for n, p in zip(names, meas, strict=True)
        ]
        sp = SimilarityParams(with_scale=with_scale, estimator=estimator)
        report: dict[str, Any] = {"strategy": strategy, "crs": _crs_text(out_crs)}
        results: dict[str, Any] = {}
        if strategy == "independent":
            res = georeference_independent(cm, ctrl, sp)
            transforms = {k: r.T_target_source for k, r in res.items()}
            results = res
            report["clouds"] = {k: r.to_dict() for k, r in res.items()}
        elif strategy == "free":
            if len(cm) != 2:
                raise InputError("the free-network strategy takes exactly two clouds")
            fn = free_network(cm[0], cm[1], meas[0], meas[1], ctrl, georef_params=sp)
            transforms = {names[0]: fn.T_world_base, names[1]: fn.T_world_other}
            results = {names[0]: fn.georef, names[1]: fn.tie}
            report.update(fn.to_dict())
        else:
            blk = block_adjustment(cm, ctrl)
            transforms = blk.transforms
            report.update(blk.to_dict())
        timings = {"adjust": time.perf_counter() - t0}
        with output_dir(out, force=force) as stage, progress.enabled(console):
            for name, pc, path in zip(names, pcs, clouds, strict=True):
                T = transforms[name]
                write_transform_json(
                    stage / f"transform_{name}.json", T, source=str(path),
                    target=str(control), result=results.get(name),
                    extra={"target_crs": _crs_text(out_crs)},
                )  # fmt: skip
                moved = replace(apply_to_cloud(pc, T, crs=out_crs), source=str(path))
                with progress.stage(f"writing {name}_georef.laz"):
                    write_cloud(moved, stage / f"{name}_georef.laz")
            atomic_write_json(stage / "georef.json", report)
            write_run_json(
                stage, step="georef", parameters=sp,
                inputs=[*clouds, control, *measured], timings=timings,
                counts={"clouds": len(clouds), "control_points": len(ctrl)},
                extra={"crs": _crs_text(out_crs), "notes": notes},
            )  # fmt: skip
            print_run_warnings(stage)
        for name, r in results.items():
            console.print(_parameter_table(f"{name} ({strategy})", r))
        if strategy == "block":
            console.print(f"block adjustment: sigma0 {blk.sigma0:.3f}, redundancy {blk.redundancy}")
        console.print(f"[green]wrote[/] {out}")

    @app.command("checkpoints")
    def checkpoints_cmd(
        cloud: Path = typer.Argument(..., metavar="CLOUD", help="Registered/georeferenced cloud."),
        points: Path = typer.Option(..., "--points", help="Check points CSV (reference)."),
        measured: Path = typer.Option(
            None, "--measured", help="Check points measured in the cloud (CSV, same ids)."
        ),
        sphere_radius: float = typer.Option(
            None, help="Measure sphere targets of this radius near the reference positions, m."
        ),
        out: Path = typer.Option(
            None, "-o", "--out", "--outdir", help="Output folder (JSON, CSV, PNG)."
        ),
        force: bool = typer.Option(False, help="Write into a non-empty output folder."),
    ) -> None:
        """Residuals and RMS of independent check points; residual map as PNG.

        Writes (only with -o OUT): checkpoints.json, checkpoints.csv (residuals per
        point), residual_map.png and run.json.

        Example:

            heracles checkpoints geo/interior_georef.laz --points chk.csv
            --sphere-radius 0.0725 -o qc/
        """
        from pyheracles.io import read_cloud
        from pyheracles.io.atomic import atomic_write_json, atomic_write_text
        from pyheracles.provenance import write_run_json
        from pyheracles.registration.checkpoints import (
            check_points,
            check_points_frame,
            plot_residual_map,
        )
        from pyheracles.registration.points import pair_points, read_points
        from pyheracles.registration.targets import measure_spheres

        if (measured is None) == (sphere_radius is None):
            raise InputError("give either --measured CSV or --sphere-radius (exactly one)")
        ref = read_points(points)
        with progress.enabled(console), progress.stage(f"reading {cloud.name}"):
            pc = read_cloud(cloud)
        if measured is not None:
            pairs = pair_points(ref, read_points(measured), unmatched="error", min_pairs=1)
            ids, reference, meas = pairs.ids, pairs.a, pairs.b
        else:
            far = check_points_frame(
                ref.xyz, ref.ids, pc.bounds(), margin_m=max(1.0, 2 * sphere_radius),
                path=points, cloud=f"the cloud {cloud.name}",
            )  # fmt: skip
            if far:
                raise InputError(
                    f"{len(far)} of {len(ref.ids)} check points lie outside the cloud "
                    f"{cloud.name} ({', '.join(far[:10])}{' ...' if len(far) > 10 else ''})",
                    path=points,
                    hint="list only the targets seen in this cloud",
                )
            m = measure_spheres(pc, ref, sphere_radius)
            ids, reference, meas = ref.ids, ref.xyz, m.xyz
        rep = check_points(reference, meas, ids)
        table = Table(title=f"check points ({len(ids)})")
        for col in ("id", "vX (mm)", "vY (mm)", "vZ (mm)", "v3D (mm)"):
            table.add_column(col, justify="right" if col != "id" else "left")
        for i, k in enumerate(ids):
            v = rep.residuals[i] * 1000
            table.add_row(
                k, f"{v[0]:.1f}", f"{v[1]:.1f}", f"{v[2]:.1f}", f"{np.linalg.norm(v):.1f}"
            )
        r = rep.rms
        table.add_row("RMS", *(f"{r[k] * 1000:.1f}" for k in ("x", "y", "z", "3d")))
        console.print(table)
        if out is not None:
            with output_dir(out, force=force) as stage:
                atomic_write_json(stage / "checkpoints.json", rep.to_dict())
                lines = ["id,vx,vy,vz,v3d"] + [
                    f"{k},{rep.residuals[i, 0]:.4f},{rep.residuals[i, 1]:.4f},"
                    f"{rep.residuals[i, 2]:.4f},{rep.residual_3d[i]:.4f}"
                    for i, k in enumerate(ids)
                ]
                atomic_write_text(stage / "checkpoints.csv", "\n".join(lines) + "\n")
                plot_residual_map(rep, stage / "residual_map.png", title=cloud.name)
                write_run_json(
                    stage, step="checkpoints", parameters={"sphere_radius_m": sphere_radius},
                    inputs=[cloud, points, *([measured] if measured else [])],
                    counts={"check_points": len(ids)}, extra={"rms_m": r},
                )  # fmt: skip
                print_run_warnings(stage)
            console.print(f"[green]wrote[/] {out}")
        else:
            err_console.print(
                "[yellow]note:[/] no output folder given: nothing written (use -o DIR)",
                highlight=False,
            )
