"""Diagnosis outputs: ``report.md``, plots and a machine-readable ``diagnosis.json``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from scenes import figures, rigs

from .diagnosis import Diagnosis
from .report import markdown_table


def _f(v: float) -> float | None:
    """A JSON number rounded to 6 decimals, None for missing or non-finite."""
    return None if v is None or not math.isfinite(float(v)) else round(float(v), 6)


def to_json(d: Diagnosis) -> dict[str, object]:
    """The cause, its parameters, held-out errors before and after, and the ranking of all candidates."""
    v = d.verification
    named = d.named

    def errors(name: str) -> dict[str, object]:
        e = v.get(name, {})
        return {"heldout_loss": float(np.sum(e["heldout_loss"])),
                "heldout_rms_relative": dict(zip(d.observables, map(_f, e["heldout_rms_rel"]), strict=True)),
                "heldout_rms": dict(zip(d.observables, map(_f, e["heldout_rms"]), strict=True)),
                "heldout_mae": dict(zip(d.observables, map(_f, e["heldout_mae"]), strict=True))} if e else {}

    return {
        "rig": d.rig,
        "verdict": d.verdict,
        "cause": list(d.cause),
        "indistinguishable_from": d.indistinguishable,
        "parameters": named.params_all() if named else {},
        "parameters_at_bound": named.at_bound() if named else [],
        "baseline_parameters": d.baseline.params_all(),
        "errors_before": errors("baseline"),
        "errors_after": errors("+".join(d.cause)) if d.cause else {},
        "gain_abs": v.get("gain_abs"),
        "gain_rel": v.get("gain_rel"),
        "residual_pattern": d.pattern,
        "residual_left": d.residual_left,
        "steps": d.steps,
        "baseline_adjustments": d.adjustments,
        "absorbed": d.absorbed,
        "tried_first": d.priority,
        "at_bound": d.at_bound,
        "cause_sizes": d.sizes,
        "convergence": d.convergence,
        "physical_bounds": d.bounds,
        "failed_extractions": {"simulated": d.failures, "measured": d.measured_failures},
        "noise_p_baseline": _f(d.noise_p_baseline),
        "noise_p_best": _f(d.noise_p_best),
        "observables": list(d.observables),
        "units": d.units,
        "uncertainty": d.uncertainty,
        "sigma": {k: d.sigma[:, i].tolist() for i, k in enumerate(d.observables)},
        "configs": d.configs,
        "ranking": [
            {"candidate": n, "heldout_loss": float(d.fits[n].heldout_loss.sum()), "gain": _f(d.fits[n].gain),
             "gain_se": _f(d.fits[n].gain_se), "p_lr_holm": _f(d.fits[n].p_holm),
             "p_heldout_t": _f(d.fits[n].p_heldout), "aicc": _f(d.fits[n].aicc),
             "significant": d.fits[n].significant, "parameters": d.fits[n].params_all()}
            for n in ["baseline"] + d.ranking
        ],
        "n_simulations": d.n_simulations,
        "wall_s": round(d.wall_s, 1),
        "wall_untimed": d.wall_untimed,
    }


def decay_curve(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Damping ratio of each cycle of a decay against its amplitude: from consecutive peaks A_i, A_i+1 (above the
    fitted offset), zeta_i = d / sqrt(4 pi^2 + d^2) with d = ln(A_i / A_i+1); (amplitudes A_i, zeta_i), each (k,).
    Viscous damping gives a flat curve, dry friction one that rises as the amplitude falls. Empty without a decay."""
    from scenes import analysis

    try:
        fit = analysis.ringdown(t, x)
    except ValueError:
        return np.array([]), np.array([])
    a = np.asarray(fit.peak_amplitudes, dtype=np.float64)
    ok = (a[:-1] > 0) & (a[1:] > 0)
    dec = np.log(a[:-1][ok] / a[1:][ok])
    return a[:-1][ok], dec / np.sqrt(4 * np.pi**2 + dec**2)


COVARIATE_UNITS = {"springs": "-", "stiffness": "N/m", "static_deflection": "m", "speed": "m/s",
                   "displacement": "m"}
"""units of the rigs' covariates (``RingingRigModel.covariates``, ``SoilBinRigModel.covariates``)."""


