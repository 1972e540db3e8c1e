"""Calibration outputs: a table like the paper's Tables 2 and 4-6, the convergence plot and ``result.json``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from scenes import figures

from .archive import Record
from .ga import CalibrationResult
from .genes import soil_fields


def _fmt(v: object) -> str:
    if isinstance(v, float):
        if not math.isfinite(v):
            return "-"
        return f"{v:.4g}" if abs(v) < 1e5 else f"{v:.3e}"
    return str(v)


def record_row(problem, r: Record) -> dict[str, object]:  # noqa: ANN001
    """One table row: genes, observables, targets, relative errors [%] and fitness."""
    row: dict[str, object] = {"index": r.index, "stage": r.stage, "generation": r.generation}
    row.update(r.genes)
    if problem.name in ("draught", "soil"):
        row["shear_cohesion"] = soil_fields(r.genes)["shear_cohesion"]
    row.update(r.observables)
    row.update({f"target_{k}": v for k, v in problem.targets.items()})
    # relative errors in %, differences (d_...) in their own unit
    row.update({k if k.startswith("d_") else f"{k}_pct": v if k.startswith("d_") else 100.0 * v
                for k, v in r.errors.items()})
    row["fitness"] = r.fitness
    return row


def markdown_table(rows: list[dict[str, object]], columns: list[str] | None = None) -> str:
    if not rows:
        return "(none)\n"
    columns = columns or list(rows[0])
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(_fmt(r.get(c, "")) for c in columns) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def convergence_plot(result: CalibrationResult, path: str | Path) -> None:
    """Fitness of every simulated individual against its generation (dots) and the best so far (line); the best
    individual's relative errors below."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    recs = [r for r in result.archive if r.stage != "archive"]
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(6.5, 6), sharex=True)
    gen = np.array([r.generation for r in recs], dtype=float)
    fit = np.array([max(r.fitness, 1e-3) for r in recs])
    ax.scatter(gen, fit, s=10, alpha=0.5, label="individuals")
    hg = np.array([h["generation"] for h in result.history], dtype=float)
    ax.plot(hg, [h["best_fitness"] for h in result.history], "k-o", ms=3, label="best so far")
    ax.set_yscale("log")
    ax.set_ylabel("fitness")
    ax.legend()
    keys = list(result.history[-1]["best_errors"]) if result.history else []
    for k in keys:
        ax2.plot(hg, [100 * abs(h["best_errors"][k]) for h in result.history], "-o", ms=3, label=k)
    ax2.set_yscale("log")
    ax2.set_ylabel("|relative error| of the best [%]")
    ax2.set_xlabel("generation (after the GA: refinement iterations)")
    ax2.axhline(1.0, color="grey", lw=0.8, ls="--")
    if keys:
        ax2.legend()
    ax.set_title("Calibration: fitness of every simulated individual and the best so far", fontsize=10)
    figures.save(fig, path, 120)


def _wall_text(history: list[dict[str, object]]) -> str:
    """The report's phrase for the time over all generations."""
    wall = history_wall_s(history)
    if wall is not None:
        return f"{wall:.1f} s wall over all generations"
    sim = sum(float(h.get("simulation_s", 0.0)) for h in history)
    return f"{sim:.1f} s of batched simulation over all generations (this history has no wall per generation)"


def history_wall_s(history: list[dict[str, object]]) -> float | None:
    """A calibration's wall time over all its generations and calls [s]: the sum of the generations' own walls
    (``generation_wall_s``); None for a history written before that field, whose ``wall_s`` counts from the start
    of each call (and which says nowhere where a call began)."""
    if not history or not all("generation_wall_s" in h for h in history):
        return None
    return float(sum(float(h["generation_wall_s"]) for h in history))


def pareto_front(costs: np.ndarray) -> np.ndarray:
    """Indices of the non-dominated rows of ``costs`` (n, m), every column a cost to minimise: a row is dominated
    when another is no worse in every column and better in one. Rows with a NaN are left out; equal rows all stay."""
    costs = np.asarray(costs, dtype=np.float64)
    ok = np.flatnonzero(np.all(np.isfinite(costs), axis=1))
    keep = [i for i in ok if not np.any(np.all(costs[ok] <= costs[i], axis=1) & np.any(costs[ok] < costs[i], axis=1))]
    return np.array(keep, dtype=int)


SOIL_TRADE = ("re_draught", "re_cohesion", "d_friction_deg")
"""the soil calibration's three errors, in the order of the trade-off table's columns."""


