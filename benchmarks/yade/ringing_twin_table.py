"""Frequency and damping ratio of every Yade ringing-twin run, as a markdown table.

Run with the project's Python (warpdem installed), from the repository root:
    python3 benchmarks/yade/ringing_twin_table.py            # ringing_twin_yade.npz -> ringing_twin_yade_table.md
    python3 benchmarks/yade/ringing_twin_table.py ringing_twin_yade_reduced.npz
                                                             # -> ringing_twin_yade_reduced_table.md
(a file name is looked up next to this script; the table is written next to the npz and printed.)

Signal: the y coordinate of the tool's sensor point (key f"{reading}/{springs}/sensor_y"), time since the hit.
Columns: f and zeta from :func:`scenes.analysis.ringdown` (least-squares fit of a damped sinusoid over the picked
run of peaks), zeta by the paper's eq. (4)-(5) on the first n+1 picked peaks (n = 3 and n = 10; "-" where fewer peaks
were found), the number of maxima picked; once on the raw record and once on the record low-passed at LOWPASS_HZ
(analysis.lowpass, zero-phase Butterworth): the records carry small ~20 Hz and ~50 Hz components (the load sphere
bouncing on the blade, and another contact mode) whose wiggles the peak picker takes for extrema, which breaks its
steady-rhythm test and leaves it only 2-3 maxima on most raw records; the low-passed results hardly change between
cutoffs of 10, 15 and 30 Hz. Then Table 2's measured frequency and calibrated f and zeta (from the spec copy in the
npz), and the share of records in which the shank lost contact with the spring column (the ringing is then not
that of a linear oscillator).
"""

from __future__ import annotations

import os
import sys

import numpy as np

from scenes import analysis

HERE = os.path.dirname(os.path.abspath(__file__))
LOWPASS_HZ = 30.0


def ringdown_row(t: np.ndarray, y: np.ndarray) -> dict[str, object]:
    row: dict[str, object] = {}
    try:
        r = analysis.ringdown(t, y)
        row.update(f=r.frequency_hz, zeta=r.damping_ratio, peaks=int(r.peak_times.size))
    except ValueError as e:  # InputError: no free vibration found
        row.update(f=None, zeta=None, peaks=0, error=str(e))
    for n in (3, 10):
        try:
            row[f"zeta{n}"] = analysis.ringdown(t, y, n_cycles=n).damping_ratio
        except ValueError:
            row[f"zeta{n}"] = None
    return row


def fmt(v: object, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def main(argv: list[str]) -> str:
    name = argv[1] if len(argv) > 1 else "ringing_twin_yade.npz"
    path = name if os.path.exists(name) else os.path.join(HERE, name)
    d = np.load(path)
    springs = [int(s) for s in d["springs"]]
    lines = [
        f"# Yade 2023.02a ringing twin: frequency and damping ratio ({os.path.basename(path)})",
        "",
        f"Sensor point y after the hit, sampled every {int(d['record_every'])} steps "
        f"({1 / float(d['record_dt']):.1f} Hz), "
        f"ring time {float(d['ring_time_used']):.3f} s, dt {float(d['dt']):.4g} s. f, zeta: fit of "
        "`scenes.analysis.ringdown`; zeta n=3, n=10: the paper's peak formula (eq. 4-5) on the first n+1 "
        "maxima ('-': fewer maxima found); max: maxima picked. Left block: raw record; right block (LP): record "
        f"low-passed at {LOWPASS_HZ:g} Hz (`analysis.lowpass`), which removes the ~20 Hz and ~50 Hz wiggles that "
        "break the peak picker's rhythm test on the raw record. Table 2: measured f, calibrated f and zeta; "
        "open: share of records with the shank off the spring column.",
        "",
        "| reading | springs | f [Hz] | zeta fit | zeta n=3 | zeta n=10 | max | LP f [Hz] | LP zeta fit | LP zeta n=3 "
        "| LP zeta n=10 | LP max | T2 f meas. [Hz] | T2 f cal. [Hz] | T2 zeta cal. | open |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for reading in [str(r) for r in d["run_readings"]]:
        for ci in [int(c) for c in d["run_configs"]]:
            s = springs[ci]
            p = f"{reading}/{s}/"
            if p + "time" not in d:
                continue
            t, y = d[p + "time"], d[p + "sensor_y"]
            row = ringdown_row(t, y)
            lp = ringdown_row(t, analysis.lowpass(y, 1.0 / float(d["record_dt"]), cutoff_hz=LOWPASS_HZ))
            open_frac = float(d[p + "ring_column_open_fraction"]) if p + "ring_column_open_fraction" in d else None
            lines.append(
                f"| {reading} | {s} | {fmt(row['f'], '.3f')} | {fmt(row['zeta'], '.4f')} | {fmt(row['zeta3'], '.4f')} "
                f"| {fmt(row['zeta10'], '.4f')} | {row['peaks']} | {fmt(lp['f'], '.3f')} | {fmt(lp['zeta'], '.4f')} "
                f"| {fmt(lp['zeta3'], '.4f')} | {fmt(lp['zeta10'], '.4f')} | {lp['peaks']} "
                f"| {float(d['measured_freq_hz'][ci]):.3f} "
                f"| {float(d['calibrated_freq_hz'][ci]):.3f} | {float(d['calibrated_damping'][ci]):.4f} "
                f"| {fmt(None if open_frac is None else 100 * open_frac, '.1f')}{'' if open_frac is None else ' %'} |")
            for label, r in (("raw", row), ("low-passed", lp)):
                if "error" in r:
                    lines.append(f"<!-- {p} {label}: {r['error']} -->")
    text = "\n".join(lines) + "\n"
    base = os.path.splitext(path)[0]
    out = base + "_table.md"
    with open(out, "w") as fh:
        fh.write(text)
    print(text)
    print("wrote", out)
    return out


if __name__ == "__main__":
    main(sys.argv)
