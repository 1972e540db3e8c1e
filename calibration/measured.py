"""Measured data for calibration and diagnosis: one documented format, read into SI units.

A MEASURED source is either a CSV file (a summary table) or a directory holding ``summary.csv`` and/or
``series/*.csv`` (time series, one file per configuration and signal). Files are UTF-8 text (a byte-order mark, as
Excel's "CSV UTF-8" writes, is accepted), comma-separated, with a point as the decimal mark.

Summary table (CSV, ``#`` lines are comments): one row per configuration (springs, speed and stiffness as given;
a configuration given twice is refused). Every column header is ``name [unit]`` (a header without a unit means a
dimensionless value). The names and the units they accept:

=====================  ==========================================  =========================================
name                   meaning                                     units accepted (-> SI)
=====================  ==========================================  =========================================
springs                spring count of the configuration           - (integer)
stiffness              spring stiffness                            N/m, N/mm, kN/m
speed                  carriage speed                              m/s, mm/s, km/h
speed_std              carriage speed's std over the run           m/s, mm/s, km/h
frequency              ring-down frequency                         Hz
damping                damping ratio                               -, %
draught_mean/_std      passive tool's draught mean / std           N, kN
rigid_draught_mean/_std rigid tool's draught mean / std            N, kN
displacement_mean/_std tool displacement at the sensor             m, mm
reduction              draught reduction vs the rigid tool         %, -
<observable>_se        standard error of the row's reduction,      the observable's units
                       draught_mean, rigid_draught_mean or
                       displacement_mean (e.g. over repeated runs)
=====================  ==========================================  =========================================

A standard-error column is that row's uncertainty of its observable: a fit weighs the row by it instead of the
rig's stated default (``calibration.rig_models.SOIL_BIN_UNCERTAINTY``; an ``uncertainty=`` given by the caller still
overrides both).

Any other column is refused with its name (nothing reads it: a note belongs in a ``#`` comment line).

Time series (CSV): comment lines ``# key: value`` give the configuration (at least ``springs``) and may give
``signal`` (``force`` or ``displacement``); two columns ``time [s|ms]`` and the signal (``force [N|kN]`` or
``displacement [m|mm]``) at any, possibly uneven, sample rate.

    m = load("../shared/data/ringing_test_table2.csv")       # or a directory
    m.summary["frequency"], m.summary["stiffness"]          # SI arrays, one value per configuration
    for s in m.series: s.config["springs"], s.time, s.values
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scenes import rigs
from warpdem.errors import InputError

_SPEED = {"m/s": 1.0, "mm/s": 1e-3, "km/h": 1 / 3.6}
_FORCE = {"N": 1.0, "kN": 1e3}
_LENGTH = {"m": 1.0, "mm": 1e-3}
_PERCENT = {"%": 1.0, "-": 100.0}
UNITS: dict[str, dict[str, float]] = {
    "springs": {"-": 1.0},
    "stiffness": {"N/m": 1.0, "N/mm": 1e3, "kN/m": 1e3},
    **dict.fromkeys(("speed", "speed_std"), _SPEED),
    "frequency": {"Hz": 1.0},
    "damping": {"-": 1.0, "%": 1e-2},
    **dict.fromkeys(("draught_mean", "draught_std", "rigid_draught_mean", "rigid_draught_std", "draught_mean_se",
                     "rigid_draught_mean_se", "force"), _FORCE),
    **dict.fromkeys(("displacement_mean", "displacement_std", "displacement_mean_se", "displacement"), _LENGTH),
    **dict.fromkeys(("reduction", "reduction_se"), _PERCENT),
    "time": {"s": 1.0, "ms": 1e-3},
}
"""accepted units per known quantity and their factor to the SI unit (reduction is kept in %)."""
SERIES_ONLY = ("time", "force", "displacement")
"""the columns of a time series, not of a summary table."""
CONFIGURATION = ("springs", "speed", "stiffness")
"""the summary columns that make a configuration: two rows alike in these are refused."""
RANGES: dict[str, tuple[float, float, str]] = {
    "springs": (0.0, 1e3, "a spring count"),
    "stiffness": (1e-3, 1e9, "N/m (a stiffer spring would need a time step below a microsecond)"),
    "speed": (1e-4, 20.0, "m/s"),
    "speed_std": (0.0, 20.0, "m/s"),
    "frequency": (1e-3, 1e3, "Hz"),
    "damping": (1e-6, 1.0, "(a damping ratio: values in percent need the header 'damping [%]')"),
    "draught_mean": (0.0, 1e6, "N"),
    "draught_std": (0.0, 1e6, "N"),
    "rigid_draught_mean": (0.0, 1e6, "N"),
    "rigid_draught_std": (0.0, 1e6, "N"),
    "displacement_mean": (-1.0, 1.0, "m"),
    "displacement_std": (0.0, 1.0, "m"),
    "reduction": (-100.0, 100.0, "%"),
    "reduction_se": (1e-12, 100.0, "% (a standard error: positive)"),
    "draught_mean_se": (1e-12, 1e6, "N (a standard error: positive)"),
    "rigid_draught_mean_se": (1e-12, 1e6, "N (a standard error: positive)"),
    "displacement_mean_se": (1e-12, 1.0, "m (a standard error: positive)"),
}
"""plausible open range (low, high) of each known quantity in SI (reduction in %), and what it is: a value outside
is refused with its column and row, so that a unit slip or a typo fails at once instead of as a meaningless fit."""
_HEADER = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*(?:\[([^\]]*)\])?\s*$")


@dataclass
class Series:
    """One measured time series: ``time`` [s] (n,), ``values`` [N or m] (n,), its ``signal`` name and the
    configuration keys from its header (e.g. ``{"springs": 16}``)."""

    config: dict[str, float | str]
    signal: str
    time: np.ndarray
    values: np.ndarray
    source: str = ""

    @property
    def sample_rate(self) -> float:
        """median sampling rate [Hz]."""
        return float(1.0 / np.median(np.diff(self.time)))


@dataclass
class Measured:
    """Measured data in SI: ``summary`` name -> (n_configs,) array; ``units`` name -> the SI unit; ``series``."""

    summary: dict[str, np.ndarray] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    series: list[Series] = field(default_factory=list)
    source: str = ""

    @property
    def n_configs(self) -> int:
        return len(next(iter(self.summary.values()))) if self.summary else 0

    def series_for(self, signal: str, **config: float) -> list[Series]:
        """The series of a signal whose configuration matches ``config`` (e.g. springs=16)."""
        return [s for s in self.series if s.signal == signal
                and all(s.config.get(k) == v for k, v in config.items())]


def _parse_header(text: str, where: str) -> tuple[str, str]:
    m = _HEADER.match(text)
    if not m:
        raise InputError(f"{where}: column header {text!r} is not 'name [unit]'")
    return m.group(1), (m.group(2) or "-").strip()


def _factor(name: str, unit: str, where: str) -> tuple[float, str]:
    """Factor to SI and the SI unit."""
    accepted = UNITS[name]
    if unit not in accepted:
        raise InputError(f"{where}: column {name!r} has unit {unit!r}; accepted: {sorted(accepted)}")
    si = next(u for u, f in accepted.items() if f == 1.0)
    return accepted[unit], si


def _rows(path: Path) -> tuple[list[str], list[list[str]], dict[str, str]]:
    meta: dict[str, str] = {}
    lines = []
    try:
        text = path.read_text(encoding="utf-8-sig")  # Excel's "CSV UTF-8" starts with a byte-order mark
    except UnicodeDecodeError as e:
        raise InputError(f"{path}: not a text CSV file (byte {e.start} is not UTF-8); save the table as CSV UTF-8") \
            from None
    except OSError as e:
        raise InputError(f"{path} cannot be read: {e.strerror or e}") from None
    for ln in text.splitlines():
        if not ln.strip():
            continue
        if ln.lstrip().startswith("#"):
            m = re.match(r"^\s*#\s*([A-Za-z_][A-Za-z0-9_]*)\s*:\s*(.+?)\s*$", ln)
            if m:
                meta[m.group(1)] = m.group(2)
            continue
        if not lines and ("," not in ln and (";" in ln or "\t" in ln)):
            sep = "';'" if ";" in ln else "tabs"
            raise InputError(f"{path}: the header {ln.strip()[:60]!r} is separated by {sep}; the separator must be "
                             "a comma (and the decimal mark a point), as Excel's 'CSV UTF-8 (Comma delimited)' writes")
        lines.append([c.strip() for c in ln.split(",")])
    if not lines:
        raise InputError(f"{path}: no header row")
    header, rows = lines[0], lines[1:]
    if not rows:
        raise InputError(f"{path}: a header ({', '.join(header)}) and no rows; give one row per "
                         f"{'sample' if len(header) == 2 and header[0].startswith('time') else 'configuration'}")
    for k, r in enumerate(rows):
        if len(r) != len(header):
            raise InputError(f"{path}: row {k + 1} has {len(r)} values for {len(header)} columns")
    return header, rows, meta


def _number(text: str, where: str) -> float:
    """A cell's value; an empty cell is a missing value (NaN), 'nan' or 'inf' written out is refused."""
    if text == "":
        return float("nan")
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"{where}: {text!r} is not a number") from None
    if not np.isfinite(v):
        raise InputError(f"{where}: {text!r} is not a finite number (leave the cell empty for a missing value)")
    return v


