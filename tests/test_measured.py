"""The measured-data format (calibration/measured.py): units to SI, the paper's tables, series, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from calibration import measured
from scenes import analysis
from warpdem.errors import InputError


def test_units_convert_to_si(tmp_path) -> None:
    # Reference: the unit factors (1 N/mm = 1e3 N/m, 1 km/h = 1/3.6 m/s, 1 mm = 1e-3 m, 1 % = 0.01)
    p = tmp_path / "s.csv"
    p.write_text("# a comment\nsprings,stiffness [N/mm],speed [km/h],damping [%],displacement_mean [mm],"
                 "draught_mean [kN]\n16,187,2.25,20.27,4.751,0.31771\n"
                 "32,94,1.872,17.708,12.487,0.35435\n")
    m = measured.load(p)
    np.testing.assert_allclose(m.summary["stiffness"], [1.87e5, 0.94e5])
    np.testing.assert_allclose(m.summary["speed"], [0.625, 0.52])
    np.testing.assert_allclose(m.summary["damping"], [0.2027, 0.17708])
    np.testing.assert_allclose(m.summary["displacement_mean"], [4.751e-3, 12.487e-3])
    np.testing.assert_allclose(m.summary["draught_mean"], [317.71, 354.35])
    assert m.units["stiffness"] == "N/m" and m.units["damping"] == "-"
    np.testing.assert_array_equal(m.summary["springs"], [16, 32])


@pytest.mark.parametrize("rig", ["ringing", "soil-bin"])
def test_paper_tables_round_trip(tmp_path, rig: str) -> None:
    # Tables 2 and 3 in this format survive writing and reading exactly (SI in, SI out)
    m = measured.from_paper(rig)
    measured.write_summary(tmp_path / "t.csv", m.summary, m.units)
    back = measured.load(tmp_path / "t.csv")
    assert back.units == m.units
    for k, v in m.summary.items():
        np.testing.assert_array_equal(back.summary[k], v)
    if rig == "ringing":  # Table 2: 16 springs ring at 6.09137 Hz, zeta 0.20270, DIN stiffness 1.87e5 N/m
        k = int(np.flatnonzero(m.summary["springs"] == 16)[0])
        assert (m.summary["frequency"][k], m.summary["damping"][k], m.summary["stiffness"][k]) == (
            6.09137, 0.20270, 1.87e5)
    else:  # Table 3: reduction = 100 (rigid - passive) / rigid on every row (to the table's two decimals)
        red = 100 * (m.summary["rigid_draught_mean"] - m.summary["draught_mean"]) / m.summary["rigid_draught_mean"]
        np.testing.assert_allclose(red, m.summary["reduction"], atol=0.01)


def test_series_in_mm_recover_a_known_ringdown(tmp_path) -> None:
    # Reference: a damped sine x = A exp(-zeta w t) sin(w_d t) (6.09 Hz, zeta 0.2027), written in mm at 2400 Hz
    # (the laboratory's rate) with ms time stamps; read back in metres, the ring-down fit (eqs. 3-5, tested to 1 %
    # in test_analysis) recovers frequency and damping within 1 %.
    f, z = 6.09137, 0.20270
    t = np.arange(0, 1.5, 1 / 2400)
    wd = 2 * np.pi * f
    wn = wd / np.sqrt(1 - z**2)
    x_mm = 3.0 * np.exp(-z * wn * t) * np.sin(wd * t)
    d = tmp_path / "lab"
    (d / "series").mkdir(parents=True)
    rows = "\n".join(f"{1e3 * a:.17g},{b:.17g}" for a, b in zip(t, x_mm, strict=True))
    header = "# springs: 16\n# signal: displacement\ntime [ms],displacement [mm]\n"
    (d / "series" / "s16.csv").write_text(header + rows + "\n")
    m = measured.load(d)
    (s,) = m.series_for("displacement", springs=16)
    assert s.sample_rate == pytest.approx(2400, rel=1e-9)
    np.testing.assert_allclose(s.values, 1e-3 * x_mm, rtol=1e-12)
    fit = analysis.ringdown(s.time, s.values)
    assert fit.frequency_hz == pytest.approx(f, rel=0.01) and fit.damping_ratio == pytest.approx(z, rel=0.01)


def test_bad_measured_files_are_named(tmp_path) -> None:
    p = tmp_path / "bad.csv"
    p.write_text("springs,stiffness [lbf/in]\n16,1000\n")
    with pytest.raises(ValueError, match=r"column 'stiffness' has unit 'lbf/in'; accepted"):
        measured.load(p)
    p.write_text("springs,frequency [Hz]\n16,6.1,7\n")
    with pytest.raises(ValueError, match="row 1 has 3 values for 2 columns"):
        measured.load(p)
    p.write_text("springs,frequency [Hz]\n16,six\n")
    with pytest.raises(ValueError, match="column 'frequency'.*'six' is not a number"):
        measured.load(p)
    p.write_text("springs,frequency [Hz]\n16.5,6.1\n")
    with pytest.raises(ValueError, match="springs must be integers"):
        measured.load(p)
    s = tmp_path / "d" / "series"
    s.mkdir(parents=True)
    (s / "a.csv").write_text("time [s],force [N]\n" + "\n".join(f"{k / 100},{k}" for k in range(10)))
    with pytest.raises(ValueError, match="must name the configuration"):
        measured.load(tmp_path / "d")
    (s / "a.csv").write_text("# springs: 4\ntime [s],force [N]\n" + "\n".join(f"{1 - k / 100},{k}" for k in range(10)))
    with pytest.raises(ValueError, match="time must increase strictly"):
        measured.load(tmp_path / "d")
    with pytest.raises(InputError, match="neither a file nor a directory"):
        measured.load(tmp_path / "nowhere")
    # a column nothing reads, a binary file, one configuration twice (with other values, or the same), a header
    # without rows, a ';'-separated export: the file, the column, row or byte, and what is expected
    p.write_text("springs,frequency [Hz],temperature [C]\n16,6.1,21\n")
    with pytest.raises(InputError, match=r"bad.csv: column 'temperature \[C\]' is not one warpdem reads; accepted: "
                                         r"springs, stiffness, speed"):
        measured.load(p)
    p.write_bytes(b"springs,frequency [Hz]\n\xff\xfe16,6.1\n")
    with pytest.raises(InputError, match=r"bad.csv: not a text CSV file \(byte 23 is not UTF-8\)"):
        measured.load(p)
    p.write_text("springs,frequency [Hz],damping [-]\n16,6.09,0.2027\n32,7.5,0.2\n16.0,7.5,0.2\n")
    with pytest.raises(InputError, match=r"rows 1 and 3 are one configuration \(springs 16.0\) with different "
                                         r"values \(frequency \[Hz\]: 6.09 and 7.5\)"):
        measured.load(p)
    p.write_text("springs,speed [m/s],reduction [%]\n16,0.6,5\n16,0.7,4\n16,0.6,5\n")
    with pytest.raises(InputError, match=r"row 3 repeats row 1 \(springs 16, speed \[m/s\] 0.6\)"):
        measured.load(p)
    p.write_text("# springs: 16\nsprings,frequency [Hz],damping [-]\n")
    with pytest.raises(InputError, match=r"bad.csv: a header \(springs, frequency \[Hz\], damping \[-\]\) and no "
                                         "rows; give one row per configuration"):
        measured.load(p)
    p.write_text("springs;frequency [Hz];damping [-]\n16;6,09;0,2027\n")
    with pytest.raises(InputError, match="bad.csv: the header 'springs;frequency .* is separated by ';'; the "
                                         "separator must be a comma"):
        measured.load(p)


def test_a_csv_with_a_byte_order_mark_reads_like_the_plain_one(tmp_path) -> None:
    # Excel's "CSV UTF-8" export starts with a byte-order mark (EF BB BF): the table reads as without it
    table = "springs,frequency [Hz],damping [%]\n16,6.09137,20.27\n32,7.5,17.7\n"
    (tmp_path / "plain.csv").write_text(table, encoding="utf-8")
    (tmp_path / "excel.csv").write_text(table, encoding="utf-8-sig")
    assert (tmp_path / "excel.csv").read_bytes()[:3] == b"\xef\xbb\xbf"
    plain, excel = measured.load(tmp_path / "plain.csv"), measured.load(tmp_path / "excel.csv")
    assert excel.units == plain.units and list(excel.summary) == list(plain.summary) == ["springs", "frequency",
                                                                                        "damping"]
    for k, v in plain.summary.items():
        np.testing.assert_array_equal(excel.summary[k], v)


@pytest.mark.parametrize("table,words", [
    ("springs,frequency [Hz],damping [-]\n16,6.1,nan\n", "row 1: 'nan' is not a finite number"),
    ("springs,frequency [Hz],damping [-]\n16,inf,0.2\n", "'inf' is not a finite number"),
    ("springs,frequency [Hz],damping [-]\n16,0,0.2\n", "'frequency .*row 1: 0 .* outside"),
    ("springs,frequency [Hz],damping [-]\n16,6.1,12.4\n", "'damping .*row 1: 12.4 .*percent"),
    ("springs,stiffness [N/m],frequency [Hz]\n16,1e30,6.1\n", "'stiffness \\[N/m\\]', row 1: 1e30"),
    ("springs,stiffness [N/m],frequency [Hz]\n16,-5,6.1\n", "row 1: -5 .* outside"),
    ("springs,speed [m/s],reduction [%]\n16,0.6,150\n", "'reduction \\[%\\]', row 1: 150"),
    ("springs,speed [m/s],reduction [%]\n16,-0.6,5\n", "'speed \\[m/s\\]', row 1: -0.6"),
    ("springs,draught_mean [N]\n16,-10\n", "'draught_mean \\[N\\]', row 1: -10"),
    ("springs,frequency [Hz]\n-4,6.1\n", "'springs', row 1: -4"),
])
def test_implausible_measured_values_are_refused_by_column_and_row(tmp_path, table: str, words: str) -> None:
    """Values no rig can produce (NaN or inf written out, 0 Hz, a damping ratio given in percent under a [-]
    header, a spring of 1e30 N/m whose time step would collapse, a reduction beyond 100 %, negative speeds, draughts
    or spring counts) are refused with the file, column, row and value, before any simulation."""
    p = tmp_path / "m.csv"
    p.write_text(table)
    with pytest.raises(InputError, match=words):
        measured.load(p)


def test_soil_bin_records_in_the_measured_format_give_the_observables(tmp_path) -> None:
    # Reference: records written in the MEASURED format (draught in kN, displacement in mm, times in ms) of known
    # signals: draught 300 N + 2 N/s drift, displacement 4 mm + 0.5 mm/s, both with noise, at 0.6 m/s. Read back
    # through the soil-bin rig model (nothing is simulated), the observables are the steady parts' (travel >= 0.15
    # m) mean and trend, equal to analysis.steady_state of the same samples (round-off), and near the truth
    # (5 standard errors).
    from calibration.rig_models import SoilBinRigModel

    rng = np.random.default_rng(3)
    t = np.arange(0.0, 1.5, 1 / 500)
    (tmp_path / "series").mkdir()
    (tmp_path / "summary.csv").write_text("springs [-],speed [m/s]\n16,0.6\n")
    truth = {"force": (300.0 + 2.0 * t, 20.0, 1e-3, "kN"), "displacement": (4e-3 + 5e-4 * t, 2e-4, 1e3, "mm")}
    samples = {}
    for signal, (clean, noise, factor, unit) in truth.items():
        samples[signal] = clean + noise * rng.standard_normal(t.size)
        lines = ["# springs: 16", f"# signal: {signal}", f"time [ms],{signal} [{unit}]"]
        lines += [f"{float(1e3 * ti)!r},{float(factor * xi)!r}" for ti, xi in zip(t, samples[signal], strict=True)]
        (tmp_path / "series" / f"{signal}.csv").write_text("\n".join(lines) + "\n")
    rig = SoilBinRigModel(measured.load(tmp_path), observables=("draught_mean", "displacement_mean",
                                                                "displacement_trend"), steady_travel=0.15)
    draught = analysis.steady_state(t, samples["force"], 0.6 * t, start_travel=0.15)
    disp = analysis.steady_state(t, samples["displacement"], 0.6 * t, start_travel=0.15)
    np.testing.assert_allclose(rig.measured[0], [draught.mean, disp.mean, disp.trend], rtol=1e-9)
    assert rig.has_series and "sensor_drift" in rig.knobs
    assert abs(draught.mean - (300.0 + 2.0 * draught.t_mean)) < 5 * draught.sem
    assert abs(disp.trend - 5e-4) < 5 * disp.trend_sem
