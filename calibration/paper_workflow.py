"""The paper's whole workflow at one scale, in resumable pieces, with error bars from replicas.

Stages, each writing its result into the run folder when it ends:

1. ``ringing_linear`` and ``ringing_paper``: the ringing calibration of all eight spring configurations (PyGAD with
   the paper's settings) for the linear spring-dashpot and for the paper's spring spheres; the linear model's GA
   ranks by the larger of its two errors and ends with a batched pattern search (``WorkflowConfig.ringing_fitness``,
   ``ringing_refine``). The eight GAs of a model run in lockstep: each generation of all eight is ONE batched
   simulation (:class:`Lockstep`).
2. ``draught``: the soil's GA calibration against the measured rigid draught at 0.62 m/s (Table 3) on the scale's
   calibration bin (``paper``: the paper's first, 1 m long bin at the paper's particle size).
3. ``screening``: the accepted sets (or, when none is accepted, the fittest) in the direct shear box; the set
   closest to the laboratory's strength becomes the soil of the Table 3 runs.
4. ``table3``: on each of several independent beds (replicas, one deposition seed each) the rigid tool at every
   distinct speed of Table 3 and the eight passive configurations at their own speeds, with Table 2's support
   offsets and without them; the linear springs carry the stiffness and dashpot calibrated in stage 1. Every
   reduction is paired with the rigid run of the same bed and speed; its standard error comes from the scatter
   over replicas. Replicas are added (up to ``replicas_max``) until every reduction's standard error is below
   ``target_sem``.
5. ``diagnosis``: ``warpdem diagnose`` of Table 3 (its configurations of ``springs``; reductions and displacements)
   with the soil of the Table 3 runs, in the draught calibration's bin on its bed: the baseline and each soil-bin
   mechanism fitted, compared on held-out configurations, the cause named and re-simulated
   (``calibration.diagnosis``; report, figures and checkpoint in ``diagnosis/``). Every fitted point is one run of
   every configuration; ``WorkflowConfig.diagnosis_rounds`` and ``diagnosis_grid`` size it (``diagnose=False``
   leaves it out).
6. ``report.md`` beside Tables 2, 3 and 7, with figures.

Pieces and resume: the GA stages save their state after every generation, every soil-bin job checkpoints (into
``checkpoints/``), every finished job writes its rows, and every simulation of the diagnosis is kept
(``checkpoints/diagnosis_runs/``) with its fitted points (``diagnosis/checkpoint.json``). Given a budget [s] of wall
time, the workflow stops with :class:`warpdem.errors.BudgetExhausted` at the first point where the next piece would
not fit (a GA batch as long as the last one, or a soil-bin run at its deadline, which saves its checkpoint first);
the same call continues where it stopped and ends with the same result (bit for bit on the CPU).
"""

from __future__ import annotations

import hashlib
import json
import math
import shutil
import threading
import time
from collections.abc import Callable
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from scenes import paper
from scenes import soil_bin as sb
from scenes.passive_tool import from_dict
from scenes.reproduce import versions
from scenes.ringing import RingingConfig, build_ringing, run_ringing
from scenes.soil_bin import ensemble
from warpdem.errors import BudgetExhausted, InputError, SimulationError
from warpdem.files import write_atomic

from . import diagnosis as diagnosis_mod
from . import diagnosis_report, measured
from .archive import same_or_extended, write_json_atomic
from .budget import BatchGuard, Budget
from .ga import accepted_records, calibrate
from .genes import soil_fields, soil_overrides
from .problems import DraughtProblem, RingingProblem, SoilProblem
from .report import write_report
from .rig_models import SoilBinRigModel
from .screening import screen
from .workflow_config import CALIBRATION_SCALE, REFIT_FIELDS, SCREEN_SCALE, VARIANTS, WorkflowConfig
from .workflow_report import write_workflow_report


class Lockstep:
    """Several GA calibrations whose batches are simulated together: each calibration runs in its own thread and
    hands its batch to the main thread, which waits until every running calibration has one (or has ended), then
    simulates them all as ONE call of ``run_batches(list of (index, values)) -> list of observables lists``.

    A calibration's result does not depend on the others as long as ``run_batches`` gives each world what it
    would give alone (true of the ringing rig, whose worlds share no contacts and no time-step choice)."""

    def __init__(self, run_batches: Callable[[list[tuple[int, np.ndarray]]], list[list[dict[str, float]]]],
                 budget: Budget, per_world: float = 0.0, timed: Callable[[float], None] | None = None) -> None:
        self.run_batches, self.budget = run_batches, budget
        self.timed = timed or (lambda v: None)
        self.cond = threading.Condition()
        self.pending: dict[int, np.ndarray] = {}
        self.results: dict[int, list[dict[str, float]]] = {}
        self.running: set[int] = set()
        self.stop: BaseException | None = None
        self.per_world = per_world

    def evaluator(self, i: int) -> Callable[[np.ndarray], list[dict[str, float]]]:
        def evaluate(values: np.ndarray) -> list[dict[str, float]]:
            with self.cond:
                self.pending[i] = np.asarray(values)
                self.cond.notify_all()
                while i not in self.results and self.stop is None:
                    self.cond.wait()
                if self.stop is not None:
                    raise BudgetExhausted(str(self.stop)) if isinstance(self.stop, BudgetExhausted) else \
                        RuntimeError(f"lockstep stopped: {self.stop}")
                out = self.results.pop(i)
            if isinstance(out, SimulationError):  # one of this calibration's worlds went unstable
                raise out
            return out
        return evaluate

    def run(self, jobs: list[Callable[[Callable[[np.ndarray], list[dict[str, float]]]], object]]) -> list[object]:
        """Run ``jobs[i](evaluator_i)`` in threads, serving their batches here; returns their results in order.
        The first error (a BudgetExhausted included) stops them all and is raised."""
        outcome: dict[int, object] = {}
        errors: dict[int, BaseException] = {}

        def target(i: int) -> None:
            try:
                outcome[i] = jobs[i](self.evaluator(i))
            except BaseException as e:  # noqa: BLE001 (handed to the main thread)
                errors[i] = e
            finally:
                with self.cond:
                    self.running.discard(i)
                    self.cond.notify_all()

        threads = [threading.Thread(target=target, args=(i,), daemon=True) for i in range(len(jobs))]
        self.running = set(range(len(jobs)))
        for t in threads:
            t.start()
        while True:
            with self.cond:
                while self.running and not set(self.running) <= set(self.pending):
                    self.cond.wait()
                if not self.running:
                    break
                batch = sorted(self.pending.items())
                self.pending.clear()
            try:
                n = sum(len(v) for _, v in batch)
                self.budget.require(self.per_world * n, f"a lockstep batch of {n} worlds")
                t0 = time.perf_counter()
                obs = self.run_batches(batch)
                self.per_world = (time.perf_counter() - t0) / max(n, 1)
                self.timed(self.per_world)
            except SimulationError as e:
                owner = _owner(batch, e.world)
                if owner is None:
                    self._halt(e, threads)
                    raise
                # the calibration owning the unstable world is told which of its individuals it was (its GA driver
                # sets that one aside and hands in the rest); the others' batches wait for the next round
                i, j = owner
                with self.cond:
                    for k, v in batch:
                        if k != i:
                            self.pending[k] = v
                    self.results[i] = SimulationError(str(e), e.step, e.body, e.cause, world=j)
                    self.cond.notify_all()
                continue
            except BaseException as e:  # noqa: BLE001 (every calibration thread is told, then it is raised)
                self._halt(e, threads)
                raise
            with self.cond:
                for (i, _), o in zip(batch, obs, strict=True):
                    self.results[i] = o
                self.cond.notify_all()
        for t in threads:
            t.join()
        if errors:
            raise errors[min(errors)]
        return [outcome[i] for i in range(len(jobs))]

    def _halt(self, e: BaseException, threads: list[threading.Thread]) -> None:
        with self.cond:
            self.stop = e
            self.cond.notify_all()
        for t in threads:
            t.join()


