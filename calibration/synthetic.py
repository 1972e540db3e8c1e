"""Synthetic "measured" data with a hidden effect, for testing model criticism (and for trying it out).

The truth is the DEM rig itself with some knobs switched on (an effect the baseline lacks) plus the imperfections of
a real test: each configuration's springs differ from their nominal rate (``scatter``), the sensor has white noise
and an offset, the record is sampled at 2400 Hz and starts with a rest period before the hammer hit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .measured import Measured, Series, write_summary


def ringing_data(
    springs: tuple[int, ...],
    truth: dict[str, float],
    *,
    scatter: float = 0.02,
    noise: float = 0.01,
    offset: float = 2e-4,
    rest: float = 0.1,
    ring_time: float = 1.5,
    seed: int = 0,
    device: str | None = None,
    out: str | Path | None = None,
) -> Measured:
    """Ringing records of the linear-spring rig with ``truth`` (``dashpot`` [N s/m] and any knobs of
    ``calibration.rig_models.RingingRigModel``, e.g. ``{"dashpot": 3000, "pivot_friction": 0.05}``).

    scatter: relative 1-sigma deviation of each configuration's true stiffness from the nominal DIN rate; noise:
    sensor noise std as a fraction of the record's first swing; offset: the sensor's zero error [m]; rest [s]
    of flat record before the hit. Returns the data (nominal stiffness in the summary, displacement series in m);
    with ``out``, also writes them there in the MEASURED format (``summary.csv``, ``series/*.csv``).
    """
    from scenes import paper
    from scenes.ringing import RingingConfig, run_ringing

    rng = np.random.default_rng(seed)
    nominal = np.array([paper.ringing_row(n)["stiffness_n_per_m"] for n in springs])
    true_k = nominal * (1.0 + scatter * rng.standard_normal(len(springs)))
    knobs = {k: v for k, v in truth.items() if k not in ("dashpot", "sensor_offset", "sensor_drift")}
    cfg = RingingConfig(springs=tuple(springs), spring_model="linear", stiffness=tuple(true_k),
                        dashpot=(float(truth["dashpot"]),) * len(springs), ring_time=ring_time,
                        **{k: (float(v),) * len(springs) for k, v in knobs.items()})
    res = run_ringing(cfg, device=device)
    dt = float(res.time[1] - res.time[0])  # the record's sampling interval (2400 Hz to within one DEM step)
    n_rest = int(round(rest / dt))
    series = []
    for w, n in enumerate(springs):
        x = res.displacement[:, w] + truth.get("sensor_drift", 0.0) * res.time
        x = np.concatenate([np.zeros(n_rest), x])
        t = np.arange(x.size) * dt
        x = x + offset + truth.get("sensor_offset", 0.0) + noise * np.abs(x).max() * rng.standard_normal(x.size)
        series.append(Series({"springs": float(n)}, "displacement", t, x, f"synthetic:{n}"))
    data = Measured({"springs": np.array(springs, dtype=float), "stiffness": nominal},
                    {"springs": "-", "stiffness": "N/m"}, series, "synthetic")
    if out is not None:
        _write(Path(out), data)
    return data


def _write(out: Path, data: Measured) -> None:
    """Write ``data`` in the MEASURED format: ``summary.csv`` and one ``series/springs_NN.csv`` per series."""
    out.mkdir(parents=True, exist_ok=True)
    write_summary(out / "summary.csv", data.summary, data.units)
    if data.series:
        (out / "series").mkdir(exist_ok=True)
    for s in data.series:
        lines = [f"# springs: {int(s.config['springs'])}", "# signal: displacement", "time [s],displacement [m]"]
        lines += [f"{float(ti)!r},{float(xi)!r}" for ti, xi in zip(s.time, s.values, strict=True)]
        (out / "series" / f"springs_{int(s.config['springs']):02d}.csv").write_text("\n".join(lines) + "\n")


def soil_bin_data(
    springs: tuple[int, ...],
    speeds: tuple[float, ...],
    truth: dict[str, float],
    *,
    scatter: float = 0.02,
    noise: dict[str, float] | None = None,
    seed: int = 0,
    device: str | None = None,
    out: str | Path | None = None,
    series: bool = False,
    **rig: object,
) -> Measured:
    """A soil-bin summary (like Table 3) from the DEM rig with ``truth`` (any knobs of
    ``calibration.rig_models.SoilBinRigModel``, e.g. ``{"sensor_offset": -1.5e-3}``).

    Each configuration's true spring rate is its nominal DIN rate off by ``scatter`` (relative, 1 sigma); the
    summary gives the nominal rate. ``noise``: measurement noise (1 sigma, absolute) added to the observables,
    default reduction 1 percentage point and displacement 0.1 mm. ``rig``: the SoilBinRigModel's scene settings
    (scale, assembly, bed, ...). Columns: springs, stiffness, speed, reduction, displacement_mean (and the
    draught means). ``series``: also the displacement record of every configuration (the DEM's samples, the
    sensor's offset and drift, white noise of ``noise["displacement_series"]``, default 0.1 mm). With ``out``,
    written there in the MEASURED format.
    """
    from scenes import paper

    from .rig_models import Case, SoilBinRigModel

    rng = np.random.default_rng(seed)
    noise = {"reduction": 1.0, "displacement_mean": 1e-4, "displacement_series": 1e-4, **(noise or {})}
    nominal = np.array([paper.ringing_row(n)["stiffness_n_per_m"] for n in springs])
    true_k = nominal * (1.0 + scatter * rng.standard_normal(len(springs)))
    n = len(springs)
    columns = {"springs": np.array(springs, dtype=float), "stiffness": true_k, "speed": np.asarray(speeds, float),
               **{k: np.zeros(n) for k in ("reduction", "displacement_mean", "draught_mean", "rigid_draught_mean")}}
    truth_rig = SoilBinRigModel(Measured(columns, {}), device=device,
                                observables=("reduction", "displacement_mean", "draught_mean", "rigid_draught_mean"),
                                **rig)
    out_sim = truth_rig.simulate([Case(j, dict(truth)) for j in range(n)], keep_series=series)
    sim = out_sim.values
    units = {"springs": "-", "stiffness": "N/m", "speed": "m/s", "reduction": "%", "displacement_mean": "m",
             "draught_mean": "N", "rigid_draught_mean": "N"}
    summary = {"springs": columns["springs"], "stiffness": nominal, "speed": columns["speed"],
               "reduction": sim[:, 0] + noise["reduction"] * rng.standard_normal(n),
               "displacement_mean": sim[:, 1] + noise["displacement_mean"] * rng.standard_normal(n),
               "draught_mean": sim[:, 2], "rigid_draught_mean": sim[:, 3]}
    records = []
    if series:
        for n_springs, (t, x) in zip(springs, out_sim.series, strict=True):
            x = x + noise["displacement_series"] * rng.standard_normal(x.size)
            records.append(Series({"springs": float(n_springs)}, "displacement", t, x, f"synthetic:{n_springs}"))
    data = Measured(summary, units, records, "synthetic")
    if out is not None:
        _write(Path(out), data)
    return data
