"""The paper workflow's plumbing (calibration.paper_workflow), on Warp's CPU backend.

References:
- ensemble statistics: the sampling distribution of synthetic replicas with known variances (closed forms: the
  variance of a replica mean is (tau^2 + var_record) / n; an AR(1) record's mean has variance
  sigma^2 (1 + phi) / ((1 - phi) N) for large N);
- pairing: synthetic job results whose every replica has the same reduction while the beds differ;
- resume: the same workflow run without interruption. This compares warpdem with itself: it checks that pieces,
  checkpoints and the lockstep resume without changing a bit, not the physics (which the rigs' own tests check).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from calibration.genes import GASettings
from calibration.paper_workflow import VARIANTS, Budget, Workflow, WorkflowConfig, compare, ensemble, replicas_needed
from scenes import analysis, paper
from warpdem.errors import BudgetExhausted, InputError


def _ar1(rng: np.random.Generator, n: int, phi: float, sigma: float) -> np.ndarray:
    """An AR(1) series of stationary standard deviation ``sigma``."""
    e = rng.normal(0.0, sigma * math.sqrt(1 - phi**2), n)
    x = np.empty(n)
    x[0] = rng.normal(0.0, sigma)
    for k in range(1, n):
        x[k] = phi * x[k - 1] + e[k]
    return x


def test_ensemble_standard_error_matches_the_known_variance_of_replicas():
    """Replicas = a bed effect (sd tau) + an AR(1) record (sd sigma, phi) averaged by analysis.steady_state. Over
    many trials: E[sem^2] equals the variance of the replica mean, (tau^2 + var_record) / n (tolerance 3 standard
    errors of that mean of sem^2, ~12 %), the record-based SE estimates var_record / n (15 %: the autocorrelation
    estimate's bias), and the t interval covers the true mean 95 % of the time (+- 3 binomial SE)."""
    rng = np.random.default_rng(1)
    mu, tau, sigma, phi, n_rec, n_rep, trials = 300.0, 3.0, 10.0, 0.8, 1500, 4, 400
    var_record = sigma**2 * (1 + phi) / ((1 - phi) * n_rec)
    t = np.arange(n_rec) * 0.002
    sem2, rec2, covered = [], [], 0
    for _ in range(trials):
        means, sems = [], []
        for _ in range(n_rep):
            y = mu + rng.normal(0.0, tau) + _ar1(rng, n_rec, phi, sigma)
            st = analysis.steady_state(t, y, t, start_travel=0.0)
            means.append(st.mean)
            sems.append(st.sem)
        e = ensemble(means, sems)
        assert e["n"] == n_rep
        sem2.append(e["sem"] ** 2)
        rec2.append(e["record_sem"] ** 2)
        covered += abs(e["mean"] - mu) <= stats.t.ppf(0.975, n_rep - 1) * e["sem"]
    expected = (tau**2 + var_record) / n_rep
    assert np.mean(sem2) == pytest.approx(expected, rel=3 * math.sqrt(2 / (n_rep - 1) / trials))
    assert np.mean(rec2) == pytest.approx(var_record / n_rep, rel=0.15)
    p = covered / trials
    assert abs(p - 0.95) < 3 * math.sqrt(0.95 * 0.05 / trials)


def test_ensemble_of_one_replica_takes_its_record_sem():
    e = ensemble([5.0], [0.7])
    assert e["mean"] == 5.0 and e["sem"] == pytest.approx(0.7) and math.isnan(e["std"])


def test_replicas_needed_from_the_one_over_sqrt_n_law():
    assert replicas_needed([2.0, 0.5], 3, 1.0, 20) == 12  # 3 (2 / 1)^2
    assert replicas_needed([2.0], 3, 1.0, 8) == 8  # capped
    assert replicas_needed([0.9, 0.2], 3, 1.0, 8) == 3  # already below
    assert replicas_needed([1.0 + 1e-12], 4, 1.0, 8) == 4  # at the target (rounding)
    assert replicas_needed([math.nan], 1, 1.0, 8) == 2  # one replica has no scatter yet: one more


def _config(**kw: object) -> WorkflowConfig:
    base = {"scale": "ci", "assembly": "A", "springs": (16, 32), "ringing_models": ("linear",),
            "ringing_ga": GASettings(generations=1, population=4, parents=2), "ringing_time": 1.0,
            "ringing_refine": {"linear": 2, "paper": 0},
            "draught_ga": GASettings(generations=1, population=3, parents=2), "screen_top": 1,
            "screen_changes": {"shear_displacement": 0.03, "consolidation_time": (0.02, 0.1)},
            "replicas_min": 2, "replicas_max": 2, "settle_time": 0.0, "travel": 0.2, "steady_travel": 0.1,
            "calibration_travel": 0.2, "diagnosis_mechanisms": ("sensor_offset", "extra_mass"),
            "diagnosis_grid": 2, "diagnosis_rounds": 1}
    base.update(kw)
    return WorkflowConfig(**base)


def _synthetic_jobs(wf: Workflow, jobs: list[dict], owners: list[list[int]], bed: list[float],
                    red: dict[int, float]) -> None:
    """Finished job files: on bed r the rigid draught at speed v is 300 (1 + bed[r]) + 20 v and every passive run
    draws (1 - red_n / 100) of its own bed's rigid run at its speed."""
    (wf.out / "table3").mkdir(exist_ok=True)
    for job, reps in zip(jobs, owners, strict=True):
        rows = []
        for n, v, r in zip(job["springs"], job["speeds"], reps, strict=True):
            rigid = 300.0 * (1 + bed[r]) + 20.0 * v
            d = rigid if n == 0 else rigid * (1 - red[n] / 100)
            rows.append({"springs": n, "speed": v, "draught_mean": d, "draught_sem": 2.0,
                         "displacement_mean": 1e-3 * n, "displacement_sem": 1e-5})
        (wf.out / "table3" / f"{job['name']}.json").write_text(json.dumps({**job, "rows": rows}))


@pytest.mark.parametrize("replica_worlds", [False, True])
def test_paired_reductions_remove_the_bed_effect(tmp_path, replica_worlds):
    """Synthetic jobs (``_synthetic_jobs``): the paired reductions are red_n on every bed (SE 0) although the
    draughts scatter; Table 3's MAE follows from red_n by hand. With the replicas as worlds, each world's row is
    paired within its own replica (a job holds worlds of several beds)."""
    cfg = _config(springs=paper.SPRING_COUNTS, replicas_min=3, replicas_max=3, worlds_per_job=3,
                  replica_worlds=replica_worlds)
    wf = Workflow(tmp_path, cfg)
    red = {n: 0.5 * n - 6.0 for n in cfg.springs}  # -4 ... +10 %
    bed = [0.0, 0.08, -0.05]
    if replica_worlds:
        jobs = wf.group_jobs(0, 3)
        assert any(len(set(j["replicas"])) > 1 for j in jobs)  # worlds of several beds in one simulation
        owners = [j["replicas"] for j in jobs]
    else:
        jobs = [j for r in range(3) for j in wf.jobs(r)]
        owners = [[j["replica"]] * len(j["springs"]) for j in jobs]
    _synthetic_jobs(wf, jobs, owners, bed, red)
    st = wf.table3_stats(3)
    assert len(st["rigid"]) == len(cfg.rigid_speeds()) == 6
    for variant in VARIANTS:
        for row in st["variants"][variant]:
            assert row["reduction"]["n"] == 3
            assert row["reduction"]["mean"] == pytest.approx(red[row["springs"]], abs=1e-9)
            assert row["reduction"]["sem"] == pytest.approx(0.0, abs=1e-9)
            assert row["draught"]["sem"] > 5.0  # the beds' scatter is in the draughts, not in the reductions
    t3 = paper.table("soil_bin_measured")
    mae = np.mean([abs(red[int(n)] - r) for n, r in zip(t3["springs"], t3["reduction_pct"], strict=True)])
    assert st["comparison"]["offset"]["mae_pp"] == pytest.approx(mae)
    signs = sum(np.sign(red[int(n)]) == np.sign(r) for n, r in zip(t3["springs"], t3["reduction_pct"], strict=True))
    assert compare(st["variants"]["offset"])["signs_right"] == signs


def test_a_folder_of_another_workflow_is_refused(tmp_path):
    Workflow(tmp_path, _config())
    with pytest.raises(InputError, match="another configuration"):
        Workflow(tmp_path, _config(replicas_max=3))


def test_a_folder_made_before_a_field_was_added_continues_at_its_default(tmp_path):
    """A run folder whose saved configuration lacks a field added since (here the diagnosis's) is the same run if
    that field is at its default, and another run if not."""
    import dataclasses

    cfg = dataclasses.replace(_config(), diagnosis_mechanisms=None, diagnosis_grid=5, diagnosis_rounds=3)
    Workflow(tmp_path, cfg)
    meta = tmp_path / "workflow.json"
    spec = json.loads(meta.read_text())
    for k in ("diagnose", "diagnosis_rounds", "diagnosis_grid", "diagnosis_mechanisms"):
        del spec["config"][k]
    meta.write_text(json.dumps(spec))
    Workflow(tmp_path, cfg)
    with pytest.raises(InputError, match="another configuration"):
        Workflow(tmp_path, dataclasses.replace(cfg, diagnosis_grid=3))
    with pytest.raises(InputError, match="another configuration"):
        Workflow(tmp_path, dataclasses.replace(cfg, diagnose=False))


def test_a_folder_may_change_its_diagnosis_rounds_and_sets_a_finished_diagnosis_aside(tmp_path):
    """``diagnosis_rounds`` is the one field a folder may change (its simulated points are kept and refitted, see
    test_diagnosis's test of the rounds): workflow.json takes the new value and records the change; a finished
    diagnosis (summary, report, figures) moves to diagnosis/rounds_<old>/, its checkpoint stays where the next fit
    reads it; a folder lacking the field counts it at its default. Any other change is still refused."""
    import dataclasses

    cfg = _config(diagnosis_rounds=3)
    Workflow(tmp_path, cfg)
    (tmp_path / "diagnosis").mkdir()
    for name, text in (("diagnosis.json", '{"verdict": "cause"}'), ("diagnosis/report.md", "# old"),
                       ("diagnosis/series.png", "png"), ("diagnosis/checkpoint.json", '{"cache": []}')):
        (tmp_path / name).write_text(text)
    log: list[str] = []
    Workflow(tmp_path, dataclasses.replace(cfg, diagnosis_rounds=1), log=log.append)
    spec = json.loads((tmp_path / "workflow.json").read_text())
    assert spec["config"]["diagnosis_rounds"] == 1
    assert spec["changes"] == [{"field": "diagnosis_rounds", "from": 3, "to": 1}]
    assert not (tmp_path / "diagnosis.json").exists()
    aside = tmp_path / "diagnosis" / "rounds_3"
    assert json.loads((aside / "summary.json").read_text()) == {"verdict": "cause"}
    assert sorted(p.name for p in aside.iterdir()) == ["report.md", "series.png", "summary.json"]
    assert sorted(p.name for p in (tmp_path / "diagnosis").iterdir()) == ["checkpoint.json", "rounds_3"]
    assert len(log) == 1 and "set aside" in log[0]
    Workflow(tmp_path, dataclasses.replace(cfg, diagnosis_rounds=1))  # the same again: no further change
    assert len(json.loads((tmp_path / "workflow.json").read_text())["changes"]) == 1
    with pytest.raises(InputError, match="another configuration"):
        Workflow(tmp_path, dataclasses.replace(cfg, diagnosis_rounds=2, diagnosis_grid=3))
    # a folder made before the field existed ran at its default, 3
    spec["config"].pop("diagnosis_rounds")
    spec.pop("changes")
    (tmp_path / "workflow.json").write_text(json.dumps(spec))
    Workflow(tmp_path, dataclasses.replace(cfg, diagnosis_rounds=2))
    assert json.loads((tmp_path / "workflow.json").read_text())["changes"] == [
        {"field": "diagnosis_rounds", "from": 3, "to": 2}]


class _StopAfter(Budget):
    """A budget that lets ``n`` pieces start, then stops (deterministic, unlike wall time)."""

    def __init__(self, n: int) -> None:
        super().__init__(None)
        self.n = n

    def require(self, seconds: float, what: str) -> None:
        if self.n <= 0:
            raise BudgetExhausted(f"test stop before {what}")
        self.n -= 1


class _PastDeadline(Budget):
    """Every piece may start, but a soil-bin run stops at its first checkpoint chance."""

    def __init__(self) -> None:
        super().__init__(None)
        self.deadline = time.time() - 1.0

    def require(self, seconds: float, what: str) -> None:
        pass


def _numbers(summary: dict) -> dict:
    d = summary["diagnosis"]
    return {"ringing": summary["ringing"]["linear"]["rows"], "draught": summary["draught"]["best"],
            "chosen": summary["screening"]["chosen"], "table3": summary["table3"]["variants"],
            "rigid": summary["table3"]["rigid"],
            "diagnosis": [d["verdict"], d["cause"], d["ranking"], d["baseline"]]}


def test_workflow_stopped_at_every_kind_of_piece_resumes_to_the_uninterrupted_result(tmp_path):
    """ci scale, assembly A: the whole workflow in one call, and again in calls that stop inside the ringing
    lockstep, between GA generations, inside a soil-bin run (from its checkpoint), between jobs and between the
    diagnosis's simulations. The two summaries, the diagnosis's verdict and fits included, agree to the bit (CPU)."""
    cfg = _config()
    whole = Workflow(tmp_path / "whole", cfg, device="cpu").run()
    import shutil

    shutil.copytree(tmp_path / "whole" / "beds", tmp_path / "pieces" / "beds")
    wf = Workflow(tmp_path / "pieces", cfg, device="cpu")
    stops = []
    budgets = [_StopAfter(1), _StopAfter(1), _PastDeadline()]
    for k in range(40):
        budget = budgets[k] if k < len(budgets) else _StopAfter(1)
        try:
            pieces = wf.run(budget)
            break
        except BudgetExhausted as e:
            stops.append(str(e))
            wf = Workflow(tmp_path / "pieces", cfg, device="cpu")
    else:
        pytest.fail(f"the workflow did not end in 40 calls: {stops[-3:]}")
    assert any("lockstep" in s for s in stops)  # stopped inside the ringing calibration's lockstep
    assert any("soil-bin run stopped" in s for s in stops), stops  # and inside a soil-bin run
    assert any("a diagnosis simulation" in s for s in stops), stops  # and inside the diagnosis
    assert len(stops) >= 8
    assert _numbers(pieces) == _numbers(whole)


def test_jobs_on_a_bed_deposited_again_differently_are_set_aside(tmp_path):
    """Pairing rule: a replica's reductions pair jobs of ONE bed. When the bed had to be deposited again and came out
    another realisation (CUDA deposition is not repeatable), the replica's finished jobs on the old bed move to
    table3/stale/ so that they are run again on the new one; jobs of other replicas stay."""
    from scenes.assemblies import AssemblySpec, Bed

    wf = Workflow(tmp_path, _config())
    bed = Bed(AssemblySpec(kind="A", radius=0.02), (0.5, 0.65, 0.45), 0.2, np.zeros((3, 3)), np.full(3, 0.02),
              np.arange(3))
    other = Bed(bed.spec, bed.bin_size, bed.depth, bed.centres + 1e-9, bed.radii, bed.particle)
    fp, old = wf._bed_fingerprint("replica_0", bed)
    assert old is None and wf._bed_fingerprint("replica_0", bed) == (fp, None)
    (tmp_path / "table3").mkdir()
    for r in (0, 1):
        for j in wf.jobs(r):
            (tmp_path / "table3" / f"{j['name']}.json").write_text(json.dumps({**j, "bed": fp}))
    fp2, old = wf._bed_fingerprint("replica_0", other)
    assert fp2 != fp and old == fp
    wf._set_aside(0, old)
    left = sorted(p.name for p in (tmp_path / "table3").glob("*.json"))
    assert left == sorted(f"{j['name']}.json" for j in wf.jobs(1))
    assert len(list((tmp_path / "table3" / "stale").glob("*.json"))) == len(wf.jobs(0))


def test_group_jobs_on_a_bed_deposited_again_differently_are_set_aside(tmp_path):
    """Pairing rule with the replicas as worlds: when replica 0's bed came out another realisation, every finished
    job holding a world of replica 0 moves to table3/stale/; the jobs of a later group stay."""
    from scenes.assemblies import AssemblySpec, Bed

    wf = Workflow(tmp_path, _config(replica_worlds=True))
    bed = Bed(AssemblySpec(kind="A", radius=0.02), (0.5, 0.65, 0.45), 0.2, np.zeros((3, 3)), np.full(3, 0.02),
              np.arange(3))
    other = Bed(bed.spec, bed.bin_size, bed.depth, bed.centres + 1e-9, bed.radii, bed.particle)
    fp, _ = wf._bed_fingerprint("replica_0", bed)
    (tmp_path / "table3").mkdir()
    (tmp_path / "table3" / "groups.json").write_text(json.dumps({"groups": [[0, 2], [2, 3]]}))
    first, later = wf.group_jobs(0, 2), wf.group_jobs(2, 3)
    for j in first + later:
        beds = [fp if r == 0 else f"bed{r}" for r in j["replicas"]]
        (tmp_path / "table3" / f"{j['name']}.json").write_text(json.dumps({**j, "beds": beds}))
    _, old = wf._bed_fingerprint("replica_0", other)
    assert old == fp
    wf._set_aside(0, old)
    holding = [j for j in first if 0 in j["replicas"]]
    assert 0 < len(holding) <= len(first)
    left = sorted(p.name for p in (tmp_path / "table3").glob("*.json") if p.name != "groups.json")
    assert left == sorted(f"{j['name']}.json" for j in first + later if j not in holding)
    assert len(list((tmp_path / "table3" / "stale").glob("*.json"))) == len(holding)


def test_replicas_as_worlds_run_in_groups_each_world_on_its_own_bed(tmp_path):
    """ci scale, 16 springs, replica beds: the first group holds replicas 0 and 1, and a target standard error no
    run can reach adds replica 2 as a second group. Reference: replica 0's rigid world run alone on its bed (same
    tool pose, time step and soil): the same draught to the bit, so the workflow wires each world to its own bed
    and settings. Every reduction averages three replicas, each world's bed is its replica's (beds.json). Each
    replica's deposition and each soil-bin job shows its progress, every job's to the end."""
    from scenes import soil_bin as sb

    cfg = _config(springs=(16,), replicas_min=2, replicas_max=3, target_sem=1e-6, replica_worlds=True,
                  travel=0.1, steady_travel=0.05, diagnose=False)
    bars: dict[str, tuple[float, float]] = {}
    wf = Workflow(tmp_path, cfg, device="cpu", progress=lambda stage, d, n: bars.__setitem__(stage, (d, n)))
    soil = {"friction_angle": 30.0, "normal_cohesion": 500.0, "eta_roll": 0.1}
    st = wf.table3(soil, None, Budget(None))
    assert {f"replica {r}'s bed: fill" for r in range(3)} <= set(bars)
    jobs = {k: v for k, v in bars.items() if k.startswith("soil-bin job")}
    assert len(jobs) == len(wf.group_jobs(0, 2)) + len(wf.group_jobs(2, 3))
    assert all(d == n > 0 for d, n in jobs.values()), jobs
    assert wf.groups() == [[0, 2], [2, 3]]
    assert wf.replicas_done() == 3
    for variant in VARIANTS:
        assert [row["reduction"]["n"] for row in st["variants"][variant]] == [3]
    prints = json.loads((tmp_path / "beds.json").read_text())
    job = wf.group_jobs(0, 2)[0]
    done = json.loads((tmp_path / "table3" / f"{job['name']}.json").read_text())
    assert job["kind"] == "rigid" and done["replicas"] == [0, 1]
    assert done["beds"] == [prints[f"replica_{r}"] for r in (0, 1)]
    # one tool pose for a group's jobs: each replica's rigid and passive worlds cut at one depth
    tips = {json.loads((tmp_path / "table3" / f"{j['name']}.json").read_text())["tool_tip_z"]
            for j in wf.group_jobs(0, 2)}
    assert len(tips) == 1
    run_cfg = sb.SoilBinConfig(scale=cfg.scale, assembly=cfg.assembly, springs=(0, 0), speed=tuple(done["speeds"]),
                               travel=cfg.travel, steady_travel=cfg.steady_travel, seed=cfg.seed, settle_time=0.0)
    beds = [sb.bed_for(run_cfg, cache_dir=tmp_path / "beds", replica=r) for r in (0, 1)]
    tool = sb.place_tool(beds, run_cfg.working_depth)
    model, _, _ = sb.build_scene(run_cfg, beds, tool, [0, 0], done["speeds"], "cpu")
    one = replace(run_cfg, springs=(0,), speed=(done["speeds"][0],),
                  dt=sb.default_dt(model, run_cfg.spring_model, rigid=True))
    overrides = {"friction_angle": [30.0], "normal_cohesion": [500.0], "shear_cohesion": [250.0], "eta_roll": [0.1],
                 "eta_twist": [0.1]}
    alone = sb.run_soil_bin(one, [0], bed=beds[0], device="cpu", speeds=[done["speeds"][0]], tool=tool,
                            place=False, soil_overrides=overrides)
    assert done["dt"] == one.dt
    assert done["rows"][0]["draught_mean"] == alone.steady[0]["draught_mean"]


def test_replica_groups_stopped_anywhere_resume_to_the_uninterrupted_result(tmp_path):
    """ci scale, replicas as worlds: Table 3 in one call, and again in calls that stop inside a soil-bin run of a
    shared layout (from its checkpoint) and between jobs, across the second group that the target standard error
    adds. The groups and the statistics agree to the bit (CPU). This compares warpdem with itself: it checks the
    bookkeeping of groups, checkpoints and resumes, not the physics (test_replica_beds.py checks that)."""
    import shutil

    cfg = _config(springs=(16,), replicas_min=2, replicas_max=3, target_sem=1e-6, replica_worlds=True,
                  travel=0.1, steady_travel=0.05, diagnose=False)
    soil = {"friction_angle": 30.0, "normal_cohesion": 500.0, "eta_roll": 0.1}
    whole = Workflow(tmp_path / "whole", cfg, device="cpu").table3(soil, None, Budget(None))
    shutil.copytree(tmp_path / "whole" / "beds", tmp_path / "pieces" / "beds")
    budgets = [_PastDeadline(), _StopAfter(1), _PastDeadline()]
    stops = []
    for k in range(30):
        wf = Workflow(tmp_path / "pieces", cfg, device="cpu")
        try:
            pieces = wf.table3(soil, None, budgets[k] if k < len(budgets) else _StopAfter(1))
            break
        except BudgetExhausted as e:
            stops.append(str(e))
    else:
        pytest.fail(f"Table 3 did not end in 30 calls: {stops[-3:]}")
    assert any("soil-bin run stopped" in s for s in stops), stops
    assert any("test stop before" in s for s in stops), stops
    assert wf.groups() == [[0, 2], [2, 3]]
    assert json.dumps(pieces, sort_keys=True) == json.dumps(whole, sort_keys=True)


def test_cli_full_workflow_stops_with_exit_3_and_refuses_another_configuration(tmp_path, capsys):
    """`warpdem reproduce --workflow full --budget S`: when the next piece would not fit (a budget of 1 ms lets the
    first ringing batch start, then none), it stops with exit code 3 and one line; the same folder with another
    configuration is a one-line input error (exit 2) and leaves the folder as it was."""
    from calibration.cli import main

    out = tmp_path / "wf"
    args = ["reproduce", "--workflow", "full", "--scale", "ci", "--assembly", "A", "--springs", "16,32",
            "--generations", "1", "--population", "2", "--parents", "1", "--device", "cpu", "--out", str(out)]
    capsys.readouterr()
    assert main([*args, "--budget", "0.001"]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("warpdem reproduce: stopped: stopped before a lockstep batch")
    assert not (out / "ringing_linear.json").exists()
    before = sorted(p.relative_to(out) for p in out.rglob("*"))
    assert main([*args, "--replicas-max", "4"]) == 2
    assert "holds another run" in capsys.readouterr().err
    assert sorted(p.relative_to(out) for p in out.rglob("*")) == before


def test_lockstep_sets_aside_unstable_individuals_as_each_calibration_alone_would():
    """Three GA calibrations of a closed-form oscillator in lockstep, whose combined "simulation" goes unstable
    (SimulationError naming the world) when any individual's stiffness exceeds a limit. Reference: each calibration
    run alone with the same failing evaluator. Records (genes, observables, failures, fitness) agree exactly: the
    owner of the unstable world sets that individual aside and the others' batches are simulated again."""
    from test_calibration import UnstableAboveOscillator

    from calibration.ga import calibrate
    from calibration.paper_workflow import Lockstep
    from warpdem.errors import SimulationError

    limit = 2000.0
    problems = [UnstableAboveOscillator(limit, hint=True) for _ in range(3)]
    for k, p in enumerate(problems):
        p.targets = {"freq_hz": 5.0 + k, "damping": 0.1 + 0.05 * k}
    settings = [GASettings(generations=3, population=10, parents=4, seed=s) for s in range(3)]

    def run_batches(batch):
        values = np.concatenate([np.atleast_2d(v) for _, v in batch])
        bad = np.flatnonzero(values[:, 0] > limit)
        if len(bad):
            raise SimulationError("unstable", cause="speed", world=int(bad[0]))
        out = []
        for i, v in batch:
            out.append(super(UnstableAboveOscillator, problems[i]).evaluate(np.atleast_2d(v)))
        return out

    def record(r):  # NaN observables compare equal as None
        return r.genes, {n: None if math.isnan(v) else v for n, v in r.observables.items()}, bool(r.failure), r.fitness

    lock = Lockstep(run_batches, Budget(None))
    together = lock.run([lambda ev, k=k: calibrate(problems[k], settings[k], evaluator=ev) for k in range(3)])
    for k in range(3):
        alone_problem = UnstableAboveOscillator(limit, hint=True)
        alone_problem.targets = problems[k].targets
        alone = calibrate(alone_problem, settings[k])
        assert [record(r) for r in together[k].archive] == [record(r) for r in alone.archive]
        assert any(r.failure for r in together[k].archive)


class _Asked(Budget):
    """A budget that records what it is asked for and refuses it (the test stops there)."""

    def __init__(self) -> None:
        super().__init__(None)
        self.asked: list[tuple[float, str]] = []

    def require(self, seconds: float, what: str) -> None:
        self.asked.append((seconds, what))
        raise BudgetExhausted(f"test stop before {what}")


def test_a_bed_deposition_must_fit_the_budget_whole(tmp_path):
    """A Table 3 job whose bed is not deposited yet first asks the budget for the deposition, sized by the last
    deposition's recorded wall time (timings.json), and stops before it when that does not fit: no bed file is
    started (a deposition cannot be checkpointed)."""

    wf = Workflow(tmp_path, _config())
    (tmp_path / "timings.json").write_text(json.dumps({"deposit": 123.0}))
    budget = _Asked()
    soil = {"friction_angle": 30.0, "normal_cohesion": 100.0, "eta_roll": 0.1}
    with pytest.raises(BudgetExhausted, match="depositing replica 0's bed"):
        wf.run_job(wf.jobs(0)[0], soil, None, budget)
    assert budget.asked == [(123.0, "depositing replica 0's bed")]
    assert not (tmp_path / "beds").exists() or not list((tmp_path / "beds").glob("*.npz"))


def test_the_draught_calibrations_bed_must_fit_the_budget_whole(tmp_path):
    """The draught calibration's bed is deposited before its first generation: that deposition asks the budget first
    too, sized by its own last recorded time or, before there is one, a Table 3 bed's (timings.json), and stops
    before depositing anything when it does not fit."""

    wf = Workflow(tmp_path, _config())
    for timings, expected in (({"deposit": 123.0}, 123.0), ({"deposit": 123.0, "deposit_draught": 45.0}, 45.0)):
        (tmp_path / "timings.json").write_text(json.dumps(timings))
        budget = _Asked()
        with pytest.raises(BudgetExhausted, match="depositing the draught calibration's bed"):
            wf.draught(budget)
        assert budget.asked == [(expected, "depositing the draught calibration's bed")]
        assert not (tmp_path / "beds").exists() or not list((tmp_path / "beds").glob("*.npz"))


def test_cli_continues_a_run_made_before_its_newer_options(tmp_path, capsys):
    """A run folder whose claim and workflow.json predate the diagnosis's options (no such keys) is the same run
    for the same command with those options at their defaults (it continues: exit 3 at the budget again), and
    another run with one of them changed (exit 2, one line)."""
    from calibration.cli import main

    out = tmp_path / "wf"
    args = ["reproduce", "--workflow", "full", "--scale", "ci", "--assembly", "A", "--springs", "16,32",
            "--generations", "1", "--population", "2", "--parents", "1", "--device", "cpu", "--out", str(out),
            "--budget", "0.001"]
    assert main(args) == 3
    new = {"no_diagnosis": "diagnose", "diagnosis_rounds": "diagnosis_rounds", "diagnosis_grid": "diagnosis_grid"}
    claim = json.loads((out / ".warpdem-run.json").read_text())
    spec = json.loads((out / "workflow.json").read_text())
    for k, field in new.items():
        claim.pop(k, None)  # the rounds are no part of the claim (a folder may change them)
        del spec["config"][field]
    del spec["config"]["diagnosis_mechanisms"]
    (out / ".warpdem-run.json").write_text(json.dumps(claim))
    (out / "workflow.json").write_text(json.dumps(spec))
    capsys.readouterr()
    assert main(args) == 3
    assert "stopped before a lockstep batch" in capsys.readouterr().err
    assert main([*args, "--diagnosis-grid", "3"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "holds another run" in err[0]
    # another number of diagnosis rounds continues the same folder, and later calls without the option keep it
    assert main([*args, "--diagnosis-rounds", "1"]) == 3
    assert json.loads((out / "workflow.json").read_text())["config"]["diagnosis_rounds"] == 1
    assert main(args) == 3
    assert json.loads((out / "workflow.json").read_text())["config"]["diagnosis_rounds"] == 1
    # a claim written while the rounds were part of it (folders made before they could change) is the same run
    claim = json.loads((out / ".warpdem-run.json").read_text())
    (out / ".warpdem-run.json").write_text(json.dumps({**claim, "diagnosis_rounds": 3}))
    assert main([*args, "--diagnosis-rounds", "2"]) == 3
    assert json.loads((out / "workflow.json").read_text())["config"]["diagnosis_rounds"] == 2


@pytest.mark.parametrize(("field", "value", "named"), [
    ("diagnosis_rounds", 0, "diagnosis_rounds"), ("diagnosis_grid", 1, "diagnosis_grid"),
    ("diagnosis_mechanisms", ("load_inertia",), "'load_inertia' is not a soil-bin mechanism"),
    ("diagnosis_mechanisms", ("no_such",), "'no_such' is not a soil-bin mechanism")])
def test_bad_diagnosis_settings_are_refused_by_name(field, value, named):
    with pytest.raises(InputError, match=named):
        _config(**{field: value})


def test_a_kept_soil_bin_run_reads_back_as_it_was(tmp_path):
    """SoilBinRun.save/load (the diagnosis's kept runs): arrays, series and steady rows as written, NaN (a failed
    extraction) kept as NaN, integers as integers."""
    from scenes import soil_bin as sb

    run = sb.SoilBinRun((16, 32), (0.68, 0.52), np.arange(3.0), np.ones((3, 2)),
                        {"draught": np.arange(6.0).reshape(3, 2), "ke_tool": np.zeros((3, 2, 2))},
                        [{"springs": np.int64(16), "draught_mean": np.float64(1.5), "draught_sem": math.nan},
                         {"springs": 32, "draught_mean": 2.5, "draught_sem": 0.1}], 5, 7, 1e-5, 100, 2.5)
    run.save(tmp_path / "run.npz")
    back = sb.SoilBinRun.load(tmp_path / "run.npz")
    assert (back.springs, back.speeds, back.n_particles, back.n_spheres, back.dt, back.steps, back.wall_s) == \
        ((16, 32), (0.68, 0.52), 5, 7, 1e-5, 100, 2.5)
    for k in ("time", "travel"):
        np.testing.assert_array_equal(getattr(back, k), getattr(run, k))
    assert sorted(back.series) == ["draught", "ke_tool"]
    for k, v in run.series.items():
        np.testing.assert_array_equal(back.series[k], v)
    assert back.steady[0]["springs"] == 16 and math.isnan(back.steady[0]["draught_sem"])
    assert back.steady[1] == run.steady[1]


def test_limits_of_the_match_are_read_from_the_runs_numbers() -> None:
    # Reference: synthetic Table 3 rows built from the laboratory's (scenes.paper) by closed forms: reductions
    # 1 + 0.2 x the laboratory's (a Pearson correlation of exactly 1, a spread of 0.2 x the laboratory's), and a
    # displacement of 0.25 x the laboratory's from 12 springs up, 2 x below it (ratios known exactly); a second
    # variant with reductions 3 - 0.6 x the laboratory's (correlation -1).
    from calibration.workflow_report import limits, limits_section

    t3 = paper.table("soil_bin_measured")
    lab_red, lab_disp = np.asarray(t3["reduction_pct"], float), np.asarray(t3["displacement_mean_mm"], float)

    def rows(a: float, b: float) -> list[dict]:
        return [{"springs": int(n), "reduction": {"mean": a + b * r, "sem": 0.1},
                 "displacement_mm": {"mean": (0.25 if n >= 12 else 2.0) * d, "sem": 0.01}}
                for n, r, d in zip(t3["springs"], lab_red, lab_disp, strict=True)]

    tab = {"variants": {"offset": rows(1.0, 0.2), "no_offset": rows(3.0, -0.6)}}
    screening = {"rows": [
        {"rank": 2, "normal_cohesion": 15.0, "draught_mean_n": 340.0, "cohesion_kpa": 0.3, "friction_angle_deg": 43.0},
        {"rank": 1, "normal_cohesion": 4.2e4, "draught_mean_n": 346.0, "cohesion_kpa": 0.5,
         "friction_angle_deg": 39.6}]}
    lim = limits(tab, screening)
    off, no = lim["variants"]["offset"], lim["variants"]["no_offset"]
    assert off["correlation"] == pytest.approx(1.0, abs=1e-12)
    assert no["correlation"] == pytest.approx(-1.0, abs=1e-12)
    np.testing.assert_allclose(off["disp_ratio"], np.where(t3["springs"] >= 12, 0.25, 2.0), rtol=1e-12)
    spread = lab_red.max() - lab_red.min()
    assert off["sim_reduction_pct"][1] - off["sim_reduction_pct"][0] == pytest.approx(0.2 * spread, rel=1e-12)
    assert lim["screening"]["cohesion_kpa"] == 0.5  # the rank-1 set's
    assert lim["screening"]["normal_cohesion_pa"] == [15.0, 4.2e4]
    text = "\n".join(limits_section(tab, screening))
    assert "below half the laboratory's for 6 of 8 configurations: 12, 16, 20, 24, 28, 32 springs" in text
    assert "r = 1.00" in text and "r = -1.00" in text
    assert "does not pin the cohesion down" in text  # 2,800 x in cohesion at draughts within 2 %
    assert "keeps the reductions from the laboratory's" not in text  # the second variant spreads 0.6 x: not narrow
    only_narrow = "\n".join(limits_section({"variants": {"offset": rows(1.0, 0.2)}}, None))
    assert "keeps the reductions from the laboratory's" in only_narrow and "The soil" not in only_narrow


def test_the_bonded_soil_protocol_calibrates_draught_and_shear_box_and_keeps_its_bonds(tmp_path, monkeypatch):
    """soil_protocol "bonded" (docs/runs/bond_protocols_h100): the draught stage's problem is the joint one (draught
    and shear box, yielding bonds, the bed settled at least BONDED_SETTLE), and Table 3's soil-bin runs take the same
    bonds and settling; the paper's protocol keeps the draught alone and fragile bonds."""
    from calibration.problems import DraughtProblem, SoilProblem
    from calibration.workflow_config import BONDED_SETTLE
    from scenes import soil_bin as sb

    with pytest.raises(InputError, match="soil_protocol must be one of"):
        _config(soil_protocol="glued")
    paper_wf = Workflow(tmp_path / "paper", _config())
    assert type(paper_wf.draught_problem()) is DraughtProblem and paper_wf.config.fragile
    wf = Workflow(tmp_path / "bonded", _config(soil_protocol="bonded", settle_time=0.2))
    p = wf.draught_problem()
    assert isinstance(p, SoilProblem) and not p.fragile and p.settle_time == BONDED_SETTLE
    assert not p.config.fragile and not p.box.fragile
    assert p.box.shear_displacement == 0.03  # the workflow's screen_changes reach the joint problem's box
    seen = []

    def capture(config: object, *a: object, **k: object) -> None:
        seen.append(config)
        raise RuntimeError("captured")

    monkeypatch.setattr(sb, "run_soil_bin", capture)
    with pytest.raises(RuntimeError, match="captured"):
        wf.run_job(wf.jobs(0)[0], {"friction_angle": 30.0, "normal_cohesion": 1e4, "eta_roll": 0.05}, None,
                   Budget(None))
    assert not seen[0].fragile and seen[0].settle_time == BONDED_SETTLE
    # The screening box: the paper's on the box's own sample (seed 0) with breaking bonds; "bonded" with yielding bonds
    # on the first sample its calibration's box never saw (seeds 0 .. box_samples - 1), a held-out check.
    from calibration import paper_workflow as pw

    asked = []

    def fake_screen(sets: object, *a: object, **k: object) -> list[dict]:
        asked.append(k)
        return [{"set": 1, "friction_angle": 30.0, "normal_cohesion": 1e4, "eta_roll": 0.05}]

    monkeypatch.setattr(pw, "screen", fake_screen)
    draught = {"candidates": [{"genes": {"friction_angle": 30.0, "normal_cohesion": 1e4, "eta_roll": 0.05},
                               "draught_mean_n": 340.0}], "accepted": 1}
    three = Workflow(tmp_path / "three", _config(soil_protocol="bonded", box_samples=3))
    for flow in (paper_wf, wf, three):
        flow.screening(draught, Budget(None))
    assert [(k.get("fragile", True), k.get("seed", 0)) for k in asked] == [(True, 0), (False, 1), (False, 3)]


def test_the_full_workflow_calibrates_the_soil_to_draught_and_box_unless_told_or_continuing(tmp_path,
                                                                                            full_workflow_start
                                                                                            ) -> None:
    """`reproduce --workflow full` in a new folder calibrates the soil to the draught and the shear box together
    ("bonded") with the box at 20-80 kPa (docs/runs/soil_ga_loose_box_h100x2: the soil that reached both);
    `--soil-protocol paper` keeps the paper's way and its box; `--box-stresses` sets the box's stresses; a folder made
    with the paper's protocol goes on with it when the command does not say. The joint calibration's box runs three
    samples per individual in a new folder (calibration.cli.SOIL_BOX_SAMPLES)."""
    from calibration import paper_workflow as pw

    configs = [full_workflow_start(tmp_path / "new"),
               full_workflow_start(tmp_path / "paper", "--soil-protocol", "paper"),
               full_workflow_start(tmp_path / "paper"),  # the folder's own protocol
               full_workflow_start(tmp_path / "low", "--box-stresses", "5,10,20")]
    stresses = {"normal_stresses": [20e3, 40e3, 80e3]}
    assert [(c.soil_protocol, json.loads(json.dumps(c.screen_changes))) for c in configs] == [
        ("bonded", stresses), ("paper", {}), ("paper", {}), ("bonded", {"normal_stresses": [5e3, 10e3, 20e3]})]
    assert [c.box_samples for c in configs] == [3, 1, 1, 3]  # box samples per individual: the joint GA's only
    config = pw.WorkflowConfig(scale="ci", assembly="A", soil_protocol="bonded", screen_changes=stresses,
                               box_samples=3)
    problem = pw.Workflow(tmp_path / "api", config).draught_problem()
    assert problem.name == "soil" and tuple(problem.box.normal_stresses) == (20e3, 40e3, 80e3)
    assert problem.box_samples == 3 and problem.simulation_key()["box_samples"] == 3