def soil_tradeoff(problem, recs: list[Record]) -> tuple[list[dict[str, object]], list[str]]:  # noqa: ANN001
    """The soil calibration's trade-off: the individuals no other beats on all three of |draught error|,
    |shear-box cohesion error| and |friction angle difference| (table rows, by draught error), and what the closest
    reach of each target is with the other two within tolerance (lines for the report)."""
    tol = problem.spec()["tolerances"]
    recs = [r for r in recs if all(k in r.errors for k in SOIL_TRADE)]
    costs = np.array([[abs(r.errors[k]) for k in SOIL_TRADE] for r in recs]).reshape(-1, 3)
    front = sorted((recs[i] for i in pareto_front(costs)), key=lambda r: abs(r.errors["re_draught"]))
    rows = [{"index": r.index, **r.genes, "draught_mean_n": r.observables.get("draught_mean_n", math.nan),
             "cohesion_kpa": r.observables.get("cohesion_kpa", math.nan),
             "friction_angle_deg": r.observables.get("friction_angle_deg", math.nan),
             "re_draught_pct": 100 * r.errors["re_draught"], "re_cohesion_pct": 100 * r.errors["re_cohesion"],
             "d_friction_deg": r.errors["d_friction_deg"]} for r in front]
    lines = []
    names = dict(zip(SOIL_TRADE, ("draught", "shear-box cohesion", "shear-box friction angle"), strict=True))
    for k, name in names.items():
        others = [j for j in SOIL_TRADE if j != k]
        within = [r for r in recs if all(abs(r.errors[j]) <= tol[j] for j in others)]
        if not within:
            lines.append(f"- The {name}: no individual has the {' and the '.join(names[o] for o in others)} both "
                         "within tolerance.")
            continue
        best = min(within, key=lambda r: abs(r.errors[k]))
        unit = "deg" if k.startswith("d_") else "%"
        size = best.errors[k] if k.startswith("d_") else 100 * best.errors[k]
        lines.append(f"- The {name}, with the other two within tolerance ({len(within)} individuals): at best "
                     f"{size:+.1f} {unit} (individual {best.index}).")
    return rows, lines


