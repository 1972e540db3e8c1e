"""The barrier between CPU threads that replay a step's graphs (cpu_threads.Barrier)."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
import warp as wp

import warpdem as wd
from warpdem import cpu_threads

pytestmark = pytest.mark.skipif(not cpu_threads.BARRIER_OK, reason="the barrier sleeps on a Linux futex only")


@wp.kernel
def _publish(mine: wp.array(dtype=int), p: int, value: int):
    mine[p] = value


@wp.kernel
def _check_others(seen: wp.array(dtype=int), parties: int, p: int, value: int, errors: wp.array(dtype=int)):
    for q in range(parties):
        if seen[q] != value:
            errors[p] = errors[p] + 1


@pytest.mark.parametrize("spins", [cpu_threads.BARRIER_SPINS, 0])
def test_barrier_orders_what_threads_write_before_it_and_read_after_it(monkeypatch: object, spins: int) -> None:
    # Reference: the barrier's contract. Each of 3 Python threads (more than this machine's 2 cores, so threads
    # are descheduled while others wait) writes its round number, waits at the barrier, and checks that every
    # thread's write of that round is visible, for 2,000 rounds; any thread passing early would see an older
    # round. Spinning first, and sleeping at once (spins 0: the futex path alone).
    monkeypatch.setattr(cpu_threads, "BARRIER_SPINS", spins)
    parties, rounds = 3, 2000
    barrier = cpu_threads.Barrier(parties)
    wait = barrier.record()
    written = wp.zeros(parties, dtype=int, device="cpu")
    errors = wp.zeros(parties, dtype=int, device="cpu")

    def run(p: int) -> None:
        for r in range(1, rounds + 1):
            wp.launch(_publish, 1, inputs=[written, p, r], device="cpu")
            wait()
            wp.launch(_check_others, 1, inputs=[written, parties, p, r, errors], device="cpu")
            wait()  # nobody writes round r + 1 before all have checked round r

    threads = [threading.Thread(target=run, args=(p,)) for p in range(parties)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert not any(t.is_alive() for t in threads)
    np.testing.assert_array_equal(written.numpy(), rounds)
    np.testing.assert_array_equal(errors.numpy(), 0)
    assert not barrier.broken
    assert barrier.state.numpy()[1] == 2 * rounds  # one generation per barrier


def test_a_barrier_nobody_else_reaches_breaks_instead_of_hanging(monkeypatch: object) -> None:
    # Reference: BARRIER_TIMEOUT_S. One thread of two arrives: after the timeout it gives up and marks the barrier
    # broken (the simulation then raises), rather than waiting forever for a thread that is gone.
    monkeypatch.setattr(cpu_threads, "BARRIER_TIMEOUT_S", 1)
    barrier = cpu_threads.Barrier(2)
    wait = barrier.record()
    t0 = time.perf_counter()
    wait()
    waited = time.perf_counter() - t0
    assert barrier.broken
    assert 0.9 < waited < 5.0
    barrier.reset()
    assert not barrier.broken


class _Boom(RuntimeError):
    pass


@pytest.mark.parametrize("thread", [0, 1])
def test_a_thread_that_raises_releases_the_others_at_once(monkeypatch: object, thread: int) -> None:
    # Reference: the other threads must not wait BARRIER_TIMEOUT_S (30 s) for a thread that has raised (an error,
    # or Ctrl-C in the calling thread, thread 0): the error reaches the caller within a few seconds. The scene of
    # the threads tests (tests/test_determinism.py) on two threads, one of whose step graphs is made to raise.
    from test_determinism import threaded_scene

    monkeypatch.setattr(cpu_threads, "MIN_SPHERES_PER_THREAD", 8)
    model, state = threaded_scene().finalize("cpu", n_worlds=2)
    sim = wd.Simulation(model, state, dt=2e-5, cohesion_on_new_contacts=True, cpu_threads=2)
    sim.advance(20)
    assert sim.parts == 2 and sim._lane_graphs is not None
    graph = sim._lane_graphs[thread]
    calls = [0]

    def boom() -> None:
        calls[0] += 1
        if calls[0] > 3:
            raise _Boom("a thread failed")
        graph()

    sim._lane_graphs[thread] = boom
    t0 = time.perf_counter()
    with pytest.raises(_Boom):
        sim.advance(200)
    assert time.perf_counter() - t0 < 5.0
