"""``heracles evaluate``: score a segmentation against a reference, object by object."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import numpy as np
import pandas as pd
import typer

__all__ = ["register"]

_HELP = """Score a segmented cloud against reference labels, object by object.

RESULT is a cloud written by a segmentation step (extra dimension 'instance',
ground as ASPRS class 2); the reference is the SAME cloud in the same point
order, carrying reference object ids (extra dimension 'reference_instance' or
'instance') or, with --reference-polygons, building points (--reference-class)
that are turned into one reference object per polygon (inside or within
--buffer metres, the nearest polygon wins).  The polygons get the checks of
step 1 ('heracles complex'): valid polygons (--fix-invalid repairs them), the
cloud's CRS (--reproject brings them into it), overlap with the cloud.

Objects are paired by maximum overlap, or with --key by a column present in
both objects tables (e.g. the GIS feature id 'fid').  Prints precision, recall,
F1 and % unclassified per object with mean and median rows (Murtiyoso 2020,
tables 5.1/5.2) and ground precision/recall.

Writes evaluation.csv (one row per object, then mean and median) and
evaluation.json into --out (default: RESULT's folder).

Examples:

  heracles evaluate out/complex/segmented.laz --reference scene/cloud.laz

  heracles evaluate out/complex/segmented.laz --reference scene/cloud.laz --key fid

  heracles evaluate out/delft/segmented.laz --reference ahn3_tile1.laz \\
      --reference-polygons bgt/bgt_pand.sqlite --key gml_id
"""


def _read_table(path: Path) -> Any:
    """An objects table from CSV or any vector format pyogrio reads."""
    import pandas as pd

    from pyheracles.errors import InputError

    if not path.is_file():
        raise InputError("objects table not found", path=path, hint="pass it explicitly")
    if path.suffix.lower() == ".csv":
        try:
            return pd.read_csv(path)
        except (OSError, ValueError) as exc:
            raise InputError(f"cannot read the table: {exc}", path=path) from exc
    from pyheracles.io import read_layer

    return read_layer(path)


def _default_table(cloud_path: Path, names: tuple[str, ...]) -> Path | None:
    for name in names:
        candidate = cloud_path.parent / name
        if candidate.is_file():
            return candidate
    return None


def _keys(table: Any, column: str, path: Path, *, instance_col: str | None) -> dict[int, Any]:
    """Instance id -> key from a table (``instance_col`` None: row k is instance k + 1)."""
    from pyheracles.errors import InputError

    if column not in table.columns:
        raise InputError(
            f"no column {column!r} in the objects table",
            path=path,
            hint=f"choose --key among {', '.join(map(str, table.columns))}",
        )
    if instance_col is None:
        ids = np.arange(1, len(table) + 1)
    else:
        if instance_col not in table.columns:
            raise InputError(f"the objects table has no {instance_col!r} column", path=path)
        ids = table[instance_col].to_numpy()
    return {int(i): v for i, v in zip(ids, table[column].tolist(), strict=True)}


def _labels_field(cloud: Any, field: str | None, candidates: tuple[str, ...], path: Path):
    from pyheracles.errors import InputError

    names = (field,) if field else candidates
    for name in names:
        if name in cloud.attributes:
            return name, np.asarray(cloud.attributes[name])
    raise InputError(
        f"the cloud has no object id dimension ({' or '.join(names)})",
        path=path,
        hint="name it with --result-field / --reference-field; available: "
        + ", ".join(sorted(cloud.attributes)),
    )


def _fmt(v: Any, pct: bool = False) -> str:
    if v is None or v is pd.NA or (isinstance(v, float) and np.isnan(v)):
        return "-"
    if isinstance(v, float | np.floating):
        return f"{v:.1f}" if pct else f"{v:.3f}"
    return str(v)


def register(app: typer.Typer) -> None:
    """Add the ``evaluate`` subcommand to ``app``."""

    @app.command("evaluate", help=_HELP)
    def evaluate_command(
        result: Annotated[Path, typer.Argument(metavar="RESULT", help="Segmented cloud.")],
        reference: Annotated[
            Path, typer.Option("--reference", "-r", help="Reference cloud (same points).")
        ],
        key: Annotated[
            str | None,
            typer.Option("--key", "-k", help="Pair objects by this column of both tables."),
        ] = None,
        result_field: Annotated[
            str | None, typer.Option(help="Object id dimension of RESULT (default: instance).")
        ] = None,
        reference_field: Annotated[
            str | None,
            typer.Option(help="Object id dimension of the reference (reference_instance)."),
        ] = None,
        result_objects: Annotated[
            Path | None, typer.Option(help="RESULT's objects table (objects.gpkg/.csv beside).")
        ] = None,
        reference_objects: Annotated[
            Path | None,
            typer.Option(help="Reference objects table (reference_objects.csv beside)."),
        ] = None,
        reference_polygons: Annotated[
            Path | None, typer.Option(help="Build the reference from these polygons.")
        ] = None,
        polygons_layer: Annotated[
            str | None, typer.Option(help="Layer of --reference-polygons.")
        ] = None,
        reference_class: Annotated[
            int, typer.Option(help="ASPRS class of the reference points (polygons).")
        ] = 6,
        buffer: Annotated[
            float, typer.Option(help="Distance to a polygon still inside it, metres.")
        ] = 1.0,
        reproject: Annotated[
            bool, typer.Option(help="Reproject --reference-polygons into the cloud's CRS.")
        ] = False,
        fix_invalid: Annotated[
            bool, typer.Option(help="Repair invalid reference polygons (make_valid).")
        ] = False,
        out: Annotated[
            Path | None,
            typer.Option("--out", "-o", "--outdir", help="Output folder (default: RESULT's)."),
        ] = None,
        rows: Annotated[int, typer.Option(help="Object rows shown (all are written).")] = 40,
    ) -> None:
        from rich.table import Table

        from pyheracles.cli.common import console
        from pyheracles.errors import InputError
        from pyheracles.evaluate import evaluate_objects, ground_scores, reference_from_polygons
        from pyheracles.io import atomic_path, atomic_write_json, read_cloud

        notes: list[str] = []
        res_cloud = read_cloud(result)
        ref_cloud = read_cloud(reference)
        if len(res_cloud) != len(ref_cloud):
            raise InputError(
                f"RESULT has {len(res_cloud)} points, the reference {len(ref_cloud)}",
                path=result,
                hint="evaluate the segmented cloud written for this very input (same points)",
            )
        if len(res_cloud) == 0:
            raise InputError("the cloud has no points", path=result)
        gap = float(np.abs(res_cloud.world_xyz() - ref_cloud.world_xyz()).max())
        if gap > 0.01:
            raise InputError(
                f"RESULT and reference points differ by up to {gap:.3f} m: not the same points "
                "in the same order",
                path=result,
                hint="segmentation outputs keep the input order; compare with that input",
            )
        _, pred = _labels_field(res_cloud, result_field, ("instance",), result)

        ref_table = None
        ref_table_path: Path | None = None
        if reference_polygons is not None:
            from dataclasses import replace

            from pyheracles.complex import prepare_layers
            from pyheracles.io import read_layer

            polys = read_layer(reference_polygons, polygons_layer)
            # step 1's layer checks: valid polygons, the cloud's CRS, overlap with the cloud
            if ref_cloud.crs is None and polys.crs is not None:
                notes.append(
                    f"the reference cloud has no CRS; taken to be the polygons' "
                    f"{polys.crs.to_string()}"
                )
                ref_cloud = replace(ref_cloud, crs=polys.crs)
            elif ref_cloud.crs is None and polys.crs is None:
                notes.append(
                    "neither the reference cloud nor the polygons have a CRS: they are taken "
                    "to be in the same coordinates"
                )
            elif reproject and polys.crs is not None and not polys.crs.equals(ref_cloud.crs):
                notes.append(
                    f"reference polygons reprojected from {polys.crs.to_string()} to "
                    f"{ref_cloud.crs.to_string()}"
                )
            polys = prepare_layers(
                {"reference": polys}, ref_cloud, reproject=reproject, fix_invalid=fix_invalid
            )["reference"]
            cls = ref_cloud.attributes.get("classification")
            if cls is None:
                raise InputError("the reference has no classification", path=reference)
            mask = np.asarray(cls) == reference_class
            if not mask.any():
                raise InputError(
                    f"the reference has no point of class {reference_class}",
                    path=reference,
                    hint="choose --reference-class",
                )
            ref = reference_from_polygons(ref_cloud.world_xyz(), mask, polys, buffer)
            ref_table, ref_table_path = polys, reference_polygons
            ref_keys_instance_col = None
            ref_field = f"class {reference_class} in polygons"
        else:
            ref_field, ref = _labels_field(
                ref_cloud, reference_field, ("reference_instance", "instance"), reference
            )
            ref_table_path = reference_objects or _default_table(
                reference, ("reference_objects.csv", "objects.gpkg", "objects.csv")
            )
            if ref_table_path is not None:
                ref_table = _read_table(ref_table_path)
            ref_keys_instance_col = "instance"

        kwargs: dict[str, Any] = {}
        if key is not None:
            res_table_path = result_objects or _default_table(
                result, ("objects.gpkg", "objects.csv")
            )
            if res_table_path is None or ref_table is None or ref_table_path is None:
                raise InputError(
                    "--key needs the objects tables of both RESULT and the reference",
                    path=result,
                    hint="pass --result-objects and --reference-objects",
                )
            res_table = _read_table(res_table_path)
            kwargs = {
                "match": "key",
                "predicted_keys": _keys(res_table, key, res_table_path, instance_col="instance"),
                "reference_keys": _keys(
                    ref_table, key, ref_table_path, instance_col=ref_keys_instance_col
                ),
            }
        if ref_table is not None and ref_keys_instance_col == "instance":
            if "instance" in ref_table.columns:
                kwargs["reference_objects"] = ref_table.drop(columns="geometry", errors="ignore")
        ev = evaluate_objects(pred, ref, **kwargs)

        res_cls = res_cloud.attributes.get("classification")
        ref_cls = ref_cloud.attributes.get("classification")
        ground = None
        if res_cls is not None and ref_cls is not None and np.any(np.asarray(res_cls) == 2):
            ground = ground_scores(np.asarray(res_cls) == 2, np.asarray(ref_cls) == 2)

        outdir = out or result.parent
        table = ev.table()
        csv_path = outdir / "evaluation.csv"
        with atomic_path(csv_path) as tmp:
            table.to_csv(tmp, index=False)
        payload = {
            "result": str(result),
            "reference": str(reference),
            "reference_labels": ref_field,
            "reference_polygons": None if reference_polygons is None else str(reference_polygons),
            "buffer_m": buffer if reference_polygons is not None else None,
            "notes": notes,
            **ev.to_dict(),
            "ground": ground,
        }
        json_path = atomic_write_json(outdir / "evaluation.json", payload)

        show = Table(title=f"Per-object scores ({ev.match} matching)")
        wide = console.width >= 110  # names only when the terminal has room
        text_cols = [
            c for c in ("object", "name") if c in table.columns and (wide or c == "object")
        ]
        for col in text_cols:
            show.add_column(col, overflow="ellipsis", no_wrap=True, max_width=22)
        for col in ("n ref", "n pred", "prec.", "recall", "F1", "uncl.%"):
            show.add_column(col, justify="right", no_wrap=True, min_width=6)
        body = table.iloc[:-2]
        for _, r in body.head(rows).iterrows():
            show.add_row(
                *[_fmt(r[c]) for c in text_cols], str(r["n_reference"]), str(r["n_predicted"]),
                _fmt(r["precision"]), _fmt(r["recall"]), _fmt(r["f1"]),
                _fmt(r["unclassified_pct"], pct=True),
            )  # fmt: skip
        blanks = [""] * (len(text_cols) + 5)
        if len(body) > rows:
            show.add_row(f"+{len(body) - rows} in CSV", *blanks)
        for _, r in table.iloc[-2:].iterrows():
            show.add_row(
                f"[bold]{r['object']}[/]", *[""] * (len(text_cols) + 1), _fmt(r["precision"]),
                _fmt(r["recall"]), _fmt(r["f1"]), _fmt(r["unclassified_pct"], pct=True),
            )  # fmt: skip
        console.print(show)
        if "layer" in ev.objects.columns and ev.objects["layer"].nunique() > 1:
            per = ev.summary(by="layer")
            by_layer = Table(title="Per layer")
            for col in ("layer", "statistic", "prec.", "recall", "F1", "uncl.%"):
                by_layer.add_column(
                    col, justify="left" if col in ("layer", "statistic") else "right"
                )
            for (layer, stat), r in per.iterrows():
                by_layer.add_row(
                    str(layer), str(stat), _fmt(r["precision"]), _fmt(r["recall"]),
                    _fmt(r["f1"]), _fmt(r["unclassified_pct"], pct=True),
                )  # fmt: skip
            console.print(by_layer)
        totals = ev.totals()
        summary = Table(title="Summary")
        summary.add_column("item")
        summary.add_column("value", justify="right")
        summary.add_row("reference objects (with points)", str(totals["n_reference_objects"]))
        summary.add_row("matched", str(totals["n_matched"]))
        summary.add_row("predicted objects unmatched", str(totals["n_unmatched_predicted"]))
        if ground is not None:
            summary.add_row("ground precision", _fmt(ground["precision"]))
            summary.add_row("ground recall", _fmt(ground["recall"]))
            summary.add_row("ground total error %", _fmt(ground["total"], pct=True))
        summary.add_row("table", str(csv_path))
        summary.add_row("json", str(json_path))
        console.print(summary)
        for note in notes:
            console.print(f"[yellow]note:[/] {note}", highlight=False)
