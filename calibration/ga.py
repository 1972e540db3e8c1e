"""The GA driver: PyGAD with batch fitness, one batched simulation per generation, resumable.

    problem = RingingProblem(springs=16)
    result = calibrate(problem, GASettings(), out="results/calibrate/ringing_16")
    result.best.genes, result.best.errors

Per generation, PyGAD hands the whole population to one fitness call (``fitness_batch_size`` = population); the
individuals not yet in the :class:`~calibration.archive.Archive` are evaluated by the evaluator as the worlds of one
simulation (:class:`~calibration.evaluators.LocalEvaluator`, or spread over workers by
:class:`~calibration.evaluators.RayEvaluator`). After every generation the GA (its population, fitness, RNG states:
PyGAD's pickle), the archive and the history are written to ``out``. A calibration killed at any moment resumes
from its last completed generation: PyGAD continues from its pickled state, and the individuals of the interrupted
generation that were already simulated come from the archive. With the same seed it ends with the same result as an
uninterrupted run (the simulations are deterministic on a given device, and an individual's result does not depend
on its batch: each problem fixes its time step).

After the GA, ``refine_iterations`` > 0 runs a batched pattern search from the best individual (every neighbour on
a grid of the current step evaluated as one batch; the step halves when none is better). It is deterministic, so a
resumed run replays it from the archive at no cost.
"""

from __future__ import annotations

import itertools
import json
import logging
import math
import os
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from warpdem.errors import SimulationError

from .archive import Archive, Record, write_json_atomic
from .genes import GASettings

_QUIET = logging.getLogger("warpdem.pygad")
_QUIET.addHandler(logging.NullHandler())
_QUIET.propagate = False
"""PyGAD's logger: PyGAD logs an exception's traceback before it re-raises it; warpdem reports it once, itself (a
budget stop is no error at all)."""

STATE_FILE, ARCHIVE_FILE, META_FILE, HISTORY_FILE = "ga_state", "archive.json", "calibration.json", "history.json"


@dataclass
class CalibrationResult:
    """What a calibration found. ``history``: one entry per GA generation (0 = the initial population) and per
    refinement iteration: stage, generation, best fitness so far, individuals simulated, wall time."""

    problem: dict[str, object]
    settings: dict[str, object]
    best: Record
    archive: Archive
    history: list[dict[str, object]] = field(default_factory=list)
    wall_s: float = 0.0

    @property
    def n_simulated(self) -> int:
        """individuals simulated by this calibration (archive records loaded from elsewhere excluded)."""
        return sum(1 for r in self.archive if r.stage != "archive")