def _axis_label(name: str) -> str:
    """A covariate's axis label with its unit."""
    return f"{name.replace('_', ' ')} [{COVARIATE_UNITS.get(name, '-')}]"


def _save(fig: object, path: Path, title: str) -> str:
    """Title, lay out, write (120 dpi) and close a figure; its file name."""

    fig.suptitle(title, fontsize=10)
    figures.save(fig, path, 120)
    return path.name


def plots(d: Diagnosis, out: Path) -> list[str]:
    """observables.png (measured vs baseline vs extended, against stiffness), residuals.png (held-out residuals of
    the baseline against each covariate) and, with series, series.png (measured records and re-simulations against
    time: the covariate along a run) and, with the ringing rig's measured records, decay.png (each cycle's damping
    ratio against its amplitude: the covariate within a decay)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    files = []
    v = d.verification
    cov = d.covariates
    x_name = "stiffness" if "stiffness" in cov else next(iter(cov))
    x = cov[x_name]
    order = np.argsort(x)
    n_obs = len(d.observables)
    fig, axes = plt.subplots(1, n_obs, figsize=(3.6 * n_obs, 3.4), squeeze=False)
    for k, name in enumerate(d.observables):
        ax = axes[0, k]
        ax.errorbar(x[order], d.measured[order, k], yerr=d.sigma[order, k], fmt="ko",
                    ms=4, label="measured")
        for key, style in (("baseline", "C0s--"), ("+".join(d.cause), "C3^-")):
            if key in v and isinstance(v[key], dict):
                ax.plot(x[order], v[key]["heldout_pred"][order, k], style, ms=4, label=f"{key} (held out)")
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())  # minor labels of a short log axis overlap
        ax.set_xlabel(_axis_label(x_name))
        ax.set_title(f"{name} [{d.units.get(name, '-')}]")
    axes[0, 0].legend(fontsize=7)
    files.append(_save(fig, out / "observables.png", "Measured (± stated uncertainty) against the held-out "
                       "predictions of the baseline and of the named extension"))

    res = (d.baseline.pred_heldout - d.measured) / d.sigma
    fig, axes = plt.subplots(1, len(cov), figsize=(3.6 * len(cov), 3.2), squeeze=False)
    for c, (cname, cval) in enumerate(cov.items()):
        ax = axes[0, c]
        for k, name in enumerate(d.observables):
            ax.plot(cval, res[:, k], "o", ms=4, label=name)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_xlabel(_axis_label(cname))
        ax.set_ylabel("baseline held-out residual [sigma]")
    axes[0, 0].legend(fontsize=7)
    files.append(_save(fig, out / "residuals.png",
                       "The baseline's held-out residuals (in stated uncertainties) against each covariate"))

    base = v.get("baseline")
    if isinstance(base, dict) and base.get("series"):
        n = len(d.configs)
        fig, axes = plt.subplots(n, 1, figsize=(7, 1.8 * n), squeeze=False, sharex=True)
        for j in range(n):
            ax = axes[j, 0]
            if d.measured_series is not None:
                t, s = d.measured_series[j]
                ax.plot(t, 1e3 * s, color="k", lw=0.6, alpha=0.6, label="measured")
            for key, color in (("baseline", "C0"), ("+".join(d.cause), "C3")):
                if key in v and isinstance(v[key], dict) and v[key].get("series"):
                    t, s = v[key]["series"][j]
                    ax.plot(t, 1e3 * s, color=color, lw=0.8, label=key)
            ax.set_ylabel(f"{d.configs[j].get('springs', j)} springs:\ndisp. [mm]", fontsize=8)
        axes[0, 0].legend(fontsize=7)
        axes[-1, 0].set_xlabel("time [s]")
        files.append(_save(fig, out / "series.png",
                           "Measured records and their re-simulations (baseline, named extension)"))
        if d.measured_series is not None and d.rig == rigs.RINGING.name:
            # the covariate within a decay: each cycle's damping ratio against its amplitude
            cols = min(n, 4)
            rows = -(-n // cols)
            fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.6 * rows), squeeze=False)
            for j in range(n):
                ax = axes[j // cols, j % cols]
                a, z = decay_curve(*d.measured_series[j])
                ax.plot(1e3 * a, z, "ko", ms=3, label="measured")
                for key, style in (("baseline", "C0s--"), ("+".join(d.cause), "C3^-")):
                    if key in v and isinstance(v[key], dict) and v[key].get("series"):
                        a, z = decay_curve(*v[key]["series"][j])
                        ax.plot(1e3 * a, z, style, ms=3, label=key)
                ax.set_title(f"{d.configs[j].get('springs', j)} springs", fontsize=9)
                ax.set_xlabel("amplitude [mm]")
                ax.set_ylabel("damping ratio per cycle [-]")
            for j in range(n, rows * cols):
                axes[j // cols, j % cols].axis("off")
            axes[0, 0].legend(fontsize=7)
            files.append(_save(fig, out / "decay.png",
                               "Damping ratio of each cycle against its amplitude: measured and re-simulated"))
    return files


UNTIMED = " in the calls that timed it (earlier calls of this resumed diagnosis did not)"


def write(d: Diagnosis, out: str | Path, command: str = "") -> Path:
    """Write report.md, diagnosis.json and the plots into ``out``; return the report's path."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    js = to_json(d)
    (out / "diagnosis.json").write_text(json.dumps(js, indent=2, default=float) + "\n")
    files = plots(d, out)
    lines = [f"# Diagnosis of the {d.rig} rig", ""]
    if command:
        lines += [f"Command: `{command}`", ""]
    if d.absorbed:
        lines += ["**The baseline absorbed what it lacks:** " + "; ".join(d.absorbed) + "."
                  + (f" Tried first (named when the data cannot tell them from the best): {', '.join(d.priority)}."
                     if d.priority else " No registered mechanism that would produce it applies to this rig."), ""]
    verdict = d.verdict + (f": **{' + '.join(d.cause)}**" if d.cause else "")
    lines += [f"**Verdict: {verdict}.**", ""]
    for b in d.at_bound:
        lines += [f"**At its bound: the cause is likely outside this mechanism:** {b['mechanism']} (step {b['step']}, "
                  f"significant, held-out loss {b['heldout_loss']:.3g}) fits {b['gene']} = {b['value']:.4g} "
                  f"{b['unit']}, the {'upper' if b['side'] == 'high' else 'lower'} end of its physical range "
                  f"{b['low']:.4g} to {b['high']:.4g} {b['unit']} ({b['source']}); not named, the search went on.",
                  ""]
    for st in d.steps:
        if not st.get("converged", True):
            lines += [f"Step {st['step']} ({st['named']}) did not converge: its loss still fell by "
                      f"{st['last_fall']:.3g} in the last of {st['convergence_rounds']} extra rounds.", ""]
    if d.sizes:
        lines += ["Size of the named cause: " + "; ".join(
            f"{e['gene']} = {e['value']:.4g} {e['unit']}" + (
                f" (from {e['low']:.4g} to {e['high']:.4g} {e['unit']} {e['why']})" if e["high"] > e["low"]
                else f" ({e['why']})") for e in d.sizes) + ".", ""]
    if d.cause and d.residual_left:
        lines += ["What the named model leaves is still larger than the stated noise (an unexplained residual "
                  "remains; its pattern is below).", ""]
    if d.adjustments:
        lines += ["The baseline had to adjust the rig as described: " + "; ".join(d.adjustments) + ".", ""]
    if len(d.steps) > 1 or (d.steps and d.residual_left):
        lines += ["Stepwise search (each step: the remaining mechanisms on top of the model named so far):", ""]
        lines += [f"{st['step']}. {st['named']}: held-out loss {st['heldout_loss_before']:.3g} -> "
                  f"{st['heldout_loss_after']:.3g} (p, likelihood ratio, Holm {st['p_lr_holm']:.2g}; residual vs "
                  f"noise p {st['noise_p_after']:.2g})" for st in d.steps] + [""]
    for what, items in (("Measured records whose extraction failed (left out)", d.measured_failures),
                        ("Simulated records whose extraction failed (scored by what the failure says)", d.failures)):
        if items:
            lines += [f"{what}:", ""] + [f"- {x}" for x in items] + [""]
    if d.indistinguishable:
        lines += [f"Indistinguishable on these data: {', '.join(d.indistinguishable)}.", ""]
    if d.cause:
        from . import mechanisms as mech

        for name in d.cause:
            m = mech.get(name)
            lines += [f"- *{m.title}*: {m.rationale}"]
        lines += ["", "Fitted parameters (all data): " + ", ".join(f"{k} = {v:.4g}" for k, v in
                                                                  d.named.params_all().items()), ""]
        for b in js["parameters_at_bound"]:
            lines += [f"**At the {'upper' if b['side'] == 'high' else 'lower'} end of its range:** {b['gene']} = "
                      f"{b['value']:.4g} {b['unit']} (searched {b['low']:.4g} to {b['high']:.4g} {b['unit']}; "
                      f"{b['folds']} of {b['n_folds']} leave-one-out fits there too). The data ask for a value the "
                      f"search did not allow: read the mechanism as standing in for one that acts the same way, "
                      f"or widen its range if such a value is physical.", ""]
        lines += [f"Held-out loss (sum over configurations of squared residuals in units of the uncertainty, "
                  f"re-simulated): before {js['errors_before']['heldout_loss']:.3g}, after "
                  f"{js['errors_after']['heldout_loss']:.3g}: gain {js['gain_abs']:.3g} "
                  f"({100 * js['gain_rel']:.1f} %).", ""]
    if d.pattern:
        which = "named model" if d.cause else "baseline"
        shared = (" The residuals are shown as they are, not whitened: where they share an error (reductions against "
                  "one rigid run), part of a common offset is that one error, which the losses count once."
                  if d.correlation is not None else "")
        lines += [f"Residual pattern of the {which} (held out).{shared}", ""] + [f"- {p}" for p in d.pattern] + [""]
    lines += [f"Baseline held-out residuals vs the stated uncertainties: chi^2 p = {d.noise_p_baseline:.3g}; best "
              f"candidate: p = {d.noise_p_best:.3g}.", ""]
    lines += ["## Held-out errors (over configurations, re-simulated)", ""]
    rows = []
    for key in ["baseline"] + (["+".join(d.cause)] if d.cause else []):
        e = js["errors_after" if key != "baseline" else "errors_before"]
        row: dict[str, object] = {"model": key}
        for k in d.observables:
            unit = d.units.get(k, "-")
            row[f"{k} MAE [{unit}]"] = e["heldout_mae"][k]
            row[f"{k} RMS [{unit}]"] = e["heldout_rms"][k]
            if unit != "%":
                rel = e["heldout_rms_relative"][k]
                row[f"{k} RMS [% of measured]"] = 100 * rel if rel is not None else math.nan
        rows.append(row)
    lines += [markdown_table(rows), ""]
    lines += ["## Candidates (leave-one-configuration-out)", ""]
    lines += [markdown_table([{"candidate": r["candidate"], "held-out loss": r["heldout_loss"],
                               "gain": r["gain"], "gain SE": r["gain_se"], "p (LR, Holm)": r["p_lr_holm"],
                               "p (held-out t)": r["p_heldout_t"], "AICc": r["aicc"],
                               "significant": r["significant"],
                               "parameters": ", ".join(f"{k}={v:.3g}" for k, v in r["parameters"].items())}
                              for r in js["ranking"]]), ""]
    lines += ["## Measured and simulated per configuration", ""]
    rows = []
    for j, c in enumerate(d.configs):
        row = dict(c)
        for k, name in enumerate(d.observables):
            row[f"{name} measured"] = float(d.measured[j, k])
            row[f"{name} baseline"] = float(d.verification["baseline"]["heldout_pred"][j, k])
            if d.cause:
                row[f"{name} extended"] = float(d.verification["+".join(d.cause)]["heldout_pred"][j, k])
        rows.append(row)
    lines += [markdown_table(rows), ""]
    lines += ["Stated 1-sigma uncertainties: " + ", ".join(f"{k} {u}" for k, u in d.uncertainty.items())
              + ("; the residuals correlate (e.g. reductions sharing a rigid reference run): every loss is the "
                 "generalized least-squares r^T C^-1 r (calibration.diagnosis.Whitening)"
                 if d.correlation is not None else ""),
              "", f"{d.n_simulations} simulated worlds (a point simulated before is reused, not run again), "
              f"{d.wall_s:.0f} s of wall time{UNTIMED if d.wall_untimed else ''}.", ""]
    lines += [f"![{f}]({f})" for f in files]
    path = out / "report.md"
    path.write_text("\n".join(lines) + "\n")
    return path
