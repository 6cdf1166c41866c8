"""Ctrl-C on a benchmark script: one line and exit code 130, never a traceback.

Benchmarks run for minutes to an hour (sweeps), and are stopped by hand.  The shared
helpers (``benchmarks/_common.py``) catch the interrupt in ``main()`` (`interruptible`)
and, through ``sys.excepthook``, while the script still imports its libraries.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCHMARKS))

from _common import INTERRUPTED, interruptible  # noqa: E402


def test_interrupt_in_main_exits_130_with_one_line(capsys: pytest.CaptureFixture) -> None:
    def main() -> None:
        print('{"partial": 1}')
        raise KeyboardInterrupt

    with pytest.raises(SystemExit) as stop:
        interruptible(main)
    assert stop.value.code == 130
    out, err = capsys.readouterr()
    assert out == '{"partial": 1}\n'
    assert err == INTERRUPTED + "\n"


def test_returned_code_is_the_exit_code() -> None:
    with pytest.raises(SystemExit) as stop:
        interruptible(lambda: 2)
    assert stop.value.code == 2
    interruptible(lambda: None)  # no exit at all: the script ends normally


@pytest.mark.parametrize("delay_s", [0.5, 3.0])
def test_real_sigint_while_importing_or_running(delay_s: float) -> None:
    """A SIGINT soon after start lands in the imports (Open3D, scipy), later in main."""
    env = {**os.environ, "PYTHONPATH": str(BENCHMARKS.parent / "src")}
    proc = subprocess.Popen(
        [sys.executable, str(BENCHMARKS / "bench_scanner.py")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    time.sleep(delay_s)
    if proc.poll() is not None:  # pragma: no cover - a machine faster than any seen
        pytest.skip("the benchmark ended before the interrupt")
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert [ln for ln in err.splitlines() if ln.strip()] == [INTERRUPTED], err
