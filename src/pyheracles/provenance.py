"""Provenance sidecar (``run.json``) written into every output folder (DESIGN.md rule 8).

It records the tool version, the step and its parameters, every input file
with its size and SHA-256, timings and point counts, so that a result can be
traced back and reproduced.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import hashlib
import platform
import sys
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from pyheracles.io.atomic import atomic_write_json

__all__ = ["add_to_run_json", "describe_file", "write_run_json"]

RUN_JSON = "run.json"


def describe_file(path: str | Path) -> dict[str, Any]:
    """Path, size in bytes and SHA-256 of a file (hashing streams 1 MiB blocks)."""
    p = Path(path)
    digest = hashlib.sha256()
    with open(p, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return {"path": str(p.resolve()), "bytes": p.stat().st_size, "sha256": digest.hexdigest()}


def _plain(params: Any) -> Any:
    if dataclasses.is_dataclass(params) and not isinstance(params, type):
        return {f.name: _plain(getattr(params, f.name)) for f in dataclasses.fields(params)}
    if isinstance(params, Mapping):
        return {str(k): _plain(v) for k, v in params.items()}
    if isinstance(params, list | tuple):
        return [_plain(v) for v in params]
    return params


def write_run_json(
    outdir: str | Path,
    *,
    step: str,
    parameters: Any = None,
    inputs: Iterable[str | Path] = (),
    timings: Mapping[str, float] | None = None,
    counts: Mapping[str, Any] | None = None,
    extra: Mapping[str, Any] | None = None,
) -> Path:
    """Write ``run.json`` into ``outdir`` atomically and return its path.

    Parameters
    ----------
    outdir
        Output folder (created if needed).
    step
        Name of the step (``complex``, ``supports``, ``bundle`` ...).
    parameters
        Parameter dataclass(es) or mapping; dataclasses are turned into dicts.
    inputs
        Input files, described with size and hash.
    timings
        Seconds per stage.
    counts
        Point or object counts (e.g. the conservation balance).
    extra
        Anything else worth keeping (warnings, assumptions, summary metrics).
    """
    from pyheracles import __version__

    out = Path(outdir)
    record = {
        "tool": "pyheracles",
        "version": __version__,
        "step": step,
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "command": sys.argv,
        "parameters": _plain(parameters),
        "inputs": [describe_file(p) for p in inputs],
        "timings_s": dict(timings or {}),
        "counts": dict(counts or {}),
    }
    record.update(_plain(dict(extra or {})))
    return atomic_write_json(out / RUN_JSON, record)


def add_to_run_json(run_json: str | Path, key: str, messages: Sequence[str], **fields: Any) -> None:
    """Append ``messages`` to the list ``key`` of an existing ``run.json`` (``warnings``,
    ``notes``), set ``fields``, and write it back atomically; a missing or unreadable
    record is left alone."""
    import json

    try:
        record = json.loads(Path(run_json).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return
    old = record.get(key)
    record[key] = [*([old] if isinstance(old, str) else (old or [])), *messages]
    record.update(fields)
    atomic_write_json(run_json, record)
