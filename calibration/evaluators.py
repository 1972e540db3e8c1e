"""Who simulates a population: this process (the default) or a Ray cluster of workers.

An evaluator is ``f(values (n, n_genes)) -> [observables per individual]``. :class:`LocalEvaluator` runs the whole
population as the worlds of one simulation on the problem's device. :class:`RayEvaluator` splits it into one chunk
per worker; each worker (a Ray actor holding its own copy of the problem, e.g. one per GPU) runs its chunk as one
batched simulation. Because an individual's result does not depend on its batch (fixed time step, independent
worlds), both give the same observables on the same kind of device.

Ray is an optional extra (``pip install -e ".[ray]"``). To use an existing cluster, start it (``ray start --head``
on one machine, ``ray start --address=HEAD:6379`` on the others) and pass ``address="HEAD:6379"`` (or
``--ray-address`` on the command line); with ``address=None`` a local cluster is started on this machine. With
``gpus_per_worker=1`` Ray gives each worker its own GPU and the problem's device should be ``"cuda"``.
"""

from __future__ import annotations

import os

import numpy as np


class LocalEvaluator:
    """Evaluate in this process: ``problem.evaluate`` (one batched simulation per call)."""

    def __init__(self, problem) -> None:  # noqa: ANN001
        self.problem = problem

    def __call__(self, values: np.ndarray) -> list[dict[str, float]]:
        return self.problem.evaluate(values)

    def close(self) -> None:
        pass


class _Worker:
    """A Ray actor: one problem, one device, one batched simulation per call; on the CPU, as many threads per step
    as the CPUs it reserved (so that workers sharing a machine do not each take every core)."""

    def __init__(self, problem, cpu_threads: int) -> None:  # noqa: ANN001
        os.environ["WARPDEM_CPU_THREADS"] = str(cpu_threads)  # read by every Simulation this worker makes
        self.problem = problem

    def evaluate(self, values: np.ndarray) -> list[dict[str, float]]:
        return self.problem.evaluate(values)

    def cpu_threads(self) -> int:
        from warpdem.cpu_threads import default_threads

        return default_threads()

    def placement(self) -> dict[str, object]:
        """Where this worker simulates: its Ray GPU ids, CUDA_VISIBLE_DEVICES, and the Warp device its problem
        runs on (name, PCI bus id: tells two workers on one machine apart)."""
        import ray
        import warp as wp

        dev = wp.get_device(getattr(self.problem, "device", None))
        return {"ray_gpu_ids": [str(g) for g in ray.get_gpu_ids()],
                "cuda_visible_devices": os.environ.get("CUDA_VISIBLE_DEVICES"), "device": str(dev),
                "device_name": dev.name, "pci_bus_id": getattr(dev, "pci_bus_id", None)}


class RayEvaluator:
    """Spread each population over ``workers`` Ray actors, one batched simulation each.

    Args:
        problem: the calibration problem (pickled to every worker).
        workers: number of actors (default: the cluster's GPUs if ``gpus_per_worker`` > 0, else 2).
        address: an existing cluster's address, "auto", or None to start a local one.
        gpus_per_worker, cpus_per_worker: resources reserved by each actor (on the CPU, a worker's step runs on
            int(cpus_per_worker) threads, at least one).
        init_kwargs: further arguments to ``ray.init`` (e.g. ``num_cpus`` of a local cluster).
    """

    def __init__(self, problem, workers: int | None = None, *, address: str | None = None,  # noqa: ANN001
                 gpus_per_worker: float = 0.0, cpus_per_worker: float = 1.0,
                 init_kwargs: dict[str, object] | None = None) -> None:
        try:
            import ray
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise ImportError("RayEvaluator needs Ray: pip install -e '.[ray]'") from e
        if workers is not None and workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers!r}")
        self._ray = ray
        self._started = not ray.is_initialized()
        if self._started:
            ray.init(address=address, include_dashboard=False, log_to_driver=False, **(init_kwargs or {}))
        if workers is None:
            gpus = int(ray.cluster_resources().get("GPU", 0))
            workers = max(1, gpus // max(1, int(gpus_per_worker))) if gpus_per_worker > 0 else 2
        actor = ray.remote(num_cpus=cpus_per_worker, num_gpus=gpus_per_worker)(_Worker)
        threads = max(1, int(cpus_per_worker))
        self.actors = [actor.remote(problem, threads) for _ in range(workers)]

    @property
    def workers(self) -> int:
        return len(self.actors)

    def cpu_threads(self) -> list[int]:
        """The CPU threads each worker's simulations use per step."""
        return self._ray.get([a.cpu_threads.remote() for a in self.actors])

    def placements(self) -> list[dict[str, object]]:
        """Each worker's device (see ``_Worker.placement``): with one GPU per worker, distinct PCI bus ids."""
        return self._ray.get([a.placement.remote() for a in self.actors])

    def __call__(self, values: np.ndarray) -> list[dict[str, float]]:
        values = np.atleast_2d(np.asarray(values, dtype=np.float64))
        chunks = [c for c in np.array_split(values, min(len(self.actors), len(values))) if len(c)]
        futures = [a.evaluate.remote(c) for a, c in zip(self.actors, chunks, strict=False)]
        return [obs for part in self._ray.get(futures) for obs in part]

    def close(self) -> None:
        for a in self.actors:
            self._ray.kill(a)
        self.actors = []
        if self._started:
            self._ray.shutdown()