class _Calibration:
    """State of one calibration: problem, evaluator, archive, history, output directory."""

    def __init__(self, problem, settings: GASettings, evaluator, out: Path | None, progress) -> None:  # noqa: ANN001
        self.problem, self.settings, self.evaluator, self.out, self.progress = (problem, settings, evaluator, out,
                                                                              progress)
        self.genes = problem.gene_list
        self.names = [g.name for g in self.genes]
        self.archive = Archive(self.names, problem.simulation_key())
        self.history: list[dict[str, object]] = []
        self.t0 = time.perf_counter()
        self._mark = self.t0
        self._batch_wall = 0.0
        self._batch_count = 0

    # ---- evaluation through the archive --------------------------------------------------------------------------
    def physical(self, ga_rows: np.ndarray) -> np.ndarray:
        ga_rows = np.atleast_2d(ga_rows)
        return np.stack([g.from_ga(ga_rows[:, k]) for k, g in enumerate(self.genes)], axis=1)

    def evaluate(self, values: np.ndarray, generation: int, stage: str) -> list[Record]:
        """Records of the individuals (n, n_genes) [physical], simulating those not archived (as one batch)."""
        todo: list[tuple[float, ...]] = []
        for v in values:
            k = self.archive.key(v)
            if self.archive.get(k) is None and k not in todo:
                todo.append(k)
        if todo:
            t = time.perf_counter()
            obs, failures = self._simulate(np.array(todo))
            if len(obs) != len(todo):
                raise RuntimeError(f"the evaluator returned {len(obs)} results for {len(todo)} individuals")
            self._batch_wall += time.perf_counter() - t
            self._batch_count += len(todo)
            self.archive.n_batches += 1
            for i, (v, o) in enumerate(zip(todo, obs, strict=True)):
                err = self.problem.errors(o)
                fit = self.problem.fitness_of(err)
                self.archive.add(Record(len(self.archive), generation, stage, dict(zip(self.names, v, strict=True)),
                                        {k: float(x) for k, x in o.items()}, err, fit, self.archive.n_batches,
                                        failures.get(i, "")))
            if self.out is not None:
                self.archive.save(self.out / ARCHIVE_FILE)
        return [self.archive.get(v) for v in values]

    def _simulate(self, values: np.ndarray) -> tuple[list[dict[str, float]], dict[int, str]]:
        """The evaluator's observables of ``values`` (n, n_genes), and {index: reason} of the individuals whose
        simulation went unstable. An unstable world stops its whole batched simulation: the individual it names
        (world i = individual i, as every warpdem problem builds its batch; otherwise the batch is halved until
        the culprit is alone) gets NaN observables, hence fitness 0, and the rest are simulated again without it."""
        try:
            return list(self.evaluator(values)), {}
        except SimulationError as e:
            n = len(values)
            if n == 1:
                return [dict.fromkeys(self.problem.targets, math.nan)], {0: str(e)}
            w = e.world if 0 <= e.world < n else -1
            if w >= 0:
                rest, fails = self._simulate(np.delete(values, w, axis=0))
                rest.insert(w, dict.fromkeys(self.problem.targets, math.nan))
                return rest, {**{(k if k < w else k + 1): r for k, r in fails.items()}, w: str(e)}
            half = n // 2
            a, fa = self._simulate(values[:half])
            b, fb = self._simulate(values[half:])
            return a + b, {**fa, **{k + half: r for k, r in fb.items()}}

    def log_generation(self, stage: str, generation: int, fitness: np.ndarray) -> None:
        # the best of the records made up to this generation (a resumed refinement replays iterations whose later
        # records are already archived)
        best = max((r for r in self.archive if r.generation <= generation), key=lambda r: r.fitness)
        now = time.perf_counter()
        # wall_s: since this call began ("so far"); generation_wall_s: this generation's own
        entry = {"stage": stage, "generation": generation, "best_fitness": best.fitness,
                 "population_best": float(np.max(fitness)), "population_median": float(np.median(fitness)),
                 "best_genes": best.genes, "best_errors": best.errors, "simulated": self._batch_count,
                 "simulation_s": self._batch_wall, "wall_s": now - self.t0, "generation_wall_s": now - self._mark}
        self._mark = now
        self._batch_count, self._batch_wall = 0, 0.0
        self.history.append(entry)
        if self.out is not None:
            write_json_atomic(self.out / HISTORY_FILE, self.history)
        if self.progress is not None:
            self.progress(entry)

    # ---- the GA ----------------------------------------------------------------------------------------------------
    def fitness_func(self, ga, solutions: np.ndarray, indices: object) -> list[float]:  # noqa: ANN001
        recs = self.evaluate(self.physical(solutions), ga.generations_completed, "ga")
        return [r.fitness for r in recs]

    def on_generation(self, ga) -> None:  # noqa: ANN001
        self.log_generation("ga", ga.generations_completed, np.asarray(ga.last_generation_fitness))
        if self.out is not None:
            self.save_ga(ga)

    def save_ga(self, ga) -> None:  # noqa: ANN001
        """Pickle the GA (population, fitness, RNG states) without its callbacks, atomically."""
        saved = {k: getattr(ga, k) for k in ("fitness_func", "on_generation")}
        try:
            for k in saved:
                setattr(ga, k, None)
            tmp = str(self.out / (STATE_FILE + "_tmp"))
            ga.save(tmp)
            os.replace(tmp + ".pkl", self.out / (STATE_FILE + ".pkl"))
        finally:
            for k, v in saved.items():
                setattr(ga, k, v)

    def make_ga(self):  # noqa: ANN201
        import pygad

        s = self.settings
        space = [{"low": g.ga_range[0], "high": g.ga_range[1]} for g in self.genes]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "mutation_percent_genes selects fewer than one gene": 1 is used
            return pygad.GA(num_generations=s.generations, num_parents_mating=s.parents, sol_per_pop=s.population,
                            num_genes=len(self.genes), gene_space=space, gene_type=float,
                            fitness_func=self.fitness_func, fitness_batch_size=s.population,
                            parent_selection_type=s.parent_selection, keep_parents=s.keep_parents,
                            keep_elitism=s.keep_elitism, crossover_type=s.crossover, mutation_type=s.mutation,
                            mutation_percent_genes=s.mutation_percent_genes, random_seed=s.seed, logger=_QUIET,
                            on_generation=self.on_generation, suppress_warnings=True, **s.extra)

    def on_start(self, ga) -> None:  # noqa: ANN001
        """PyGAD calls this before it evaluates the initial population: evaluate it here (one batch; PyGAD then
        finds every fitness in the archive), log it as generation 0 and save the GA, so that a run killed during
        generation 1 resumes without redoing generation 0."""
        ga.on_start = None
        recs = self.evaluate(self.physical(ga.population), 0, "ga")
        self.log_generation("ga", 0, np.array([r.fitness for r in recs]))
        if self.out is not None:
            self.save_ga(ga)

    # ---- refinement ------------------------------------------------------------------------------------------------
    def refine(self) -> None:
        s = self.settings
        g = len(self.genes)
        lo = np.array([gn.ga_range[0] for gn in self.genes])
        hi = np.array([gn.ga_range[1] for gn in self.genes])
        dirs = (np.array([d for d in itertools.product((-1, 0, 1), repeat=g) if any(d)], dtype=float) if g <= 3
                else np.vstack([np.eye(g), -np.eye(g)]))
        # start from the best record made before the refinement: after a kill during it, the archive also holds
        # refinement records, and starting from those would take another path than the uninterrupted run
        before = [r for r in self.archive if r.stage != "refine"]
        best = max(before, key=lambda r: r.fitness)
        x = np.array([gn.to_ga(best.genes[gn.name]) for gn in self.genes], dtype=float)
        step = s.refine_step
        for it in range(s.refine_iterations):
            trial = np.clip(x + step * (hi - lo) * dirs, lo, hi)
            recs = self.evaluate(self.physical(trial), s.generations + 1 + it, "refine")
            fit = np.array([r.fitness for r in recs])
            k = int(np.argmax(fit))
            if fit[k] > best.fitness:
                best, x = recs[k], trial[k]
            else:
                step *= 0.5
            self.log_generation("refine", s.generations + 1 + it, fit)


