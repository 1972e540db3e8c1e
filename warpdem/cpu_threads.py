"""CPU threads that share a step.

Warp's CPU backend runs each launch on one thread. A CPU launch releases Python's GIL while its kernel runs, so
launches over disjoint index ranges (the first and second half of the spheres, say) run at the same time from
Python threads. :class:`Parallel` is one such phase of a step: each part's launches run in order on one thread of a
process-wide :class:`Team`, and the phase ends when every part has. Which thread runs which part does not change
the result: the kernels that a step shares out write only their own range, and the force sums go through per-part
fixed-point accumulators (accumulate.py), whose integer totals do not depend on the split.
"""

from __future__ import annotations

import os
import queue
import threading
from collections.abc import Callable, Sequence

Op = Callable[[], object]

MIN_SPHERES_PER_THREAD = 2048
"""a step is shared out only where each thread gets at least this many spheres (below it the hand-over, ~35 us
per phase on a 2-core machine, costs more than it saves)."""


def default_threads() -> int:
    """Threads a CPU simulation uses: ``WARPDEM_CPU_THREADS`` if set, else the cores this process may run on."""
    env = os.environ.get("WARPDEM_CPU_THREADS", "").strip()
    if env:
        try:
            n = int(env)
        except ValueError:
            n = 0
        if n < 1:
            from .errors import InputError

            raise InputError(f"WARPDEM_CPU_THREADS must be a positive integer, got {env!r}")
        return n
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


class Team:
    """Worker threads (daemons) that run lists of ops handed to them; the calling thread is the team's first."""

    def __init__(self) -> None:
        self._inbox: list[queue.SimpleQueue] = []
        self._outbox: queue.SimpleQueue = queue.SimpleQueue()
        self._lock = threading.Lock()

    def _grow(self, workers: int) -> None:
        with self._lock:
            while len(self._inbox) < workers:
                box: queue.SimpleQueue = queue.SimpleQueue()
                threading.Thread(target=self._work, args=(box,), daemon=True, name="warpdem-cpu").start()
                self._inbox.append(box)

    def _work(self, box: queue.SimpleQueue) -> None:
        while True:
            ops, reply = box.get()
            try:
                for op in ops:
                    op()
                reply.put(None)
            except BaseException as exc:  # handed to the caller, which raises it
                reply.put(exc)

    def run(self, parts: Sequence[Sequence[Op]]) -> None:
        """Run each part's ops in order, part 0 on the calling thread and the others on workers; return when all
        are done, raising the first error a part met."""
        self._grow(len(parts) - 1)
        reply: queue.SimpleQueue = queue.SimpleQueue()
        for box, ops in zip(self._inbox[:len(parts) - 1], parts[1:], strict=True):
            box.put((ops, reply))
        error: BaseException | None = None
        try:
            for op in parts[0]:
                op()
        except BaseException as exc:
            error = exc
        for _ in parts[1:]:
            got = reply.get()
            if error is None and got is not None:
                error = got
        if error is not None:
            raise error


_TEAM = Team()


class Parallel:
    """One phase of a step: ``parts[p]`` (a list of ops) runs on thread p; calling it runs them all."""

    def __init__(self, name: str, parts: Sequence[Sequence[Op]]) -> None:
        self.name = name
        self.parts = [list(ops) for ops in parts]

    def __call__(self) -> None:
        _TEAM.run(self.parts)


def split(weights_before: Sequence[int] | object, total: int, parts: int) -> list[int]:
    """Cut points 0 = c_0 <= ... <= c_parts = n of n items so that each part holds about total / parts of the work,
    given ``weights_before`` (n + 1,): the work of the items before each index (a cumulative sum starting at 0)."""
    import numpy as np

    cum = np.asarray(weights_before)
    n = len(cum) - 1
    cuts = np.searchsorted(cum, np.arange(parts + 1) * total / parts, side="left").clip(0, n)
    cuts[0], cuts[-1] = 0, n
    return [int(c) for c in np.maximum.accumulate(cuts)]