def _owner(batch: list[tuple[int, np.ndarray]], world: int) -> tuple[int, int] | None:
    """(calibration, individual) of world ``world`` of a lockstep simulation (one world per individual, the
    calibrations' batches concatenated in order), or None."""
    if world < 0:
        return None
    for i, v in batch:
        n = len(np.atleast_2d(v))
        if world < n:
            return i, world
        world -= n
    return None


def ringing_batches(problems: list[RingingProblem], device: str | None
                    ) -> Callable[[list[tuple[int, np.ndarray]]], list[list[dict[str, float]]]]:
    """Simulate batches of several ringing problems (one spring model, one time step) as one simulation."""
    def run(batch: list[tuple[int, np.ndarray]]) -> list[list[dict[str, float]]]:
        cfgs = [problems[i]._config(np.atleast_2d(v), problems[i].dt) for i, v in batch]
        per_world = {f: sum((getattr(c, f) for c in cfgs), ()) for f in ("springs", "spring_young", "local_damping",
                                                                           "stiffness", "damping_ratio")
                     if getattr(cfgs[0], f) is not None}
        res = run_ringing(replace(cfgs[0], **per_world), device=device)
        out, k = [], 0
        for _, v in batch:
            n = len(np.atleast_2d(v))
            out.append([{"freq_hz": float(res.frequency_hz[j]), "damping": float(res.damping_ratio[j]),
                         "static_deflection_m": float(res.static_deflection[j])} for j in range(k, k + n)])
            k += n
        return out
    return run


# ------------------------------------------------------------------------------------------------ ensembles
def replicas_needed(sems: list[float], n: int, target: float, most: int) -> int:
    """Replicas that bring the largest standard error (from ``n`` replicas) below ``target`` if it falls as
    1/sqrt(n): ceil(n (max sem / target)^2), at least n, at most ``most``."""
    worst = max((s for s in sems if math.isfinite(s)), default=math.inf)
    if not math.isfinite(worst):
        return min(most, n + 1)
    return int(min(most, max(n, math.ceil(n * (worst / target) ** 2 - 1e-9))))


def _one_bed_per_replica(done: list[dict]) -> bool:
    """Whether finished group jobs ran every world of a replica on one bed (by the fingerprints they recorded)."""
    beds: dict[int, set] = {}
    for d in done:
        for r, fp in zip(d["replicas"], d["beds"], strict=True):
            beds.setdefault(r, set()).add(fp)
    return all(len(v) == 1 for v in beds.values())


# ------------------------------------------------------------------------------------------------ the run
def bed_fingerprint(bed: sb.Bed) -> str:
    """A deposited bed's identity: the first 16 hex digits of the SHA-1 of its sphere centres."""
    return hashlib.sha1(np.ascontiguousarray(bed.centres).tobytes()).hexdigest()[:16]