def _meta(problem, settings: GASettings) -> dict[str, object]:  # noqa: ANN001
    return json.loads(json.dumps({"problem": problem.spec(), "settings": settings.to_dict()}))


def calibrate(problem, settings: GASettings | None = None, *, out: str | Path | None = None,  # noqa: ANN001
              evaluator: Callable[[np.ndarray], list[dict[str, float]]] | None = None, resume: bool = True,
              archive: str | Path | None = None,
              progress: Callable[[dict[str, object]], None] | None = None) -> CalibrationResult:
    """Run a GA calibration (and the optional refinement) of ``problem``.

    Args:
        problem: a :mod:`calibration.problems` problem (genes, targets, ``evaluate``).
        settings: GA settings (default: the paper's).
        out: directory for the GA state, the archive and the history (None: nothing written, no resume).
        evaluator: ``f(values (n, n_genes)) -> [observables]`` (default: the problem's own, in this process).
        resume: continue from ``out``'s saved state when there is one (it must be the same calibration).
        archive: a previous archive (JSON) of the same simulation whose records are reused, not re-simulated.
        progress: called with each history entry (after every generation and refinement iteration).
    Returns:
        The :class:`CalibrationResult`; ``result.best`` is the fittest individual evaluated.
    """
    settings = settings or GASettings()
    out_dir = Path(out) if out is not None else None
    cal = _Calibration(problem, settings, evaluator or problem.evaluate, out_dir, progress)
    meta = _meta(problem, settings)
    ga = None
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
        state = out_dir / (STATE_FILE + ".pkl")
        if resume and (out_dir / META_FILE).exists():
            old = json.loads((out_dir / META_FILE).read_text())
            if old != meta:
                raise ValueError(f"{out_dir} holds a different calibration; use another --out or resume=False "
                                 f"(saved: {old}, now: {meta})")
            if (out_dir / ARCHIVE_FILE).exists():
                saved = Archive.load(out_dir / ARCHIVE_FILE)
                for r in saved:
                    cal.archive.add(r)
                cal.archive.n_batches = saved.n_batches
            if (out_dir / HISTORY_FILE).exists():
                cal.history = [h for h in json.loads((out_dir / HISTORY_FILE).read_text()) if h["stage"] == "ga"]
            if state.exists():
                import pygad

                ga = pygad.load(str(out_dir / STATE_FILE))
                ga.fitness_func, ga.on_generation = cal.fitness_func, cal.on_generation
                cal.history = [h for h in cal.history if h["generation"] <= ga.generations_completed]
            else:
                cal.history = []
        else:
            for f in (STATE_FILE + ".pkl", ARCHIVE_FILE, HISTORY_FILE):
                (out_dir / f).unlink(missing_ok=True)
        write_json_atomic(out_dir / META_FILE, meta)
    if archive is not None:
        cal.archive.merge(Archive.load(archive))
        for r in cal.archive:  # another calibration's targets: rescore its observables against ours
            if r.stage == "archive":
                r.errors = problem.errors(r.observables)
                r.fitness = problem.fitness_of(r.errors)
    if ga is None:
        ga = cal.make_ga()
        ga.on_start = cal.on_start
        remaining = settings.generations
    else:
        remaining = settings.generations - ga.generations_completed
    if remaining > 0:
        ga.num_generations = remaining
        ga.run()
    if settings.refine_iterations:
        cal.refine()
    best = cal.archive.best()
    return CalibrationResult(problem.spec(), settings.to_dict(), best, cal.archive, cal.history,
                             time.perf_counter() - cal.t0)


def accepted_records(result: CalibrationResult, problem) -> list[Record]:  # noqa: ANN001
    """Draught calibration: the distinct individuals with |RE| below the acceptance threshold, best first."""
    recs = [r for r in result.archive if r.stage != "archive" and problem.accepted(r.errors)]
    return sorted(recs, key=lambda r: abs(r.errors["re_draught"]))