def load_summary(path: str | Path) -> Measured:
    """Read a summary table (format in the module docstring) into SI units."""
    path = Path(path)
    header, rows, _ = _rows(path)
    out = Measured(source=str(path))
    for j, h in enumerate(header):
        name, unit = _parse_header(h, str(path))
        if name not in UNITS or name in SERIES_ONLY:
            raise InputError(f"{path}: column {h!r} is not one warpdem reads; accepted: "
                             f"{', '.join(n for n in UNITS if n not in SERIES_ONLY)} (a note belongs in a '#' line)")
        if name in out.summary:
            raise InputError(f"{path}: column {name!r} appears twice")
        f, si = _factor(name, unit, str(path))
        out.summary[name] = np.array([_number(r[j], f"{path}: column {name!r}, row {k + 1}")
                                      for k, r in enumerate(rows)]) * f
        out.units[name] = si
        if name in RANGES:
            low, high, what = RANGES[name]
            v = out.summary[name]
            bad = np.flatnonzero(~np.isnan(v) & ((v < low) | (v > high) | ((v == low) & (low > 0))))
            if len(bad):
                k = int(bad[0])
                raise InputError(f"{path}: column {h!r}, row {k + 1}: {rows[k][j]} ({v[k]:.6g} in SI) is outside "
                                 f"({low:g}, {high:g}) {what}")
    if "springs" in out.summary and not np.all(np.mod(out.summary["springs"], 1) == 0):
        raise InputError(f"{path}: springs must be integers, got {out.summary['springs'].tolist()}")
    _one_row_per_configuration(path, header, rows, np.column_stack(list(out.summary.values())))
    return out