class Workflow:
    """One run folder of the workflow (see the module's docstring). ``log`` receives one line per event."""

    def __init__(self, out: str | Path, config: WorkflowConfig | None = None, *, device: str | None = None,
                 log: Callable[[str], None] | None = None,
                 progress: Callable[[str, float, float], None] | None = None) -> None:
        self.out = Path(out)
        self.config = config or WorkflowConfig()
        self.device = device
        self.log = log or (lambda m: None)
        self.progress = progress
        """``f(stage, done, total)``: the long stages' progress (depositions, soil-bin batches and jobs, shear
        boxes), besides the ``log`` lines."""
        meta = self.out / "workflow.json"
        spec = {"config": self.config.to_dict()}
        if meta.exists():
            saved = json.loads(meta.read_text())
            old, now, defaults = saved.get("config", {}), spec["config"], WorkflowConfig().to_dict()

            def fixed(d: dict) -> dict:
                return {k: v for k, v in d.items() if k not in REFIT_FIELDS}

            # a folder made before a field was added is this run if the new field is at its default
            if not same_or_extended(fixed(old), fixed(now), defaults):
                raise InputError(f"{str(self.out)!r} holds a workflow with another configuration; choose another "
                                 "--out (or remove that folder)")
            changed = {k: (old.get(k, defaults[k]), now[k]) for k in REFIT_FIELDS if old.get(k, defaults[k]) != now[k]}
            if changed:
                self._refit(saved, changed)
        else:
            write_json_atomic(meta, spec)

    def _refit(self, saved: dict, changed: dict[str, tuple[object, object]]) -> None:
        """Take this call's values of :data:`REFIT_FIELDS` (``changed``: field -> (folder's, this call's)): a
        finished diagnosis moves to ``diagnosis/rounds_<old value>/`` (its report, figures and summary; the
        checkpoint stays, to be fitted again), and ``workflow.json`` records the change."""
        what = ", ".join(f"{k} {a!r} -> {b!r}" for k, (a, b) in changed.items())
        done = self._path("diagnosis.json")
        if done.exists():
            old_rounds = changed.get("diagnosis_rounds", (self.config.diagnosis_rounds,))[0]
            aside = self._path("diagnosis") / f"rounds_{old_rounds}"
            aside.mkdir(parents=True, exist_ok=True)
            done.replace(aside / "summary.json")
            for f in self._path("diagnosis").iterdir():
                if f.is_file() and f.name != "checkpoint.json" and not f.name.startswith("checkpoint_"):
                    f.replace(aside / f.name)
            self.log(f"  {what}: the finished diagnosis is set aside (diagnosis/{aside.name}/) and fitted again")
        else:
            self.log(f"  {what}: the diagnosis's simulated points are kept and fitted with the new value")
        history = [*saved.get("changes", []), *({"field": k, "from": a, "to": b} for k, (a, b) in changed.items())]
        write_json_atomic(self._path("workflow.json"), {**saved, "config": self.config.to_dict(), "changes": history})

    # ---- small helpers ----------------------------------------------------------------------------------------
    def _path(self, name: str) -> Path:
        return self.out / name

    def _done(self, name: str) -> dict | None:
        p = self._path(name)
        return json.loads(p.read_text()) if p.exists() else None

    def _timed(self, key: str, seconds: float) -> None:
        """Record how long a piece took [s] (``timings.json``): later calls size their budget checks by it."""
        p = self._path("timings.json")
        t = json.loads(p.read_text()) if p.exists() else {}
        t[key] = seconds
        write_json_atomic(p, t)

    def _timing(self, key: str, default: float = 0.0) -> float:
        p = self._path("timings.json")
        return float(json.loads(p.read_text()).get(key, default)) if p.exists() else default

    def _bed_fingerprint(self, key: str, bed: sb.Bed) -> tuple[str, str | None]:
        """(this bed's fingerprint, the one recorded under ``key`` before if it differs, else None); records it.
        A bed missing from ``beds/`` is deposited again: the same bed on the CPU, another realisation on CUDA."""
        fp = bed_fingerprint(bed)
        p = self._path("beds.json")
        known = json.loads(p.read_text()) if p.exists() else {}
        old = known.get(key)
        if old != fp:
            known[key] = fp
            write_json_atomic(p, known)
        return fp, (old if old not in (None, fp) else None)

    # ---- stage 1: ringing ---------------------------------------------------------------------------------------
    def ringing(self, model: str, budget: Budget) -> dict:
        name = f"ringing_{model}.json"
        if (done := self._done(name)) is not None:
            return done
        c = self.config
        problems = [RingingProblem(springs=n, spring_model=model, fitness=c.ringing_fitness[model],
                                   ring_time=c.ringing_time, device=self.device) for n in c.springs]
        ga = replace(c.ringing_ga, refine_iterations=c.ringing_refine.get(model, 0))
        dt = min(p.dt for p in problems)
        for p in problems:
            p.dt = dt
        run_batches = ringing_batches(problems, self.device)
        total, done = ga.generations + 1 + ga.refine_iterations, [0]
        if self.progress is not None:  # a step per lockstep batch: the first population, each generation, refinement

            def counted(batches: list[tuple[int, np.ndarray]], inner: Callable = run_batches) -> list:
                out = inner(batches)
                done[0] += 1
                self.progress(f"ringing calibration ({model})", min(done[0], total), total)
                return out
            run_batches = counted
        lock = Lockstep(run_batches, budget, self._timing(f"ringing_{model}_per_world"),
                        lambda v: self._timed(f"ringing_{model}_per_world", v))
        t0 = time.perf_counter()
        self.log(f"ringing calibration ({model} springs): {len(problems)} GAs in lockstep")

        def job(k: int) -> Callable[[Callable], object]:
            return lambda ev: calibrate(problems[k], ga, out=self.out / f"ringing_{model}" /
                                        str(c.springs[k]), evaluator=ev)
        results = lock.run([job(k) for k in range(len(problems))])
        if self.progress is not None:  # a refinement that stops early ends the bar too
            self.progress(f"ringing calibration ({model})", total, total)
        rows = []
        for n, p, res in zip(c.springs, problems, results, strict=True):
            b = res.best
            row = {"springs": n, **b.genes, **b.observables, **{f"target_{k}": v for k, v in p.targets.items()},
                   **b.errors, "fitness": b.fitness, "simulated": res.n_simulated}
            if model == "linear":
                rig = build_ringing(RingingConfig(springs=(n,), spring_model="linear",
                                                  stiffness=(b.genes["stiffness"],),
                                                  damping_ratio=(b.genes["damping_ratio"],)))
                row["dashpot_n_s_per_m"] = float(np.asarray(rig.info["dashpot_n_s_per_m"])[0])
            rows.append(row)
        out = {"model": model, "dt": dt, "rows": rows, "wall_s": time.perf_counter() - t0}
        write_json_atomic(self._path(name), out)
        self.log(f"ringing calibration ({model}) done in {out['wall_s']:.0f} s")
        return out

    # ---- stage 2: draught calibration ----------------------------------------------------------------------------
    def draught_problem(self) -> DraughtProblem:
        """The draught GA's problem: the paper's (draught alone) or, with the "bonded" soil protocol, the draught and
        the shear box together."""
        c = self.config
        if c.soil_protocol == "bonded":
            return SoilProblem(assembly=c.assembly, scale=CALIBRATION_SCALE[c.scale], box_scale=SCREEN_SCALE[c.scale],
                               travel=c.calibration_travel, settle_time=c.soil_settle_time, fragile=False,
                               deposit_friction=c.deposit_friction, stage_progress=self.progress,
                               box_changes=dict(c.screen_changes) or None, box_samples=c.box_samples, seed=c.seed,
                               cache_dir=str(self.out / "beds"), device=self.device)
        return DraughtProblem(assembly=c.assembly, scale=CALIBRATION_SCALE[c.scale], travel=c.calibration_travel,
                              settle_time=c.settle_time, seed=c.seed, cache_dir=str(self.out / "beds"),
                              deposit_friction=c.deposit_friction, stage_progress=self.progress,
                              device=self.device)

    def draught(self, budget: Budget) -> dict:
        if (done := self._done("draught.json")) is not None:
            return done
        problem = self.draught_problem()
        self.log(f"draught calibration on the {problem.scale} bin (target {problem.targets['draught_mean_n']:.1f} N)")
        deposits = not sb.bed_path(problem.config, problem.cache_dir).exists()
        if deposits:  # a deposition must fit whole (it cannot be checkpointed); sized like a Table 3 bed's at first
            budget.require(self._timing("deposit_draught", self._timing("deposit")),
                           "depositing the draught calibration's bed")
        t0 = time.perf_counter()
        _, old = self._bed_fingerprint("draught", problem.bed())  # deposited or read before any batch is timed
        if deposits:
            self._timed("deposit_draught", time.perf_counter() - t0)
        if old is not None:
            self.log(f"  the calibration bed was missing and has been deposited again as another realisation (was "
                     f"{old}): generations before and after this call see different beds")
        t0 = time.perf_counter()
        guard = BatchGuard(problem.evaluate, budget, "soil-bin worlds", self._timing("draught_per_world"),
                       lambda v: self._timed("draught_per_world", v))
        res = calibrate(problem, self.config.draught_ga, out=self.out / "draught", evaluator=guard,
                        progress=lambda h: self.log(f"  draught GA generation {h['generation']}: best fitness "
                                                    f"{h['best_fitness']:.3g}, {h['best_genes']}"))
        write_report(res, problem, self.out / "draught", extra={"device": self.device})
        accepted = accepted_records(res, problem)
        recs = accepted or sorted((r for r in res.archive if r.stage != "archive"), key=lambda r: -r.fitness)
        out = {"accepted": len(accepted), "best": {"genes": res.best.genes, "observables": res.best.observables,
                                                   "errors": res.best.errors, "fitness": res.best.fitness},
               "candidates": [{"genes": r.genes, "draught_mean_n": r.observables["draught_mean_n"],
                               "re_draught": r.errors["re_draught"]} for r in recs[:self.config.screen_top]],
               "target_n": problem.targets["draught_mean_n"], "scale": problem.scale,
               "simulated": res.n_simulated, "wall_s": time.perf_counter() - t0}
        write_json_atomic(self._path("draught.json"), out)
        return out

    # ---- stage 3: screening ------------------------------------------------------------------------------------
    def _screen_protocol(self) -> dict[str, object]:
        """The screening box's bonds and sample: the paper's protocol screens on the box's own sample with bonds that
        break; "bonded" with yielding bonds on the first sample its soil calibration never saw (seed ``box_samples``),
        so that the screening checks the calibration's box result off the samples it was selected on."""
        return {} if self.config.fragile else {"fragile": False, "seed": self.config.box_samples}

    def screening(self, draught: dict, budget: Budget) -> dict:
        if (done := self._done("screening.json")) is not None:
            return done
        key = "screening"
        budget.require(self._timing(key), "the shear-box screening")
        self.log(f"shear-box screening of {len(draught['candidates'])} sets ({SCREEN_SCALE[self.config.scale]})")
        t0 = time.perf_counter()
        bar = self.progress
        rows = screen([c["genes"] for c in draught["candidates"]], self.config.assembly,
                      SCREEN_SCALE[self.config.scale], device=self.device,
                      progress=(lambda ph, d, n: bar(f"screening: shear box {ph}", d, n)) if bar else None,
                      **{**self.config.screen_changes, **self._screen_protocol()})
        for r in rows:
            r["draught_mean_n"] = draught["candidates"][r["set"] - 1]["draught_mean_n"]
        chosen = {g: rows[0][g] for g in ("friction_angle", "normal_cohesion", "eta_roll")}
        out = {"rows": rows, "chosen": chosen, "from_accepted": draught["accepted"] > 0,
               "wall_s": time.perf_counter() - t0}
        self._timed(key, out["wall_s"])
        write_json_atomic(self._path("screening.json"), out)
        return out

    # ---- stage 4: Table 3 --------------------------------------------------------------------------------------
    def jobs(self, replica: int) -> list[dict]:
        """The soil-bin jobs of one replica: (kind, springs, speeds) in at most ``worlds_per_job`` worlds each."""
        c = self.config
        speeds = c.speeds()
        out = []

        def chunks(kind: str, springs: list[int], vs: list[float]) -> None:
            for k in range(0, len(springs), c.worlds_per_job):
                out.append({"name": f"r{replica}_{kind}_{k // c.worlds_per_job}", "replica": replica, "kind": kind,
                            "springs": springs[k:k + c.worlds_per_job], "speeds": vs[k:k + c.worlds_per_job]})
        rigid = c.rigid_speeds()
        chunks("rigid", [0] * len(rigid), rigid)
        for variant in VARIANTS:
            chunks(variant, list(c.springs), [speeds[n] for n in c.springs])
        return out

    def group_jobs(self, first: int, end: int) -> list[dict]:
        """With ``replica_worlds``: the soil-bin jobs of replicas ``first`` .. ``end`` - 1 as worlds of the same
        simulations (world by world: replica, springs, speed), at most ``worlds_per_job`` worlds each. Worlds are
        dealt out replica after replica, so a job mixes replicas only where one replica's worlds of a kind do not
        fill whole jobs: the parked particles of a shared layout (``scenes.replica_beds``) stay where they buy
        fuller simulations."""
        c = self.config
        speeds = c.speeds()
        kinds = [("rigid", [(0, v) for v in c.rigid_speeds()])]
        kinds += [(variant, [(n, speeds[n]) for n in c.springs]) for variant in VARIANTS]
        out = []
        for kind, rows in kinds:
            worlds = [(r, n, v) for r in range(first, end) for n, v in rows]
            for k in range(0, len(worlds), c.worlds_per_job):
                chunk = worlds[k:k + c.worlds_per_job]
                out.append({"name": f"g{first}-{end - 1}_{kind}_{k // c.worlds_per_job}", "kind": kind,
                            "group": [first, end], "replicas": [w[0] for w in chunk],
                            "springs": [w[1] for w in chunk], "speeds": [w[2] for w in chunk]})
        return out

    def groups(self) -> list[list[int]]:
        """With ``replica_worlds``: the replica groups decided so far, [first, end) each (``table3/groups.json``)."""
        saved = self._done("table3/groups.json")
        return [list(g) for g in saved["groups"]] if saved else [[0, self.config.replicas_min]]

    def _beds(self, job: dict, cfg: sb.SoilBinConfig, budget: Budget
              ) -> tuple[sb.Bed | list[sb.Bed], object, list[sb.Bed] | None]:
        """The bed of a job (a replica's own), or its worlds' replica beds; its fingerprint(s); and for a group's job,
        every replica bed of the group (where the tool goes). A bed that had to be deposited again and came out
        another realisation sets its replica's finished jobs aside."""
        replicas = list(range(*job["group"])) if "replicas" in job else [job["replica"]]
        beds, fps = {}, {}
        for r in replicas:
            rep = r if "replicas" in job else None
            deposits = not sb.bed_path(cfg, self.out / "beds", rep).exists()
            if deposits:  # a deposition must fit whole too (at paper scale minutes: it cannot be checkpointed)
                budget.require(self._timing("deposit"), f"depositing replica {r}'s bed")
            t0 = time.perf_counter()
            bar = self.progress  # a phase at rest early reports the deposition's max_time (3 s) last
            beds[r] = sb.bed_for(cfg, device=self.device, cache_dir=self.out / "beds", replica=rep,
                                 progress=(lambda ph, t, ke, r=r, bar=bar: bar(f"replica {r}'s bed: {ph}", t, 3.0))
                                 if bar else None)
            if deposits:
                self._timed("deposit", time.perf_counter() - t0)
            fps[r], old = self._bed_fingerprint(f"replica_{r}", beds[r])
            if old is not None:
                self._set_aside(r, old)
        if "replicas" in job:
            return [beds[r] for r in job["replicas"]], [fps[r] for r in job["replicas"]], list(beds.values())
        return beds[job["replica"]], fps[job["replica"]], None

    def run_job(self, job: dict, soil: dict, ring: dict | None, budget: Budget) -> dict:
        path = self._path(f"table3/{job['name']}.json")
        if (done := self._done(f"table3/{job['name']}.json")) is not None:
            return done
        c = self.config
        ckpt = self.out / "checkpoints" / job["name"]
        timing = f"job_{'rigid' if job['kind'] == 'rigid' else 'passive'}_{len(job['springs'])}"
        cfg = sb.SoilBinConfig(scale=c.scale, assembly=c.assembly, springs=tuple(job["springs"]),
                               speed=tuple(job["speeds"]), support_offset=job["kind"] == "offset",
                               travel=c.travel, steady_travel=c.steady_travel,
                               seed=c.seed if "replicas" in job else c.seed + job["replica"],
                               settle_time=c.soil_settle_time, fragile=c.fragile,
                               deposit_friction=c.deposit_friction)
        n = len(job["springs"])
        overrides = soil_overrides(soil, n)
        knobs, described = None, None
        if c.passive_tool is not None:
            described = replace(from_dict(c.passive_tool), support_offsets=job["kind"] == "offset")
        if job["kind"] != "rigid" and ring is not None and described is None:
            by_n = {r["springs"]: r for r in ring["rows"]}
            knobs = {"stiffness": [by_n[s]["stiffness"] for s in job["springs"]],
                     "dashpot": [by_n[s]["dashpot_n_s_per_m"] for s in job["springs"]]}
        bed, fp, group_beds = self._beds(job, cfg, budget)
        # a group's jobs all put the tool at the group's mean bed surface: each replica's rigid and passive worlds
        # then cut at one depth below its own surface, whichever replicas share their simulations
        tool = sb.place_tool(group_beds if group_beds else bed, cfg.working_depth,
                             None if described is None else described.sweep())
        # a job that has not started must fit whole (its checkpoint would not outlive a lost machine); one that
        # has, saves its checkpoint at the deadline. Checked once the bed is ready: depositing it may take minutes
        # (the bed stays in beds/ for the next call)
        budget.require(30.0 if ckpt.exists() else self._timing(timing, 30.0), f"soil-bin job {job['name']}")
        self.log(f"soil-bin job {job['name']}: {n} worlds, springs {job['springs']}, speeds {job['speeds']} m/s")
        t0 = time.perf_counter()
        resumed = ckpt.exists()
        bar = self.progress
        run = sb.run_soil_bin(cfg, list(job["springs"]), bed=bed, device=self.device, speeds=list(job["speeds"]),
                              soil_overrides=overrides, knobs=knobs, checkpoint=ckpt, deadline=budget.deadline,
                              progress=(lambda d, n: bar(f"soil-bin job {job['name']}", d, n)) if bar else None,
                              tool=tool, place=False, passive_tool=None if job["kind"] == "rigid" else described)
        owners = job["replicas"] if "replicas" in job else [job["replica"]] * n
        first = [w for w, r in enumerate(owners) if r == 0]
        if first:  # the series of one bed (replica 0's worlds) for the figures
            keep = {"time": run.time, "travel": run.travel, "kind": np.array(job["kind"]),
                    "springs": np.asarray(job["springs"])[first], "speeds": np.asarray(job["speeds"])[first],
                    **{k: run.series[k][:, first] for k in ("draught", "displacement", "ke_tool", "ke_soil")}}
            write_atomic(path.with_suffix(".npz"), lambda tmp: np.savez_compressed(tmp, **keep))
        out = {**job, ("beds" if "replicas" in job else "bed"): fp, "rows": sb.json_safe(run.steady),
               "dt": run.dt, "steps": run.steps, "spheres": run.n_spheres, "particles": run.n_particles,
               "tool_tip_z": float(tool.tip[2]),
               "wall_s": time.perf_counter() - t0,
               "device": self.device, "versions": versions()}
        write_json_atomic(path, out)
        if not resumed:
            self._timed(timing, out["wall_s"])
        shutil.rmtree(ckpt, ignore_errors=True)
        self.log(f"  done in {out['wall_s']:.0f} s")
        return out

    def _set_aside(self, replica: int, fingerprint: str) -> None:
        """Move the finished jobs of ``replica`` made on the bed ``fingerprint`` to ``table3/stale/``: its bed had
        to be deposited again and came out another realisation, so they would not pair with the jobs to come."""
        stale = self._path("table3/stale")
        for j in self.jobs_of(replica):
            p = self._path(f"table3/{j['name']}.json")
            done = json.loads(p.read_text()) if p.exists() else {}
            beds = done.get("beds", [done.get("bed")] * len(j["springs"]))
            if any(fp == fingerprint and r == replica for fp, r in zip(beds, j.get("replicas", [replica] * len(beds)),
                                                                         strict=True)):
                stale.mkdir(parents=True, exist_ok=True)
                for q in (p, p.with_suffix(".npz")):
                    if q.exists():
                        q.replace(stale / f"{q.stem}_{fingerprint}{q.suffix}")
                self.log(f"  {j['name']} set aside: made on bed {fingerprint}, which was deposited again differently")

    def jobs_of(self, replica: int) -> list[dict]:
        """The jobs that hold worlds of ``replica``: its own, or its group's (``replica_worlds``)."""
        if not self.config.replica_worlds:
            return self.jobs(replica)
        for first, end in self.groups():
            if first <= replica < end:
                return self.group_jobs(first, end)
        return []

    def replica_group(self, first: int, end: int, soil: dict, ring: dict | None, budget: Budget) -> list[dict]:
        """Every job of replicas ``first`` .. ``end`` - 1 as worlds of the same simulations, each replica's worlds
        on one bed."""
        while True:
            results = [self.run_job(j, soil, ring, budget) for j in self.group_jobs(first, end)]
            if _one_bed_per_replica(results):
                return results

    def replica(self, r: int, soil: dict, ring: dict | None, budget: Budget) -> list[dict]:
        """Every job of replica ``r``, all on one bed."""
        while True:
            results = [self.run_job(j, soil, ring, budget) for j in self.jobs(r)]
            if len({x.get("bed") for x in results}) == 1:
                return results

    def table3(self, soil: dict, ring: dict | None, budget: Budget) -> dict:
        c = self.config
        if c.replica_worlds:
            return self._table3_grouped(soil, ring, budget)
        replicas = c.replicas_min
        r = 0
        while r < replicas:
            self.replica(r, soil, ring, budget)
            r += 1
            if r == replicas:
                stats = self.table3_stats(r)
                sems = [row["reduction"]["sem"] for rows in stats["variants"].values() for row in rows]
                replicas = replicas_needed(sems, r, c.target_sem, c.replicas_max)
                if replicas > r:
                    self.log(f"largest reduction SE {max(sems):.2f} pp with {r} replicas: running {replicas}")
        stats = self.table3_stats(replicas)
        write_json_atomic(self._path("table3.json"), stats)
        return stats

    def _table3_grouped(self, soil: dict, ring: dict | None, budget: Budget) -> dict:
        """``table3`` with replicas as worlds: group after group, each as many new replicas as the standard errors
        ask for (the groups decided are kept in ``table3/groups.json``, so that a resumed run repeats them)."""
        c = self.config
        groups = self.groups()
        i = 0
        while i < len(groups):
            write_json_atomic(self._path("table3/groups.json"), {"groups": groups})
            self.replica_group(*groups[i], soil, ring, budget)
            i += 1
            if i == len(groups):
                n = groups[-1][1]
                stats = self.table3_stats(n)
                sems = [row["reduction"]["sem"] for rows in stats["variants"].values() for row in rows]
                more = replicas_needed(sems, n, c.target_sem, c.replicas_max)
                if more > n:
                    self.log(f"largest reduction SE {max(sems):.2f} pp with {n} replicas: running {more}")
                    groups.append([n, more])
        stats = self.table3_stats(groups[-1][1])
        write_json_atomic(self._path("table3.json"), stats)
        return stats

    def _replica_jobs(self, replicas: int) -> list[tuple[dict, list[int]]]:
        """The jobs of replicas 0 .. ``replicas`` - 1, each with its worlds' replicas."""
        if not self.config.replica_worlds:
            return [(j, [r] * len(j["springs"])) for r in range(replicas) for j in self.jobs(r)]
        return [(j, j["replicas"]) for first, end in self.groups() if end <= replicas
                for j in self.group_jobs(first, end)]

    def table3_stats(self, replicas: int) -> dict:
        """Per variant and configuration: draught, rigid reference and reduction over the replicas' jobs."""
        c = self.config
        rows: dict[tuple[str, int], list[dict]] = {}
        rigid: dict[tuple[int, float], dict] = {}
        for job, owners in self._replica_jobs(replicas):
            done = self._done(f"table3/{job['name']}.json")
            for row, r in zip(done["rows"], owners, strict=True):
                if job["kind"] == "rigid":
                    rigid[(r, sb.speed_key(row["speed"]))] = row
                else:
                    rows.setdefault((job["kind"], row["springs"]), []).append({**row, "replica": r})
        speeds = c.speeds()
        out: dict[str, object] = {"replicas": replicas, "variants": {}, "rigid": []}
        for v in c.rigid_speeds():
            reps = [rigid[(r, v)] for r in range(replicas)]
            out["rigid"].append({"speed": v, "draught": ensemble([x["draught_mean"] for x in reps],
                                                                 [x["draught_sem"] for x in reps])})
        for variant in VARIANTS:
            table = []
            for n in c.springs:
                reps = rows[(variant, n)]
                refs = [rigid[(x["replica"], sb.speed_key(speeds[n]))] for x in reps]
                reds = [sb.reduction(x["draught_mean"], x["draught_sem"], ref["draught_mean"], ref["draught_sem"])
                        for x, ref in zip(reps, refs, strict=True)]
                table.append({
                    "springs": n, "speed": speeds[n],
                    "draught": ensemble([x["draught_mean"] for x in reps], [x["draught_sem"] for x in reps]),
                    "rigid": ensemble([x["draught_mean"] for x in refs], [x["draught_sem"] for x in refs]),
                    "reduction": ensemble([d[0] for d in reds], [d[1] for d in reds]),
                    "displacement_mm": ensemble([1e3 * x["displacement_mean"] for x in reps],
                                                [1e3 * x["displacement_sem"] for x in reps]),
                    "per_replica_reduction": [d[0] for d in reds]})
            out["variants"][variant] = table
        out["comparison"] = {v: compare(t, c.assembly) for v, t in out["variants"].items()}
        return out

    # ---- stage 5: diagnosis ------------------------------------------------------------------------------------
    def diagnosis_rig(self, soil: dict, budget: Budget) -> SoilBinRigModel:
        """The soil-bin rig model of the diagnosis: Table 3's rows of this run's configurations, the soil of the
        Table 3 runs, in the draught calibration's bin on its bed; each simulation must fit the budget whole."""
        c = self.config
        t3 = measured.from_paper("soil-bin")
        keep = np.isin(t3.summary["springs"], c.springs)
        data = measured.Measured({k: v[keep] for k, v in t3.summary.items()}, t3.units, [], t3.source)
        contact = soil_fields(soil)  # as run_job gives the Table 3 runs

        runs = self.out / "checkpoints" / "diagnosis_runs"
        bed_key: list[str] = []  # the bed's fingerprint, taken once

        def simulator(config: sb.SoilBinConfig, springs: list[int], speeds: list[float],
                      knobs: dict[str, list[float]] | None, soil_overrides: dict[str, list[float]] | None
                      ) -> sb.SoilBinRun:
            """run_soil_bin, each run kept (``checkpoints/diagnosis_runs/``) so that a stopped diagnosis does not
            simulate it again, whatever it had saved."""
            bed = rig.bed()
            if not bed_key:
                bed_key.append(bed_fingerprint(bed))
            what = json.dumps(sb.json_safe([asdict(config), springs, speeds, knobs, soil_overrides, bed_key[0]]),
                              sort_keys=True)
            path = runs / f"{hashlib.sha1(what.encode()).hexdigest()[:20]}.npz"
            if path.exists():
                return sb.SoilBinRun.load(path)
            per_world = self._timing("diagnosis_per_world", self._timing("draught_per_world"))
            budget.require(per_world * len(springs), f"a diagnosis simulation of {len(springs)} worlds")
            t0 = time.perf_counter()
            run = sb.run_soil_bin(config, springs, bed=bed, device=self.device, speeds=speeds, knobs=knobs,
                                  soil_overrides=soil_overrides)
            self._timed("diagnosis_per_world", (time.perf_counter() - t0) / len(springs))
            runs.mkdir(parents=True, exist_ok=True)
            run.save(path)
            return run

        rig = SoilBinRigModel(data, device=self.device, scale=CALIBRATION_SCALE[c.scale], assembly=c.assembly,
                              seed=c.seed, travel=c.calibration_travel, steady_travel=c.steady_travel,
                              settle_time=c.soil_settle_time, fragile=c.fragile, soil=contact,
                              deposit_friction=c.deposit_friction,
                              max_worlds=len(c.springs),
                              cache_dir=str(self.out / "beds"), simulator=simulator)
        return rig

    def diagnosis(self, soil: dict, budget: Budget) -> dict | None:
        """``warpdem diagnose`` of Table 3 (``diagnosis/``: its report, figures and checkpoint): every fitted point
        is one soil-bin run per configuration, saved after each; the same call continues a stopped one."""
        c = self.config
        if not c.diagnose:
            return None
        if (done := self._done("diagnosis.json")) is not None:
            return done
        rig = self.diagnosis_rig(soil, budget)
        folder = self.out / "diagnosis"
        folder.mkdir(exist_ok=True)
        checkpoint = folder / "checkpoint.json"
        deposits = not sb.bed_path(rig.config, self.out / "beds").exists()
        if deposits:
            budget.require(self._timing("deposit_draught", self._timing("deposit")), "depositing the diagnosis's bed")
        _, old = self._bed_fingerprint("diagnosis", rig.bed())
        if old is not None and checkpoint.exists():  # its points were simulated on another realisation of the bed
            checkpoint.replace(folder / f"checkpoint_{old}.json")
            self.log(f"  the diagnosis's bed was deposited again differently (was {old}): its points so far are "
                     f"set aside (diagnosis/checkpoint_{old}.json) and simulated again")
        settings = diagnosis_mod.DiagnosisSettings(
            rounds=c.diagnosis_rounds, first_grid={0: 1, 1: c.diagnosis_grid, 2: max(2, c.diagnosis_grid - 1),
                                                   3: max(2, c.diagnosis_grid - 2), 4: 2},
            mechanisms=c.diagnosis_mechanisms, batch_worlds=len(c.springs))
        self.log(f"diagnosis of Table 3 on the {rig.config.scale} bin ({len(c.springs)} configurations)")
        t0 = time.perf_counter()
        d = diagnosis_mod.diagnose(rig, settings, log=self.log, checkpoint=checkpoint)
        diagnosis_report.write(d, folder, command=f"the workflow's stage 5 ({self.out.name})")
        out = {"verdict": d.verdict, "cause": list(d.cause), "residual_left": d.residual_left,
               "rounds": c.diagnosis_rounds,
               "steps": d.steps, "ranking": d.ranking, "scale": rig.config.scale,
               "n_simulations": d.n_simulations, "wall_s_last_call": time.perf_counter() - t0,
               "baseline": {"measured": rig.measured.tolist(), "sigma": rig.sigma.tolist(),
                            "observables": list(rig.observables), "springs": [x["springs"] for x in rig.configs],
                            "simulated": np.asarray(d.verification["baseline"]["all_pred"]).tolist()}}
        write_json_atomic(self._path("diagnosis.json"), sb.json_safe(out))
        return out

    # ---- everything --------------------------------------------------------------------------------------------
    def replicas_done(self) -> int:
        """How many replicas, from the first, have every job finished on one bed."""
        if self.config.replica_worlds:
            n = 0
            for first, end in self.groups():
                done = [self._done(f"table3/{j['name']}.json") for j in self.group_jobs(first, end)]
                if any(d is None for d in done) or not _one_bed_per_replica(done):
                    return n
                n = end
            return n
        r = 0
        while True:
            done = [self._done(f"table3/{j['name']}.json") for j in self.jobs(r)]
            if any(d is None for d in done) or len({d.get("bed") for d in done}) != 1:
                return r
            r += 1

    def write_interim_report(self) -> Path:
        """report.md of the stages done so far, saying what is still to come (after a budget stop)."""

        c = self.config
        summary: dict[str, object] = {"ringing": {m: r for m in c.ringing_models
                                                  if (r := self._done(f"ringing_{m}.json")) is not None}}
        for stage in ("draught", "screening"):
            if (d := self._done(f"{stage}.json")) is not None:
                summary[stage] = d
        n = self.replicas_done()
        todo = [f"ringing ({m})" for m in c.ringing_models if m not in summary["ringing"]]
        todo += [s for s in ("draught calibration", "screening") if s.split()[0] not in summary]
        if n and "screening" in summary:
            summary["table3"] = self.table3_stats(n)
        if self._done("table3.json") is None:
            todo.append(f"Table 3 replicas ({n} of at least {c.replicas_min}, at most {c.replicas_max}, finished)")
        if (diag := self._done("diagnosis.json")) is not None:
            summary["diagnosis"] = diag
        elif c.diagnose:
            todo.append("the diagnosis of Table 3" + (" (under way: diagnosis/checkpoint.json)"
                                                      if self._path("diagnosis/checkpoint.json").exists() else ""))
        return write_workflow_report(self.out, c, summary, device=self.device,
                                     status="still to come: " + "; ".join(todo) + ". Run the same command again.")

    def run(self, budget: Budget | None = None) -> dict:
        """Run (or continue) every stage; returns the summary. Raises BudgetExhausted when the budget ends first."""
        budget = budget or Budget(None)
        t0 = time.perf_counter()
        ring = {m: self.ringing(m, budget) for m in self.config.ringing_models}
        draught = self.draught(budget)
        screening = self.screening(draught, budget)
        table3 = self.table3(screening["chosen"], ring.get("linear"), budget)
        diag = self.diagnosis(screening["chosen"], budget)
        summary = {"ringing": ring, "draught": draught, "screening": screening, "table3": table3,
                   "wall_s_last_call": time.perf_counter() - t0}
        if diag is not None:
            summary["diagnosis"] = diag
        write_json_atomic(self._path("summary.json"), sb.json_safe(summary))

        write_workflow_report(self.out, self.config, summary, device=self.device)
        return summary