def tradeoff_plot(problem, recs: list[Record], path: str | Path) -> None:  # noqa: ANN001
    """Every individual's shear-box cohesion [kPa] against its rigid draught [N], coloured by its shear-box
    friction angle [deg]; the laboratory's targets and tolerances as a box, the trade-off's individuals ringed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    recs = [r for r in recs if all(k in r.observables for k in ("draught_mean_n", "cohesion_kpa",
                                                                "friction_angle_deg"))]
    if not recs:
        return
    t, tol = problem.targets, problem.spec()["tolerances"]
    d = np.array([r.observables["draught_mean_n"] for r in recs])
    c = np.array([r.observables["cohesion_kpa"] for r in recs])
    phi = np.array([r.observables["friction_angle_deg"] for r in recs])
    front = pareto_front(np.array([[abs(r.errors[k]) for k in SOIL_TRADE] for r in recs]))
    fig, ax = plt.subplots(figsize=(6.5, 4.6))
    sc = ax.scatter(d, c, c=phi, cmap="viridis", s=18, vmin=t["friction_angle_deg"] - 15,
                    vmax=t["friction_angle_deg"] + 15)
    ax.scatter(d[front], c[front], s=70, facecolors="none", edgecolors="k", lw=0.8,
               label="not beaten on all three errors")
    dt, ct = t["draught_mean_n"], t["cohesion_kpa"]
    ax.add_patch(plt.Rectangle((dt * (1 - tol["re_draught"]), ct * (1 - tol["re_cohesion"])),
                               2 * dt * tol["re_draught"], 2 * ct * tol["re_cohesion"], fill=False, color="r",
                               lw=1.2, label=f"laboratory: {dt:.0f} N, {ct:g} kPa, with tolerances"))
    ax.set_xscale("log")
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.xaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
    ax.set_xticks([x for x in (100, 200, 300, 500, 1000, 2000, 5000, 10000, 20000) if d.min() <= x <= d.max()])
    ax.set_xlabel("rigid draught, steady mean [N]")
    ax.set_ylabel("shear-box cohesion [kPa]")
    fig.colorbar(sc, ax=ax, label="shear-box friction angle [deg]")
    ax.set_title("Soil calibration: draught against shear-box cohesion, every individual", fontsize=10)
    ax.legend(fontsize=8, loc="upper left")
    figures.save(fig, path, 120)


def held_out_lines(held: dict[str, object], problem) -> list[str]:  # noqa: ANN001
    """The report's section on the best set's shear box on samples the calibration never saw
    (:meth:`calibration.problems.SoilProblem.held_out_box`)."""
    obs, err, tol = held["observables"], held["errors"], problem.spec()["tolerances"]
    seeds = ", ".join(map(str, held["seeds"]))

    def value(key: str, unit: str) -> str:
        se = obs.get(f"{key}_se")
        return f"{obs[key]:.2f}" + (f" +- {se:.2f}" if se is not None else "") + f" {unit}"

    verdict = ("holds there: both within their tolerances" if held["box_accepted"] else
               "does not hold there: the calibration's box result does not carry over to other samples of the same "
               "soil, so the set does not reach the laboratory's box")
    return ["## The best set's shear box on samples the calibration never saw\n",
            f"Samples of seeds {seeds} (the calibration's own: {problem.box.seed} to "
            f"{problem.box.seed + problem.box_samples - 1}): c = {value('cohesion_kpa', 'kPa')} "
            f"({100 * err['re_cohesion']:+.1f} %, tolerance {100 * tol['re_cohesion']:.0f} %), phi = "
            f"{value('friction_angle_deg', 'deg')} ({err['d_friction_deg']:+.2f} deg, tolerance "
            f"{tol['d_friction_deg']:g} deg). The box result {verdict}.\n"]


def write_report(result: CalibrationResult, problem, out: str | Path, *,  # noqa: ANN001
                 screening: list[dict[str, object]] | None = None, extra: dict[str, object] | None = None,
                 top: int = 10) -> Path:
    """Write ``report.md``, ``table.csv`` (every simulated individual), ``convergence.png`` and ``result.json``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    recs = sorted((r for r in result.archive if r.stage != "archive"), key=lambda r: -r.fitness)
    rows = [record_row(problem, r) for r in recs]
    if rows:
        cols = list(rows[0])
        lines = [",".join(cols)] + [",".join(repr(r.get(c, "")) if isinstance(r.get(c), float) else str(r.get(c, ""))
                                             for c in cols) for r in rows]
        (out / "table.csv").write_text("\n".join(lines) + "\n")
    convergence_plot(result, out / "convergence.png")
    best = record_row(problem, result.best)
    title = {"ringing": "Ringing calibration (like Table 2)", "draught": "Draught calibration (like Tables 4-6)",
             "soil": "Soil calibration: the rigid draught and the shear box together"}
    md = [f"# {title.get(problem.name, 'Calibration')}\n", f"Problem: `{json.dumps(problem.spec())}`\n",
          f"GA settings: `{json.dumps(result.settings)}`\n",
          f"{result.n_simulated} individuals simulated in {result.archive.n_batches} batched simulations, "
          f"{_wall_text(result.history)} ({result.wall_s:.1f} s in the last call).\n", "## Best individual\n",
          markdown_table([best]),
          f"## The {min(top, len(rows))} fittest individuals\n", markdown_table(rows[:top])]
    accepted = []
    if problem.name == "draught":
        accepted = [record_row(problem, r) for r in recs if problem.accepted(r.errors)]
        md += [f"## Accepted sets (|RE| < {100 * 0.1:.0f} %): {len(accepted)}\n"]
        if screening is not None:
            md += ["## Shear-box screening (rank 1 = closest to the laboratory's 6.4 kPa and 32.3 deg)\n",
                   markdown_table(screening)]
    if problem.name == "soil":
        accepted = [record_row(problem, r) for r in recs if problem.accepted(r.errors)]
        tol = problem.spec()["tolerances"]
        md += [f"## Accepted sets (draught within {100 * tol['re_draught']:.0f} %, shear-box cohesion within "
               f"{100 * tol['re_cohesion']:.0f} %, friction angle within {tol['d_friction_deg']:g} deg): "
               f"{len(accepted)}\n"]
        top_cn = 5e4  # the paper's normal-cohesion range ends here (section 2.2.2)
        if result.best.genes["normal_cohesion"] > top_cn:
            md += [f"The best set's normal cohesion, {result.best.genes['normal_cohesion'] / 1e3:.1f} kPa, is "
                   f"{result.best.genes['normal_cohesion'] / top_cn:.1f}x the top of the paper's range (50 kPa): a "
                   "fitted number outside the paper's range, which may stand for a mechanism the model lacks.\n"]
        if (held := (extra or {}).get("held_out_box")) is not None:
            md += held_out_lines(held, problem)
        front, reach = soil_tradeoff(problem, recs)
        tradeoff_plot(problem, recs, out / "tradeoff.png")
        md += ["## The trade-off\n",
               "The individuals that no other beats on all three errors (|draught error|, |cohesion error|, "
               "|friction angle difference|), by draught error:\n", markdown_table(front), *reach, "",
               "![trade-off](tradeoff.png)\n"]
    md += ["## Convergence\n", "![convergence](convergence.png)\n"]
    (out / "report.md").write_text("\n".join(md))
    summary = {"problem": problem.spec(), "settings": result.settings, "best": best, "history": result.history,
               "n_simulated": result.n_simulated, "n_batches": result.archive.n_batches, "wall_s": result.wall_s,
               "accepted": accepted, "screening": screening, **(extra or {})}
    (out / "result.json").write_text(json.dumps(summary, indent=1, default=float))
    return out / "report.md"