def _one_row_per_configuration(path: Path, header: list[str], rows: list[list[str]], values: np.ndarray) -> None:
    """Refuse two rows of one configuration (alike in the CONFIGURATION columns given), naming both rows;
    ``values``: the table in SI, (rows, columns)."""
    keys = [j for j, h in enumerate(header) if _parse_header(h, str(path))[0] in CONFIGURATION]
    if not keys:
        return
    first: dict[tuple[float, ...], int] = {}
    for k, row in enumerate(values):
        key = tuple(np.nan_to_num(row[keys], nan=np.inf).tolist())
        if key not in first:
            first[key] = k
            continue
        i = first[key]
        config = ", ".join(f"{header[j]} {rows[k][j]}" for j in keys)
        same = (values[i] == row) | (np.isnan(values[i]) & np.isnan(row))
        differ = np.flatnonzero(~same)
        if len(differ):
            j = int(differ[0])
            raise InputError(f"{path}: rows {i + 1} and {k + 1} are one configuration ({config}) with different "
                             f"values ({header[j]}: {rows[i][j]} and {rows[k][j]}); give one row per configuration "
                             "(the mean of repeated runs)")
        raise InputError(f"{path}: row {k + 1} repeats row {i + 1} ({config}); give each configuration once")


def load_series(path: str | Path) -> Series:
    """Read one time series (format in the module docstring): time [s] and force [N] or displacement [m]."""
    path = Path(path)
    header, rows, meta = _rows(path)
    if len(header) != 2:
        raise InputError(f"{path}: a series has two columns (time and the signal), got {header}")
    (tn, tu), (sn, su) = (_parse_header(h, str(path)) for h in header)
    if tn != "time" or sn not in ("force", "displacement"):
        raise InputError(f"{path}: columns must be 'time [s]' and 'force [N]' or 'displacement [m]', got {header}")
    ft, _ = _factor(tn, tu, str(path))
    fs, _ = _factor(sn, su, str(path))
    data = np.array([[_number(v, str(path)) for v in r] for r in rows], dtype=np.float64)
    t, x = data[:, 0] * ft, data[:, 1] * fs
    if len(t) < 8 or not np.all(np.diff(t) > 0):
        raise InputError(f"{path}: time must increase strictly over at least 8 samples")
    config: dict[str, float | str] = {}
    for k, v in meta.items():
        try:
            config[k] = float(v)
        except ValueError:
            config[k] = v
    if "springs" not in config:
        raise InputError(f"{path}: the header must name the configuration, e.g. '# springs: 16'")
    signal = str(config.pop("signal", sn))
    return Series(config, signal, t, x, str(path))


