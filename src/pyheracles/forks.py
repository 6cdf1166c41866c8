"""Independent Python-heavy pieces of work shared with a forked copy of this process.

Why a fork and not threads: the per-support measurements of step 2a (cutting a support
out of its cookie, fitting its primitive) are many small numpy and scipy calls driven
by Python, which holds the interpreter lock; threads run them one at a time.  A child
made with ``fork`` shares the parent's memory (the 10 M point cloud is not copied: its
pages are shared until written), computes its share of the pieces and sends back only
their results, while the parent computes the rest.  Each piece runs the same code on
the same inputs in either process, so the results do not depend on where it ran.

``HERACLES_THREADS=1`` (or a machine with one core, no ``fork``, a daemonic process such
as a pool's worker, or a fork that fails) runs every piece in the calling process.  A
child that fails or dies leaves its pieces to the parent, which computes them again (an
error is then raised here as in a plain loop).

Examples
--------
>>> map_fork(lambda k: k * k, range(5), cost=[1, 1, 1, 1, 1])
[0, 1, 4, 9, 16]
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Sequence
from typing import TypeVar

from pyheracles.threads import n_workers

__all__ = ["ForkedCall", "map_fork", "split_by_cost"]

T = TypeVar("T")
R = TypeVar("R")


def _fork(target: Callable, args: tuple) -> tuple[object, object] | None:
    """A started forked process running ``target(*args, send)`` and the receiving end of
    its pipe; None where no child can be made (one core, no fork, a daemonic process)."""
    if n_workers() < 2 or not hasattr(os, "fork") or multiprocessing.current_process().daemon:
        return None
    ctx = multiprocessing.get_context("fork")
    recv, send = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=target, args=(*args, send), daemon=True)
    try:
        proc.start()
    except (OSError, AssertionError):  # out of memory or processes: all pieces here
        recv.close()
        send.close()
        return None
    send.close()
    return proc, recv


def split_by_cost(cost: Sequence[float]) -> tuple[list[int], list[int]]:
    """Two groups of piece numbers of about equal total cost (the costliest piece first,
    each to the group with less so far); the parent's group first."""
    groups: tuple[list[int], list[int]] = ([], [])
    total = [0.0, 0.0]
    for k in sorted(range(len(cost)), key=lambda i: -cost[i]):
        g = 0 if total[0] <= total[1] else 1
        groups[g].append(k)
        total[g] += cost[k]
    return sorted(groups[0]), sorted(groups[1])


def _child(fn: Callable[[T], R], items: list[T], mine: list[int], conn) -> None:
    """The forked process: computes its pieces, sends them, ends without cleanup."""
    code = 0
    try:
        conn.send(("ok", {k: fn(items[k]) for k in mine}))
    except BaseException as exc:  # the parent computes the pieces again
        try:
            conn.send(("error", repr(exc)))
        except BaseException:
            code = 1
    finally:
        conn.close()
    os._exit(code)  # no atexit handlers, no flush of the parent's buffers


def map_fork(fn: Callable[[T], R], items: Sequence[T], *, cost: Sequence[float]) -> list[R]:
    """``[fn(x) for x in items]``, about half of the cost computed by a forked child.

    ``fn``'s results must be picklable; side effects in the child (changes to its
    arguments) are lost, so ``fn`` must return all that it changes.  ``cost`` (one number
    per piece, e.g. its point count) balances the two processes.
    """
    todo = list(items)
    parent_part, child_part = split_by_cost(cost)
    forked = _fork(_child, (fn, todo, child_part)) if len(todo) >= 2 else None
    if forked is None:
        return [fn(x) for x in todo]
    proc, recv = forked
    out: dict[int, R] = {}
    try:
        for k in parent_part:
            out[k] = fn(todo[k])
        try:
            status, payload = recv.recv()
        except (EOFError, OSError):
            status, payload = "died", None
    finally:
        recv.close()
        if proc.is_alive() and len(out) < len(parent_part):  # the parent failed first
            proc.kill()
        proc.join()
    if status == "ok":
        out.update(payload)
    else:  # the child's pieces again, here: the same results, or the same error
        for k in child_part:
            out[k] = fn(todo[k])
    return [out[k] for k in range(len(todo))]


class ForkedCall:
    """``fn()`` computed by a forked child while this process goes on with other work;
    :meth:`result` waits for it (computing it here if the child failed, or on one core).

    Examples
    --------
    >>> call = ForkedCall(lambda: sum(range(10)))
    >>> call.result()
    45
    """

    def __init__(self, fn: Callable[[], R]) -> None:
        self.fn = fn
        self.proc = None
        forked = _fork(_child, (lambda _: fn(), [None], [0]))
        if forked is not None:
            self.proc, self.recv = forked

    def result(self) -> R:
        """The value of ``fn()``."""
        if self.proc is None:
            return self.fn()
        try:
            status, payload = self.recv.recv()
        except (EOFError, OSError):
            status, payload = "died", None
        finally:
            self.recv.close()
            self.proc.join()
            self.proc = None
        return payload[0] if status == "ok" else self.fn()

    def __del__(self) -> None:  # an abandoned call (an error in the meantime)
        proc = getattr(self, "proc", None)
        if proc is not None and proc.is_alive():
            proc.kill()
            proc.join()
