"""``heracles simulate``: bad input is one clear line and exit 2, nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyheracles.cli import main


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["--family", "nope"], "unknown scene family"),
        (["--family", "supports", "--seed", "-1"], "seed must be"),
        (["--family", "supports", "--set", "n_stations_inside=0",
          "--set", "n_stations_outside=0"], "no station"),
        (["--family", "roof", "--set", "n_stations=0"], "n_stations"),
        (["--family", "church", "--set", "n_interior_stations=0"], "n_interior_stations"),
        (["--family", "terrain", "--set", "bogus=1"], "no parameter 'bogus'"),
        (["--family", "roof", "--set", "n_stations"], "KEY=VALUE"),
    ],
)  # fmt: skip
def test_bad_simulate_input_exits_2(args: list[str], said: str, tmp_path: Path, capsys) -> None:
    out = tmp_path / "sim"
    assert main(["--no-report", "simulate", *args, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert said in err and "Traceback" not in err
    assert not out.exists()
    assert not any(p.name.startswith(".heracles-partial") for p in tmp_path.iterdir())