def load(path: str | Path) -> Measured:
    """A summary CSV, or a directory with ``summary.csv`` and/or ``series/*.csv``."""
    path = Path(path)
    if path.is_file():
        return load_summary(path)
    if not path.is_dir():
        raise InputError(f"measured data {str(path)!r} is neither a file nor a directory")
    out = load_summary(path / "summary.csv") if (path / "summary.csv").exists() else Measured(source=str(path))
    out.series = [load_series(p) for p in sorted((path / "series").glob("*.csv"))]
    if not out.summary and not out.series:
        raise InputError(f"{path}: no summary.csv and no series/*.csv")
    return out


def write_summary(path: str | Path, columns: dict[str, np.ndarray], units: dict[str, str]) -> None:
    """Write a summary table in this format: ``columns`` name -> values, ``units`` name -> unit."""
    names = list(columns)
    lines = [",".join(f"{n} [{units.get(n, '-')}]" for n in names)]
    n = len(next(iter(columns.values())))
    for k in range(n):
        lines.append(",".join(repr(float(columns[c][k])) for c in names))
    Path(path).write_text("\n".join(lines) + "\n")


def _paper_table2() -> tuple[dict[str, object], dict[str, str]]:
    from scenes import paper

    t = paper.table("ringing")
    cols = {"springs": t["springs"], "stiffness": t["stiffness_n_per_m"], "frequency": t["measured_freq_hz"],
            "damping": t["measured_damping"]}
    return cols, {"springs": "-", "stiffness": "N/m", "frequency": "Hz", "damping": "-"}


def _paper_table3() -> tuple[dict[str, object], dict[str, str]]:
    from scenes import paper

    t = paper.table("soil_bin_measured")
    cols = {"springs": t["springs"], "speed": t["speed_mean_m_s"], "speed_std": t["speed_std_m_s"],
            "rigid_draught_mean": t["rigid_draught_mean_n"], "rigid_draught_std": t["rigid_draught_std_n"],
            "draught_mean": t["passive_draught_mean_n"], "draught_std": t["passive_draught_std_n"],
            "displacement_mean": 1e-3 * t["displacement_mean_mm"],
            "displacement_std": 1e-3 * t["displacement_std_mm"], "reduction": t["reduction_pct"]}
    units = {"springs": "-", "speed": "m/s", "speed_std": "m/s", "rigid_draught_mean": "N",
             "rigid_draught_std": "N", "draught_mean": "N", "draught_std": "N", "displacement_mean": "m",
             "displacement_std": "m", "reduction": "%"}
    return cols, units


PAPER_TABLES = {rigs.RINGING.name: _paper_table2, rigs.SOIL_BIN.name: _paper_table3}
"""each rig's measured table in the paper, as (columns, units)."""


def from_paper(rig: str) -> Measured:
    """The paper's measured tables in this format: ``"ringing"`` (Table 2: springs, stiffness, frequency, damping)
    or ``"soil-bin"`` (Table 3: springs, speed and its std, rigid and passive draught, displacement, reduction)."""
    cols, units = PAPER_TABLES[rigs.get(rig, tuple(PAPER_TABLES)).name]()
    return Measured({k: np.asarray(v, dtype=np.float64) for k, v in cols.items()}, units, [], f"paper:{rig}")
