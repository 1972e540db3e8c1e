"""Calibration outputs: a table like the paper's Tables 2 and 4-6, the convergence plot and ``result.json``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .archive import Record
from .ga import CalibrationResult


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
        row["shear_cohesion"] = 0.5 * r.genes["normal_cohesion"]
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
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


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
          f"{result.wall_s:.1f} s wall.\n", "## Best individual\n", markdown_table([best]),
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
    md += ["## Convergence\n", "![convergence](convergence.png)\n"]
    (out / "report.md").write_text("\n".join(md))
    summary = {"problem": problem.spec(), "settings": result.settings, "best": best, "history": result.history,
               "n_simulated": result.n_simulated, "n_batches": result.archive.n_batches, "wall_s": result.wall_s,
               "accepted": accepted, "screening": screening, **(extra or {})}
    (out / "result.json").write_text(json.dumps(summary, indent=1, default=float))
    return out / "report.md"
