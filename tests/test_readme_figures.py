"""The README's measured figures against the committed runs they quote (docs/runs/), so that a rerun that changes
a number and a README that is not updated cannot both be committed.

Reference: each case reads the committed run's own files (summary.json, result.json) and formats the value as the
README prints it; the README must contain that text. Figures without a committed run behind them are listed in
docs/figures-review.md ("README figures without a run")."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RUNS = ROOT / "docs" / "runs"


def _readme() -> str:
    """The README with its line breaks folded to spaces (a quoted phrase may wrap)."""
    return " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())


def _json(path: str) -> object:
    return json.loads((RUNS / path).read_text(encoding="utf-8"))


WORDS = {n: w for n, w in enumerate(("none", "one", "two", "three", "four", "five", "six", "seven", "eight"))}
"""small counts as the README spells them."""


def _soil_bin_s8() -> list[str]:
    rows = {(r["springs"], r["speed"]): r for r in _json("soil_bin_paper_h100_s8/summary.json")}
    r68, r52 = rows[(0, 0.68)], rows[(0, 0.52)]
    p16, p32 = rows[(16, 0.68)], rows[(32, 0.52)]
    return [f"rigid {r68['draught_mean']:.1f} N (standard error {r68['draught_sem']:.1f}) at 0.68 m/s and "
            f"{r52['draught_mean']:.1f} N ({r52['draught_sem']:.1f}) at 0.52 m/s",
            f"16 springs reduction {p16['reduction_pct']:+.1f} % (SE {p16['reduction_sem']:.1f}), 32 springs "
            f"{p32['reduction_pct']:+.1f} % (SE {p32['reduction_sem']:.1f})"]


def _table3_workflow() -> list[str]:
    s = _json("table3-paper-h100/summary.json")
    d = s["draught"]
    cmp_ = s["table3"]["comparison"]
    off, no = cmp_["offset"], cmp_["no_offset"]
    rows = [r for v in s["table3"]["variants"].values() for r in v]
    red = [r["reduction"]["mean"] for r in rows]
    disp = [r["displacement_mm"]["mean"] for r in rows]
    screen = s["screening"]["rows"]
    steps = s["diagnosis"]["steps"]
    return [
        f"the draught calibration reaches {d['best']['observables']['draught_mean_n']:.1f} N against the "
        f"laboratory's {d['target_n']:.2f} N",
        f"the calibrated soils give {min(r['cohesion_kpa'] for r in screen):.1f}-"
        f"{max(r['cohesion_kpa'] for r in screen):.1f} kPa and {min(r['friction_angle_deg'] for r in screen):.0f}-"
        f"{max(r['friction_angle_deg'] for r in screen):.0f} deg in the shear box",
        f"mean absolute error of {off['mae_pp']:.2f} +- {off['mae_sem_pp']:.2f} percentage points with Table 2's "
        f"support offsets ({off['signs_right']} of {off['n']} signs right) and {no['mae_pp']:.2f} +- "
        f"{no['mae_sem_pp']:.2f} without ({no['signs_right']} of {no['n']}; the paper's final DEM: "
        f"{off['paper_dem_mae_pp']:.2f}, {off['paper_dem_signs_right']} of {off['n']})",
        f"every reduction's standard error at most {off['max_sem_pp']:.2f} and {no['max_sem_pp']:.2f} points",
        f"every reduction lies between {min(red):.1f} and {max(red):+.1f} %",
        f"the passive tool moves {min(disp):.1f}-{max(disp):.1f} mm",
        f"names a preloaded spring stack (`{steps[0]['named']}`",
        f"the workflow's screening of {WORDS[len(screen)]} sets at paper scale: {s['screening']['wall_s']:.0f} s on "
        "one H100",
        f"held-out loss {steps[0]['heldout_loss_before']:.0f} -> {steps[0]['heldout_loss_after']:.1f} -> "
        f"{steps[1]['heldout_loss_after']:.1f}",
    ]


def _speed_sweep() -> list[str]:
    s = _json("speed_sweep_paper_h100/summary.json")
    return [f"The rigid draught grows by {s['line']['slope']:.0f} N per m/s at paper scale",
            f"one H100, {s['wall_s']:.0f} s; `docs/runs/speed_sweep_paper_h100/`"]


def _draught_calibration() -> list[str]:
    r = _json("draught_C_cpu_h100/result.json")
    b, sc = r["best"], r["screening"][0]
    return [f"({r['n_simulated']} individuals, {r['wall_s']:.0f} s; `docs/runs/draught_C_cpu_h100/`)",
            f"one set was accepted ({b['friction_angle']:.1f} deg, Cn = {b['normal_cohesion']:.0f} Pa, "
            f"{b['draught_mean_n']:.1f} N)",
            f"its shear box gave {sc['cohesion_kpa']:.2f} kPa and {sc['friction_angle_deg']:.1f} deg"]


def _reproduce_cpu() -> list[str]:
    import numpy as np

    from scenes import paper

    s = _json("reproduce_cpu/summary.json")
    rows = {(r["springs"], r["speed"]): r for r in s["soil_bin"]}
    r52, r68, p16, p32 = rows[(0, 0.52)], rows[(0, 0.68)], rows[(16, 0.68)], rows[(32, 0.52)]
    sem = [r["draught_sem"] for r in (r52, r68, p16, p32)]
    t3 = paper.table("soil_bin_measured")  # the report's rule: Table 3's rigid runs at the same speed
    ratios = [r["draught_mean"] / float(np.mean(t3["rigid_draught_mean_n"][np.abs(t3["speed_mean_m_s"] - r["speed"])
                                                                             < 5e-3])) for r in (r52, r68)]
    runs, ring = s["soil_bin_runs"], s["ringing_wall_s"]
    particles = f"{s['bed']['particles']:,}"
    return [f"`cpu` (default; {particles} particles)",
            f"a bed of {particles} particles",
            f"{s['wall_s']:.0f} s (ringing {ring['paper']:.1f} + {ring['linear']:.1f} + {ring['twin']:.1f} s",
            f"deposition of the assembly-C bed {s['bed']['deposition_wall_s']:.0f} s; the rigid runs at 0.52 and "
            f"0.68 m/s {runs['rigid']['wall_s']:.0f} s; the passive runs {runs['passive']['wall_s']:.0f} s)",
            f"Rigid {r52['draught_mean']:.1f} N at 0.52 m/s and {r68['draught_mean']:.1f} N at 0.68 m/s, 16 springs "
            f"{p16['draught_mean']:.1f} N, 32 springs {p32['draught_mean']:.1f} N, each with a standard error of "
            f"{min(sem):.0f}-{max(sem):.0f} N",
            f"it draws {100 * min(ratios):.0f}-{100 * max(ratios):.0f} % of the laboratory's rigid draught",
            f"| {s['wall_s']:.0f} s on 2 CPU cores shared with two other jobs, deposition included (`--scale cpu`)"]


def _soil_ga_5_20() -> list[str]:
    r = _json("soil_ga_loose_5_20_h200x2/result.json")
    b, held = r["best"], r["held_out_box"]["observables"]
    err = 100 * (b["draught_mean_n"] / r["problem"]["targets"]["draught_mean_n"] - 1)
    sim = sum(h["simulation_s"] for h in r["history"])  # over the GA's four calls (wall_s is the last call's)
    return [f"(`docs/runs/soil_ga_loose_5_20_h200x2/`, two H200s, {sim:,.0f} s of batched simulation for "
            f"{r['n_simulated']} individuals)",
            f"the best draws {b['draught_mean_n']:.1f} N ({err:+.1f} %) with box c = {b['cohesion_kpa']:.2f} kPa and "
            f"phi = {b['friction_angle_deg']:.1f} deg ({held['cohesion_kpa']:.2f} kPa and "
            f"{held['friction_angle_deg']:.1f} deg on three held-out samples)"]


CASES: dict[str, Callable[[], list[str]]] = {
    "soil_ga_loose_5_20_h200x2": _soil_ga_5_20,
    "reproduce_cpu": _reproduce_cpu,
    "soil_bin_paper_h100_s8": _soil_bin_s8,
    "table3-paper-h100": _table3_workflow,
    "speed_sweep_paper_h100": _speed_sweep,
    "draught_C_cpu_h100": _draught_calibration,
}


@pytest.mark.parametrize("run", sorted(CASES))
def test_the_readme_quotes_the_committed_run(run: str) -> None:
    """Every phrase the case builds from the run's files appears in the README as printed."""
    text = _readme()
    missing = [q for q in CASES[run]() if q not in text]
    assert not missing, f"README.md does not quote docs/runs/{run}/ as it is: {missing}"


def test_the_quickstart_ci_check_does_not_block_the_default_run() -> None:
    """`warpdem reproduce` refuses a folder holding a run of another scale (calibration/cli.py, `_claim`), so the
    README's quick `--scale ci` check must write elsewhere than the default run's `results/reproduce/`."""
    import re

    text = _readme()
    for m in re.finditer(r"`warpdem reproduce --scale ci[^`]*`", text):
        assert "--out " in m.group(0) and "--out results/reproduce`" not in m.group(0), m.group(0)
