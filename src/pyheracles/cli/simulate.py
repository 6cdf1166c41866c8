"""``heracles simulate``: draw one member of a scene family and scan it."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

__all__ = ["parse_overrides", "register"]

_HELP = "\n\n".join(
    [
        "Draw one member of a randomised scene family and scan it with the scan simulator "
        "(terrestrial stations, photogrammetry, airborne strips; occlusion, range-dependent "
        "density, grazing drop-out, noise, mixed pixels and outliers).",
        "Families: supports (buildings with columns, piers, engaged columns), roof (timber "
        "roof frames with boarding, walls and stored timber), church (interior and exterior "
        "clouds in their own frames, for registration), complex (a walled complex from the "
        "air, with its GIS layers), terrain (steep, terraced and vegetated ground from the air).",
        "Writes into OUTDIR: cloud.laz (LAS 1.4, scanner attributes, no reference labels; the "
        "church writes interior.laz and exterior.laz), truth.npz (int arrays instance, "
        "class_id, part and bool outlier aligned with the cloud; truth_<cloud>.npz for the "
        "church, with the true transforms), scene.json (classes, parts, objects with their "
        "true primitives, stations, drawn parameters) and preview.png.",
        "Examples:",
        "  heracles simulate --family supports --seed 3 -o sim/supports3",
        "  heracles simulate --family roof --seed 0 --set n_stations=2 -o sim/roof0",
    ]
)


def parse_overrides(items: list[str]) -> dict[str, object]:
    """``["key=value", ...]`` to a dict; values read as YAML scalars (``3``, ``0.5``, ``true``)."""
    import yaml

    from pyheracles.errors import InputError

    out: dict[str, object] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise InputError(f"--set {item!r} is not KEY=VALUE", hint="e.g. --set n_stations=2")
        try:
            out[key.strip()] = yaml.safe_load(value)
        except yaml.YAMLError as exc:
            raise InputError(f"--set {item!r}: value is not readable ({exc.problem})") from exc
    return out


def register(app: typer.Typer) -> None:
    """Add the ``simulate`` subcommand to ``app``."""

    @app.command("simulate", help=_HELP)
    def simulate_command(
        family: Annotated[
            str, typer.Option("--family", "-f", help="supports, roof, church, complex, terrain.")
        ],
        outdir: Annotated[Path, typer.Option("-o", "--out", "--outdir", help="Output folder.")],
        seed: Annotated[int, typer.Option("--seed", "-s", help="Draw number (>= 0).")] = 0,
        overrides: Annotated[
            list[str] | None,
            typer.Option("--set", help="Fix a drawn parameter, KEY=VALUE (repeatable)."),
        ] = None,
        preview: Annotated[
            bool, typer.Option("--preview/--no-preview", help="Write preview.png.")
        ] = True,
        force: Annotated[
            bool, typer.Option("--force", help="Write into a non-empty output folder.")
        ] = False,
    ) -> None:
        import time

        from rich.table import Table

        from pyheracles.cli.common import console, output_dir, print_run_warnings
        from pyheracles.progress import enabled, stage
        from pyheracles.provenance import write_run_json
        from pyheracles.synthetic.families import family as family_fn
        from pyheracles.synthetic.families import simulate, write_simulation

        family_fn(family)  # an unknown family is refused before any work
        kw = parse_overrides(overrides or [])
        with output_dir(outdir, force=force) as out, enabled(console):
            t = time.perf_counter()
            with stage(f"simulating {family} seed {seed}"):
                sim = simulate(family, seed, **kw)
            t_scan = time.perf_counter() - t
            t = time.perf_counter()
            with stage("writing"):
                written = write_simulation(sim, out, preview=preview)
            write_run_json(
                out,
                step="simulate",
                parameters={"family": family, "seed": seed, "overrides": kw, "drawn": sim.params},
                timings={"simulate": t_scan, "write": time.perf_counter() - t},
                counts={name: len(res) for name, res in sim.clouds.items()},
                extra={"outputs": sorted(p.name for p in written.values())},
            )
            print_run_warnings(out)
        table = Table(title=f"heracles simulate: {family} seed {seed}")
        table.add_column("cloud")
        table.add_column("points", justify="right")
        table.add_column("outliers", justify="right")
        table.add_column("sources", justify="right")
        for name, res in sim.clouds.items():
            table.add_row(
                name,
                f"{len(res):,}",
                f"{int(res.outlier.sum()):,}",
                str(len(set(res.point_source_id.tolist()))),
            )
        console.print(table)
        console.print(
            f"{len(sim.scene.objects)} objects; simulated in {t_scan:.1f} s; "
            f"wrote {', '.join(sorted(p.name for p in written.values()))} to {outdir}"
        )
