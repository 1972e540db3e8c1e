"""CPU threads that share a step.

Warp's CPU backend runs each launch on one thread. A CPU launch releases Python's GIL while its kernel runs, so
launches over disjoint index ranges (the first and second half of the spheres, say) run at the same time from
Python threads. :class:`Parallel` is one such phase of a step: each part's launches run in order on one thread of a
process-wide :class:`Team`, and the phase ends when every part has. Which thread runs which part does not change
the result: the kernels that a step shares out write only their own range, and the force sums go through per-part
fixed-point accumulators (accumulate.py), whose integer totals do not depend on the split.

Between the phases of a step, a thread that has replayed its share waits for the others at a :class:`Barrier`: a
one-thread kernel that spins briefly and then sleeps on a Linux futex, so that each thread replays a whole step (its
shares of every phase and the barriers between them) as one Warp CPU graph, and hands over to Python once per many
steps instead of twice per step.
"""

from __future__ import annotations

import ctypes
import os
import platform
import queue
import sys
import threading
from collections.abc import Callable, Sequence

import warp as wp

wp.set_module_options({"enable_backward": False})

Op = Callable[[], object]

MIN_SPHERES_PER_THREAD = 2048
"""a step is shared out only where each thread gets at least this many spheres (below it the hand-over, ~35 us
per phase on a 2-core machine, costs more than it saves)."""


def _futex_call() -> tuple[int, int]:
    """(address of libc's ``syscall``, the futex system call's number) on Linux x86-64 and aarch64; (0, 0)
    elsewhere (the barrier then only spins)."""
    number = {"x86_64": 202, "amd64": 202, "aarch64": 98, "arm64": 98}.get(platform.machine().lower(), 0)
    if not sys.platform.startswith("linux") or number == 0:
        return 0, 0
    try:
        return int(ctypes.cast(ctypes.CDLL(None).syscall, ctypes.c_void_p).value or 0), number
    except Exception:  # noqa: BLE001 - no libc to ask: the barrier only spins
        return 0, 0


FUTEX_SYSCALL, FUTEX_NUMBER = _futex_call()
BARRIER_OK = FUTEX_SYSCALL != 0
"""the barrier can sleep (a Linux futex); elsewhere steps shared between threads hand over through Python."""
_TEAM_LOCK = threading.Lock()
"""held while the process-wide team runs one simulation's threads that meet at barriers: two simulations stepped
at once from different Python threads must not interleave their parts on the team's workers."""
BARRIER_SPINS = 4000
"""spins (each a pause instruction on x86) before a waiting thread sleeps on the futex."""
BARRIER_TIMEOUT_S = 30
"""a thread that has waited this long at a barrier gives up and marks it broken (a lost thread: the caller raises
instead of hanging)."""


@wp.func_native("""
#if !defined(__CUDA_ARCH__)
int* c = (int*)state.data;  // c[0]: threads arrived, c[1]: generation, c[2]: broken
if (__atomic_load_n(c + 2, __ATOMIC_ACQUIRE) != 0) return;
int gen = __atomic_load_n(c + 1, __ATOMIC_ACQUIRE);
if (__atomic_add_fetch(c, 1, __ATOMIC_ACQ_REL) == parties) {
    __atomic_store_n(c, 0, __ATOMIC_RELAXED);
    __atomic_store_n(c + 1, gen + 1, __ATOMIC_RELEASE);
    if (sys_fn != 0)  // FUTEX_WAKE_PRIVATE, every waiter
        ((long (*)(long, ...))sys_fn)((long)futex_nr, (long)(c + 1), 129L, 0x7fffffffL, 0L, 0L, 0L);
    return;
}
int spins = 0;
long slept_ms = 0;
struct { long sec; long nsec; } timeout = {0, 100000000L};  // 0.1 s per sleep
while (__atomic_load_n(c + 1, __ATOMIC_ACQUIRE) == gen) {
    if (__atomic_load_n(c + 2, __ATOMIC_ACQUIRE) != 0) return;  // broken (a thread gave up, or raised)
    if (spins < spin_limit || sys_fn == 0) {
#if defined(__x86_64__) || defined(__i386__)
        __builtin_ia32_pause();
#endif
        spins++;
    } else {  // FUTEX_WAIT_PRIVATE while the generation is still gen (returns at once if it has moved on)
        ((long (*)(long, ...))sys_fn)((long)futex_nr, (long)(c + 1), 128L, (long)gen, (long)&timeout, 0L, 0L);
        slept_ms += 100;
        if (slept_ms > 1000L * (long)timeout_s) {
            __atomic_store_n(c + 2, 1, __ATOMIC_RELEASE);
            return;
        }
    }
}
#endif
""")
def _barrier_wait(state: wp.array(dtype=int), parties: int, sys_fn: wp.uint64, futex_nr: int, spin_limit: int,
                  timeout_s: int):
    ...


@wp.kernel
def barrier_kernel(state: wp.array(dtype=int), parties: int, sys_fn: wp.uint64, futex_nr: int, spin_limit: int,
                   timeout_s: int):
    """Wait until ``parties`` threads have launched it (one thread each): state = (arrived, generation, broken)."""
    _barrier_wait(state, parties, sys_fn, futex_nr, spin_limit, timeout_s)


class Barrier:
    """A barrier between the CPU threads that replay a step's graphs (:func:`barrier_kernel` in each graph)."""

    def __init__(self, parties: int) -> None:
        self.parties = int(parties)
        self.state = wp.zeros(3, dtype=int, device="cpu")
        self._view = self.state.numpy()  # a view: the CPU array's memory

    def record(self) -> Callable[[], object]:
        """A recorded launch of the barrier (to capture into a thread's graph)."""
        return wp.launch(barrier_kernel, 1, inputs=[self.state, self.parties, wp.uint64(FUTEX_SYSCALL),
                                                    FUTEX_NUMBER, BARRIER_SPINS, BARRIER_TIMEOUT_S],
                         device="cpu", record_cmd=True).launch

    @property
    def broken(self) -> bool:
        """A thread gave up waiting (BARRIER_TIMEOUT_S), or :meth:`break_` was called."""
        return bool(self._view[2])

    def break_(self) -> None:
        """Release every thread waiting at the barrier now and let later arrivals pass (a thread raised: the
        others must not wait for it)."""
        self._view[2] = 1
        if FUTEX_SYSCALL:
            libc_syscall = ctypes.CFUNCTYPE(ctypes.c_long, ctypes.c_long, ctypes.c_void_p, ctypes.c_long,
                                            ctypes.c_long)(FUTEX_SYSCALL)
            libc_syscall(FUTEX_NUMBER, self.state.ptr + 4, 129, 0x7FFFFFFF)  # FUTEX_WAKE_PRIVATE on the generation

    def reset(self) -> None:
        """Zero the barrier (no thread may be waiting at it)."""
        self._view[:] = 0


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


def run_locked(parts: Sequence[Sequence[Op]]) -> None:
    """:meth:`Team.run` on the process-wide team, one caller at a time (threads that meet at barriers)."""
    with _TEAM_LOCK:
        _TEAM.run(parts)


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
