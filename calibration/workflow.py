"""A whole calibration as the ``warpdem calibrate`` command runs it: GA (+ refinement), screening, report.

    from calibration.workflow import run_calibration
    run_calibration("ringing", "results/calibrate/ringing_16", springs=16, spring_model="linear", fitness="max",
                    settings=GASettings(refine_iterations=12))
    run_calibration("draught", "results/calibrate/draught_C", assembly="C", scale="ci", screen_scale="ci")
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path

from .archive import write_json_atomic
from .budget import BatchGuard, Budget
from .evaluators import LocalEvaluator, RayEvaluator
from .ga import CalibrationResult, accepted_records, calibrate
from .genes import GASettings
from .problems import SoilProblem, make_problem
from .report import write_report
from .screening import screen

TIMING_FILE = "batch_timing.json"
"""in a calibration's folder: the last GA batch's wall time per individual [s], which sizes a later call's budget
check."""
HELD_OUT_FILE = "held_out_box.json"
"""a soil calibration's held-out box check of its best set (genes, result, wall time), kept so that the same command
run again (e.g. after its budget stopped it) neither repeats nor skips it."""


def _held_out_box(problem: SoilProblem, genes: dict[str, float], path: Path, clock: Budget,
                  estimate: float) -> dict[str, object]:
    """:meth:`SoilProblem.held_out_box` of ``genes``: read from ``path`` when it holds those genes' check with this
    problem's simulation; else run when ``estimate`` [s] fits the budget (the GA's time per individual times the
    box samples: an individual's share of a batch, soil bin and boxes, against one set's boxes alone), raising
    BudgetExhausted otherwise."""
    key = {"genes": {k: float(v) for k, v in genes.items()},
           "simulation_key": json.loads(json.dumps(problem.simulation_key()))}
    if path.exists():
        saved = json.loads(path.read_text())
        if {k: saved.get(k) for k in key} == key:
            return {"held_out_box": saved["held_out_box"], "held_out_box_wall_s": saved["held_out_box_wall_s"]}
    clock.require(estimate, "the held-out shear box of the best set (the calibration itself is finished)")
    t0 = time.perf_counter()
    held = {"held_out_box": problem.held_out_box(genes), "held_out_box_wall_s": time.perf_counter() - t0}
    write_json_atomic(path, {**key, **held})
    return held


def run_calibration(kind: str, out: str | Path, *, settings: GASettings | None = None, device: str | None = None,
                    ray_workers: int | None = None, ray_address: str | None = None, gpus_per_worker: float = 0.0,
                    screen_scale: str | None = None, screen_top: int = 6, archive: str | Path | None = None,
                    resume: bool = True, progress: Callable[[dict[str, object]], None] | None = None,
                    screen_progress: Callable[[str, float, float], None] | None = None,
                    budget: float | None = None,
                    **problem_kwargs: object) -> tuple[CalibrationResult, dict[str, object]]:
    """Calibrate, screen (draught: the accepted sets, at most ``screen_top`` of them, in the shear box at
    ``screen_scale``; None skips it) and write the report into ``out``.

    ``ray_workers`` or ``ray_address``: evaluate through :class:`~calibration.evaluators.RayEvaluator`.
    ``screen_progress(phase, done, total)``: the shear box's progress (simulated times [s]).
    ``budget``: wall time [s] for this call. A GA batch that would not fit (as long per individual as the last one,
    also a previous call's: ``out/batch_timing.json``) is not started: :class:`warpdem.errors.BudgetExhausted` is
    raised with every finished generation saved, and the same call continues the calibration.
    ``problem_kwargs``: the problem's fields (:mod:`calibration.problems`). Returns the result and a summary dict.
    """
    clock = Budget(budget)
    out = Path(out)
    if kind in ("draught", "soil"):
        problem_kwargs.setdefault("cache_dir", str(out / "beds"))
    problem = make_problem(kind, device=device, **problem_kwargs)
    use_ray = ray_workers is not None or ray_address is not None
    extra: dict[str, object] = {"device": device, "evaluator": "ray" if use_ray else "local"}
    if use_ray and kind in ("draught", "soil"):  # deposited (or read) once here, into cache_dir, which the workers read
        problem.bed()
    evaluator = (RayEvaluator(problem, ray_workers, address=ray_address, gpus_per_worker=gpus_per_worker)
                 if use_ray else LocalEvaluator(problem))
    try:
        if use_ray:
            extra["workers"] = evaluator.placements()
        timing = out / TIMING_FILE
        guard = BatchGuard(evaluator, clock, "individuals",
                           json.loads(timing.read_text())["per_individual_s"] if timing.exists() else 0.0,
                           lambda v: write_json_atomic(timing, {"per_individual_s": v}))
        result = calibrate(problem, settings, out=out, evaluator=guard, resume=resume, archive=archive,
                           progress=progress)
    finally:
        evaluator.close()
    screening = None
    if kind == "draught":
        accepted = accepted_records(result, problem)
        extra["n_accepted"] = len(accepted)
        if screen_scale is not None and accepted:
            t0 = time.perf_counter()
            screening = screen([r.genes for r in accepted[:screen_top]], problem.assembly, screen_scale,
                               device=device, progress=screen_progress)
            extra["screening_wall_s"] = time.perf_counter() - t0
    if kind == "soil":
        extra.update(_held_out_box(problem, result.best.genes, out / HELD_OUT_FILE, clock,
                                   guard.per_individual * problem.box_samples))
    write_report(result, problem, out, screening=screening, extra=extra)
    return result, {"best": result.best, "screening": screening, **extra}
