"""Shared fixtures: the real data folder (../shared/data) and small synthetic clouds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """Path of ../shared/data; the test is skipped when the folder is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real data folder {SHARED_DATA} is absent (fresh clone without ../shared)")
    return SHARED_DATA


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded random generator."""
    return np.random.default_rng(12345)


@pytest.fixture(autouse=True)
def _no_reports_unless_asked(request, monkeypatch) -> None:
    """Commands skip report.html in tests (seconds each), except the tests of the reports."""
    if "report" not in request.node.module.__name__:
        monkeypatch.setenv("HERACLES_NO_REPORT", "1")


def pytest_configure(config) -> None:
    """Ctrl-C as a terminal delivers it, whatever started the test run.

    A shell without job control starts background commands with SIGINT ignored, and a
    process keeps an ignored signal across exec: the Ctrl-C tests (exit code 130, no
    traceback) would then see no interrupt at all, in process or in the commands they
    start.  The default handler here is reset to the default action in those commands.
    """
    import signal

    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