def compare(table: list[dict], assembly: str = "C") -> dict[str, float]:
    """A variant's reductions against Table 3's: mean absolute error [percentage points] with its standard error
    (first order: sqrt(sum SE_i^2) / n; the laboratory's values taken exact), how many signs agree, the largest
    SE; and the same MAE and signs of the paper's DEM (Table 7): its ``assembly`` column in the 1 m bin and its
    final model (assembly C, 2 m bin)."""
    t3 = paper.table("soil_bin_measured")
    t7 = paper.table("soil_bin_dem")
    col = {"A": "a", "B": "b", "C": "c"}[assembly]
    dem1 = np.array([float(t7[f"{col}_red_pct"][t7["springs"] == r["springs"]][0]) for r in table])
    sim = np.array([r["reduction"]["mean"] for r in table])
    se = np.array([r["reduction"]["sem"] for r in table])
    lab = np.array([float(t3["reduction_pct"][t3["springs"] == r["springs"]][0]) for r in table])
    dem = np.array([float(t7["c_final_red_pct"][t7["springs"] == r["springs"]][0]) for r in table])
    return {"mae_pp": float(np.mean(np.abs(sim - lab))), "mae_sem_pp": float(np.sqrt(np.sum(se**2)) / len(se)),
            "signs_right": int(np.sum(np.sign(sim) == np.sign(lab))), "n": len(table),
            "max_sem_pp": float(np.max(se)),
            "paper_dem_mae_pp": float(np.mean(np.abs(dem - lab))),
            "paper_dem_signs_right": int(np.sum(np.sign(dem) == np.sign(lab))),
            "paper_dem_1m_mae_pp": float(np.mean(np.abs(dem1 - lab))),
            "paper_dem_1m_signs_right": int(np.sum(np.sign(dem1) == np.sign(lab)))}
