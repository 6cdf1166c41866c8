"""Pieces of work shared with a forked child (:mod:`pyheracles.forks`, issue 12 speed)
give what the plain loop gives, in order, whichever process computed them; a child
that fails leaves its pieces to the parent; the supports step gives the same supports
on one process and on two."""

from __future__ import annotations

import os

import numpy as np
import pytest

from pyheracles.forks import map_fork, split_by_cost


def test_split_by_cost_balances_the_two_groups() -> None:
    cost = [10, 1, 1, 7, 3, 2, 2]
    a, b = split_by_cost(cost)
    assert sorted(a + b) == list(range(len(cost)))
    assert abs(sum(cost[k] for k in a) - sum(cost[k] for k in b)) <= 2


def test_map_fork_returns_the_loop_results_in_order(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HERACLES_THREADS", "2")
    parent = os.getpid()
    out = map_fork(lambda k: (k * k, os.getpid()), range(8), cost=[1] * 8)
    assert [v for v, _ in out] == [k * k for k in range(8)]
    pids = {pid for _, pid in out}
    assert parent in pids and len(pids) == 2  # half of them ran in the child


def test_map_fork_on_one_thread_runs_here(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HERACLES_THREADS", "1")
    assert {pid for pid in map_fork(lambda k: os.getpid(), range(4), cost=[1] * 4)} == {os.getpid()}


def test_a_daemonic_process_runs_every_piece_itself(monkeypatch: pytest.MonkeyPatch) -> None:
    """A pool's worker may not have children: the pieces run in it, as the loop."""
    import types

    from pyheracles import forks

    monkeypatch.setenv("HERACLES_THREADS", "2")
    monkeypatch.setattr(
        forks.multiprocessing, "current_process", lambda: types.SimpleNamespace(daemon=True)
    )
    assert map_fork(lambda k: os.getpid(), range(4), cost=[1] * 4) == [os.getpid()] * 4
    assert forks.ForkedCall(os.getpid).result() == os.getpid()


def test_a_failing_child_leaves_its_pieces_to_the_parent(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("HERACLES_THREADS", "2")
    parent = os.getpid()

    def piece(k: int) -> int:
        if os.getpid() != parent:
            raise RuntimeError("child fails")
        return k + 1

    assert map_fork(piece, range(6), cost=[1] * 6) == [1, 2, 3, 4, 5, 6]

    def error(k: int) -> int:
        raise ValueError(k)

    with pytest.raises(ValueError):  # the same error as the loop
        map_fork(error, range(4), cost=[1] * 4)


def test_supports_are_the_same_on_one_process_and_two(monkeypatch: pytest.MonkeyPatch) -> None:
    """The hall's supports (changes to the shapes made in the child come back: the
    engaged columns' classes, what they carry)."""
    from pyheracles.supports import detect_supports
    from pyheracles.synthetic.buildings import building_scene

    scene = building_scene("hall", spacing_m=0.05, rng=0)
    found = {}
    for threads in ("1", "2"):
        monkeypatch.setenv("HERACLES_THREADS", threads)
        found[threads] = detect_supports(scene.xyz)
    one, two = found["1"], found["2"]
    np.testing.assert_array_equal(one.instance, two.instance)
    assert one.objects.equals(two.objects)
    assert one.notes == two.notes
    assert set(two.objects["class"]) == {"column", "engaged_column"}
