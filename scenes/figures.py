"""Shared pieces of the figures like the paper's (Figs. 6, 16-19 and the reductions): the end of each carriage's
travel, a simulated steady mean drawn with its band, the laboratory's and the paper's values drawn in as references.

Used by ``scenes.reproduce`` (``warpdem reproduce``, ``warpdem soil-bin``) and ``calibration.workflow_report``
(``warpdem reproduce --workflow full``). Every reference value comes from ``scenes.paper`` (its tables and the values
its text gives for its figures).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from . import paper


def plt():
    """matplotlib.pyplot on the Agg back end (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as pyplot

    return pyplot


def save(fig: object, path: str | Path, dpi: int = 110, *, tight_box: bool = False) -> None:
    """Lay out a matplotlib figure, write it to ``path`` (PNG at ``dpi``; ``tight_box``: cropped to what is drawn,
    e.g. a legend outside the axes) and close it."""
    fig.tight_layout()
    fig.savefig(path, dpi=dpi, **({"bbox_inches": "tight"} if tight_box else {}))
    plt().close(fig)


def moving_records(travel: np.ndarray) -> int:
    """How many records of one world were taken while its carriage moved: those up to and including the first
    record at the full travel. ``travel``: carriage travel [m] (k,), clamped at its end (``SoilBinRun.travel``);
    the later records are the tool standing still at the end of the bin while a slower world finishes, which the
    steady statistics leave out too."""
    travel = np.asarray(travel, dtype=float)
    at_end = np.nonzero(travel >= travel.max())[0]
    return int(at_end[0]) + 1 if len(at_end) else len(travel)


def displacement_records(travel: np.ndarray) -> int:
    """How many records of one world's displacement to draw: the moving ones (:func:`moving_records`) less the
    record at the carriage's stop. That record is taken at the first whole record past the full travel; records
    written before ``scenes.soil_bin`` read the displacement against the carriage's own position (2026-11-26;
    docs/figures-review.md) read it against the travel clamped at its end, off by the carriage's overshoot there
    (up to speed x the record interval, about -1 mm at 500 records/s and 0.7 m/s)."""
    return max(1, moving_records(travel) - 1)


def steady_band(ax: object, x0: float, x1: float, mean: float | None, half: float | None, color: str,
                label: str) -> None:
    """The simulated steady mean as a line over the steady window [x0, x1] (travel [m]) with a band of +-``half``
    (its standard error or standard deviation, in the mean's unit); nothing when the mean is not finite."""
    if mean is None or not np.isfinite(mean):
        return
    ax.hlines(mean, x0, x1, color=color, lw=1.6, label=label, zorder=4)
    if half is not None and np.isfinite(half):
        ax.fill_between([x0, x1], mean - half, mean + half, color=color, alpha=0.25, lw=0, zorder=3)


def fft_references(ax: object, key: str, springs: Sequence[int], colors: dict[int, str] | None = None) -> None:
    """Draw the paper's frequencies into an FFT axis (x: frequency [Hz]; :func:`fft_caption` says what they
    are). ``key``: "draught" (Figs. 8 and 17: the text gives bounds, no peak) or "displacement" (Fig. 18d's 8.34 Hz
    for 16 springs, and the laboratory's ringing frequency, Table 2, of every passive configuration shown)."""
    colors = colors or {}
    if key == "draught":
        ax.axvline(paper.FFT_DRAUGHT_SPLIT_HZ, color="k", ls="--", lw=0.9,
                   label=f"{paper.FFT_DRAUGHT_SPLIT_HZ:g} Hz: paper's DEM, the passive tool loses amplitude "
                         "above (Fig. 17)")
        ax.axvline(paper.FFT_LAB_TOOL_MAX_HZ, color="0.4", ls=":", lw=0.9,
                   label=f"{paper.FFT_LAB_TOOL_MAX_HZ:g} Hz: laboratory's tool frequencies below (Fig. 8)")
        return
    for n in springs:
        if n == 0:
            continue
        f_ring = paper.ringing_row(n)["measured_freq_hz"]
        ax.axvline(f_ring, color=colors.get(n, "0.3"), ls=":", lw=1.0,
                   label=f"{n} springs: laboratory ringing {f_ring:.2f} Hz (Table 2)")
        if n in paper.FFT_DEM_DISPLACEMENT_PEAK_HZ:
            f_peak = paper.FFT_DEM_DISPLACEMENT_PEAK_HZ[n]
            ax.axvline(f_peak, color=colors.get(n, "0.3"), ls="--", lw=1.2,
                       label=f"{n} springs: paper's DEM peak {f_peak:.2f} Hz (Fig. 18d)")


def fft_caption(key: str) -> str:
    """What :func:`fft_references` draws for ``key`` ("draught" or "displacement"), as a caption sentence."""
    if key == "draught":
        return ("References: the paper's text gives no peak frequency of the draught; it says that its DEM's passive "
                f"tool loses draught amplitude above {paper.FFT_DRAUGHT_SPLIT_HZ:g} Hz (Fig. 17, dashed), as the "
                "laboratory's passive runs show lower frequencies than its rigid ones (Fig. 8), and that the "
                f"laboratory's tool frequencies were below {paper.FFT_LAB_TOOL_MAX_HZ:g} Hz (dotted).")
    return ("References: each passive configuration's laboratory ringing frequency (Table 2, dotted) and the one "
            "peak the paper's text quotes, its DEM's 8.34 Hz for 16 springs (Fig. 18d, dashed); the text gives no "
            "peak of the laboratory's displacement spectrum (Fig. 9).")


def fig19_reference(ax: object, n: int, x_max: float, color: str) -> bool:
    """The paper's Fig. 19 trend line of the tool's kinetic energy [J] for ``n`` springs over travel [0, x_max]
    [m] (x read as the travel: see ``paper.FIG19_TOOL_KE_TREND``); False when the paper gives none for ``n``."""
    if n not in paper.FIG19_TOOL_KE_TREND:
        return False
    slope, icpt = paper.FIG19_TOOL_KE_TREND[n]
    x = np.array([0.0, x_max])
    ax.plot(x, icpt + slope * x, color=color, ls="--", lw=1.2,
            label=f"{n} springs: paper's DEM trend (Fig. 19), {slope:g} x + {icpt:g}")
    return True


FIG19_CAPTION = ("Reference: the trend lines of the paper's Fig. 19 (its caption gives y = a x + b per "
                 "configuration, y the tool's kinetic energy [J]); its text does not state the unit of x, drawn here "
                 "as the travel [m]. Most of the tool's kinetic energy is its translation with the carriage, "
                 "m v^2 / 2 (1.9 J for the paper's 7.69 kg sweep at 0.70 m/s), so matching levels say that the "
                 "tool's mass and the speeds are the paper's; the vibration is the fluctuation about that level.")


def plot_reductions(rows: Sequence[dict], path: Path, *, assembly: str = "C", title: str) -> None:
    """Draught reduction [%] per spring configuration: warpdem's (``rows``: dicts of ``springs``, ``mean``, ``sem``
    [%] and ``label``; a series per label, each point with +-SE bars), the laboratory's (Table 3) and the paper's
    DEM (Table 7: the final model in the 2 m bin, and ``assembly`` in the 1 m bin)."""
    pyplot = plt()
    t3, t7 = paper.table("soil_bin_measured"), paper.table("soil_bin_dem")
    col = {"A": "a", "B": "b", "C": "c"}[assembly]
    fig, ax = pyplot.subplots(figsize=(9, 4.8))
    labels = list(dict.fromkeys(r["label"] for r in rows))
    for k, label in enumerate(labels):
        mine = [r for r in rows if r["label"] == label]
        shift = (k - 0.5 * (len(labels) - 1)) * 0.7
        ax.errorbar(np.array([r["springs"] for r in mine], dtype=float) + shift, [r["mean"] for r in mine],
                    yerr=[r["sem"] if r["sem"] is not None and np.isfinite(r["sem"]) else 0.0 for r in mine],
                    fmt="o", capsize=3, label=f"{label} (± SE)")
    ax.plot(t3["springs"], t3["reduction_pct"], "k*", ms=11, label="laboratory (Table 3)")
    passive = t7["springs"] > 0
    ax.plot(t7["springs"][passive], t7["c_final_red_pct"][passive], "rx", ms=9,
            label="paper's final DEM (Table 7, C, 2 m bin)")
    ax.plot(t7["springs"][passive], t7[f"{col}_red_pct"][passive], "+", color="C4", ms=9,
            label=f"paper's DEM (Table 7, {assembly}, 1 m bin)")
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("springs [-]")
    ax.set_ylabel("draught reduction against the rigid tool [%]")
    ax.set_xticks(paper.SPRING_COUNTS)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.savefig(path, dpi=110, bbox_inches="tight")
    pyplot.close(fig)


def figure_captions(names: Sequence[str], captions: dict[str, str]) -> list[str]:
    """A report's lines for the figures ``names`` (file names): each image with its caption from ``captions``
    (what it shows, what it is compared with), the FFT figures (``fig17_*``, ``fig18_*``) followed by the paper's
    references (:func:`fft_caption`) and Fig. 19's (``fig19_*``) by :data:`FIG19_CAPTION`."""
    extra = {"fig17_": fft_caption("draught"), "fig18_": fft_caption("displacement"), "fig19_": FIG19_CAPTION}
    lines: list[str] = []
    for p in names:
        more = extra.get(p[:6])
        lines += [f"![{p}]({p})", "", f"*{captions.get(p, p)}{' ' + more if more else ''}*", ""]
    return lines
