"""Draught reductions pair a passive run with a rigid run at its own speed (Table 3's pairing).

References: closed forms on synthetic draughts of known speed dependence (no DEM: the pairing, the standard errors,
the line through the rigid draughts and the re-paired Table 7 are arithmetic on the means), a Monte Carlo of the
reduction's standard error, and a diagnosis on data from an independent analytic soil-bin model written here (a
rigid draught linear in speed, a passive draught lower by a known fraction per spring count): the diagnosis must
name the rigid reference's speed when the data were made with one rigid run at 0.68 m/s, as the paper's Table 7
was, and nothing when they were paired at equal speeds.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from calibration import diagnosis
from calibration.measured import Measured
from calibration.rig_models import SoilBinRigModel
from scenes import paper, speed_sweep
from scenes import soil_bin as sb

F0, SLOPE, V0 = 300.0, 150.0, 0.6
"""the analytic soil: rigid draught F0 + SLOPE (v - V0) [N] (speeds in m/s)."""


def rigid_draught(v: float) -> float:
    return F0 + SLOPE * (v - V0)


def true_reduction(n: int) -> float:
    """the passive tool's draught reduction [%] against a rigid run at the same speed, by spring count."""
    return 1.0 + 0.15 * n


def test_rigid_speeds_cover_every_configuration() -> None:
    cfg = sb.SoilBinConfig(springs=(0, 16, 20, 32, 24), speed=(0.68, 0.68, 0.57, 0.52, 0.5700000001))
    assert cfg.rigid_speeds() == [0.52, 0.57, 0.68]
    assert sb.SoilBinConfig(springs=(16, 32)).rigid_speeds() == []  # no rigid configuration asked for
    # default speeds: Table 7's (rigid 0.68, 16 springs 0.68, 32 springs 0.52)
    assert sb.SoilBinConfig(springs=(0, 16, 32)).rigid_speeds() == [0.52, 0.68]


def test_reductions_pair_equal_speeds_closed_form() -> None:
    speeds = {4: 0.70, 20: 0.57, 32: 0.52, 16: 0.68}
    rows = [{"springs": 0, "speed": v, "draught_mean": rigid_draught(v), "draught_sem": 2.0}
            for v in sorted(set(speeds.values()))]
    rows += [{"springs": n, "speed": v, "draught_mean": rigid_draught(v) * (1 - true_reduction(n) / 100),
              "draught_sem": 1.0} for n, v in speeds.items()]
    rows.append({"springs": 8, "speed": 0.61, "draught_mean": 280.0, "draught_sem": 1.0})  # no rigid run at 0.61
    sb.pair_reductions(rows)
    for r in rows:
        if r["springs"] == 0:
            assert r["reduction_pct"] is None and r["rigid_reference_speed"] is None
        elif r["springs"] == 8:
            assert r["reduction_pct"] is None and r["reduction_sem"] is None
        else:
            assert r["rigid_reference_speed"] == r["speed"]
            assert r["rigid_reference_draught"] == pytest.approx(rigid_draught(r["speed"]), rel=1e-12)
            assert r["reduction_pct"] == pytest.approx(true_reduction(r["springs"]), abs=1e-10)
    # one rigid run at 0.68 for all (Table 7's way) would have shown the slow configurations' speed as reduction
    r32 = next(r for r in rows if r["springs"] == 32)
    biased = 100 * (rigid_draught(0.68) - r32["draught_mean"]) / rigid_draught(0.68)
    assert biased - r32["reduction_pct"] > 7.0
    # JSON: null, not NaN
    text = json.dumps(sb.json_safe([{**rows[0], "x": math.nan, "y": np.float64(np.inf), "z": (1.0, np.nan)}]))
    assert "NaN" not in text and "Infinity" not in text and json.loads(text)[0]["z"] == [1.0, None]


def test_reduction_standard_error_matches_monte_carlo() -> None:
    # first-order propagation against sampling: independent normal means, 0.5 % relative SEs (the first-order
    # error of the ratio is O(SE^2) = 2.5e-5 relative); 2e5 samples estimate an SD to 0.16 % (1/sqrt(2N)).
    rng = np.random.default_rng(3)
    p, sp, r, sr = 290.0, 1.5, 310.0, 1.6
    red, sem = sb.reduction(p, sp, r, sr)
    assert red == pytest.approx(100 * 20 / 310, rel=1e-12)
    draws = 100 * (1 - (p + sp * rng.standard_normal(200_000)) / (r + sr * rng.standard_normal(200_000)))
    assert sem == pytest.approx(draws.std(), rel=0.01)


def test_run_study_runs_rigid_at_every_speed(monkeypatch: pytest.MonkeyPatch) -> None:
    # run_study with the soil bin replaced by the analytic soil: every passive row is paired with a rigid world at
    # its own speed, all rigid worlds in one simulation.
    calls = []

    def fake_run(config, springs, *, bed, speeds, **kw):
        calls.append((list(springs), list(speeds)))
        steady = [{"springs": n, "speed": v,
                   "draught_mean": rigid_draught(v) * (1 - (true_reduction(n) if n else 0.0) / 100),
                   "draught_sem": 1.0} for n, v in zip(springs, speeds, strict=True)]
        return sb.SoilBinRun(tuple(springs), tuple(speeds), np.zeros(1), np.zeros((1, len(springs))), {}, steady)

    monkeypatch.setattr(sb, "run_soil_bin", fake_run)
    monkeypatch.setattr(sb, "bed_for", lambda *a, **k: None)
    cfg = sb.SoilBinConfig(scale="ci", springs=(0, 16, 20, 32))  # Table 7's speeds: 0.68, 0.68, 0.57, 0.52
    study = sb.run_study(cfg)
    assert calls[0] == ([0, 0, 0], [0.52, 0.57, 0.68]) and calls[1] == ([16, 20, 32], [0.68, 0.57, 0.52])
    for r in study["table"]:
        if r["springs"]:
            assert r["rigid_reference_speed"] == r["speed"]
            assert r["reduction_pct"] == pytest.approx(true_reduction(r["springs"]), abs=1e-10)


def test_line_and_table7_repaired_closed_form() -> None:
    v = np.array([0.45, 0.55, 0.65, 0.75])
    line = speed_sweep.fit_line(v, rigid_draught(v), np.full(4, 1.0))
    assert line.slope == pytest.approx(SLOPE, rel=1e-9) and line.intercept == pytest.approx(F0 - SLOPE * V0)
    t7 = paper.table("soil_bin_dem")
    rows = speed_sweep.repair_table7(line)
    row32 = next(r for r in rows if r["springs"] == 32)
    ref = t7["c_final_mean_n"][0] * rigid_draught(0.52) / rigid_draught(0.68)
    assert row32["c_final"]["rigid_reference"] == pytest.approx(ref, rel=1e-12)
    assert row32["c_final"]["reduction"] == pytest.approx(100 * (ref - t7["c_final_mean_n"][-1]) / ref, rel=1e-12)
    # the line's uncertainty: none at the reference speed itself; at 0.52 m/s the ratio's SE by the delta method
    # equals a Monte Carlo over the line's parameters (2e5 samples: 0.2 %)
    assert next(r for r in rows if r["springs"] == 16)["speed_ratio_se"] == pytest.approx(0.0, abs=1e-15)
    ab = np.random.default_rng(1).multivariate_normal([line.intercept, line.slope], line.cov, 200_000)
    ratios = (ab[:, 0] + ab[:, 1] * 0.52) / (ab[:, 0] + ab[:, 1] * 0.68)
    assert row32["speed_ratio_se"] == pytest.approx(ratios.std(), rel=0.01)
    # a speed-independent draught leaves the paper's reductions as its draughts give them; Table 7 prints them
    # rounded to 0.01 % (within 0.011 of the draughts' rounding) except one cell: assembly A, 4 springs prints
    # 5.57 % where its draughts (341.19 and 328.72 N) give 3.65 %
    flat = speed_sweep.fit_line(v, np.full(4, 300.0), np.full(4, 1e-6))
    off = []
    for r in speed_sweep.repair_table7(flat):
        for col in speed_sweep.TABLE7_COLUMNS:
            assert r[col]["reduction"] == pytest.approx(r[col]["paper_reduction_from_draughts"], abs=1e-9)
            assert r[col]["reduction_se"] < 1e-6
            if abs(r[col]["reduction"] - r[col]["paper_reduction"]) > 0.011:
                off.append((col, r["springs"]))
    assert off == [("a", 4)]


def analytic_soil_bin(config, springs, speeds, knobs, soil) -> sb.SoilBinRun:
    """The independent soil-bin model: rigid draught linear in speed; the passive tool draws true_reduction(n) %
    less at the same speed and deflects by its draught's moment over the spring's (0.1 m lever, force at 0.25 m);
    soil_viscosity b adds b v to the draught. Steady-state standard errors 0.5 N and 0.01 mm."""
    knobs = knobs or {}
    steady = []
    for w, (n, v) in enumerate(zip(springs, speeds, strict=True)):
        b = float(knobs.get("soil_viscosity", [0.0] * len(springs))[w])
        f = rigid_draught(v) * (1 - (true_reduction(n) if n else 0.0) / 100) + b * v
        k = float(knobs["stiffness"][w]) if n else math.inf
        steady.append({"springs": n, "speed": v, "draught_mean": f, "draught_sem": 0.5,
                       "displacement_mean": f * 0.25 / (0.1 * 0.1 * k), "displacement_sem": 1e-5,
                       "displacement_trend": 0.0, "displacement_trend_sem": 1e-5, "steady_time_mean": 1.0})
    t = np.linspace(0.0, 1.0, 11)
    series = {"displacement": np.tile([r["displacement_mean"] for r in steady], (len(t), 1)),
              "draught": np.tile([r["draught_mean"] for r in steady], (len(t), 1))}
    return sb.SoilBinRun(tuple(springs), tuple(speeds), t, np.outer(t, speeds), series, steady)


def _table7_like(one_rigid_speed: float | None, seed: int) -> Measured:
    """Table 3's configurations and speeds; reductions against a rigid run at one speed (Table 7's way) or at each
    configuration's own (Table 3's), with 0.3 percentage points of noise; displacements with 0.05 mm."""
    t3 = paper.table("soil_bin_measured")
    rng = np.random.default_rng(seed)
    springs, speeds = t3["springs"].astype(int), t3["speed_mean_m_s"]
    k = np.array([paper.ringing_row(int(n))["stiffness_n_per_m"] for n in springs])
    run = analytic_soil_bin(None, list(springs), list(speeds), {"stiffness": list(k)}, None)
    passive = np.array([r["draught_mean"] for r in run.steady])
    rigid = np.array([rigid_draught(one_rigid_speed or v) for v in speeds])
    return Measured({"springs": springs.astype(float), "speed": speeds, "stiffness": k,
                     "reduction": 100 * (rigid - passive) / rigid + 0.3 * rng.standard_normal(len(springs)),
                     "displacement_mean": np.array([r["displacement_mean"] for r in run.steady])
                     + 5e-5 * rng.standard_normal(len(springs))}, {})


@pytest.mark.parametrize("one_rigid_speed", [0.68, None])
def test_diagnosis_names_a_rigid_reference_at_another_speed(one_rigid_speed: float | None) -> None:
    data = _table7_like(one_rigid_speed, seed=5)
    rig = SoilBinRigModel(data, simulator=analytic_soil_bin, uncertainty={"reduction": 0.3,
                                                                          "displacement_mean": 5e-5})
    settings = diagnosis.DiagnosisSettings(
        rounds=4, mechanisms=("rigid_reference_speed", "speed_dependence", "sensor_offset"))
    d = diagnosis.diagnose(rig, settings)
    if one_rigid_speed is None:
        assert d.verdict == "no significant discrepancy" and not d.cause
        return
    assert d.cause == ("rigid_reference_speed",)
    fit = d.fits["rigid_reference_speed"]
    # the fitted reference speed: the line through the analytic rigid runs is exact, so only the noise moves it;
    # 0.3 points of noise on 8 reductions with a lever of ~0.5 % per 0.01 m/s: a few mm/s
    assert fit.candidate.values(fit.z_all)["rigid_speed"] == pytest.approx(0.68, abs=0.01)


def test_the_speed_sweep_reports_what_this_means_from_its_numbers() -> None:
    """Reference: hand arithmetic. Line F = 100 + 150 v N with slope SE 20 N s/m: F(0.68) = 202 N, 100 x 15 / 202 =
    +7.4 % per 0.1 m/s; pairing 0.52 with 0.68 m/s moves a reduction by 100 x 150 x 0.16 / 202 = +11.9 pp, beside
    laboratory reductions of mean magnitude (4.9 + 5.52) / 2 = 5.2 %. Line F = 100 + 5 v with slope SE 20: within
    two SEs of zero; shift 100 x 5 x 0.16 / 103.4 = 0.77 pp, under a quarter of 5.2 %; reduced chi^2 3.5 > 2."""
    from scenes.speed_sweep import SpeedLine, sweep_meaning

    rows = [{"speed": 0.52, "lab_reduction": -5.52}, {"speed": 0.70, "lab_reduction": 4.9}]
    text = "\n".join(sweep_meaning(SpeedLine(100.0, 150.0, [[1.0, 0.0], [0.0, 400.0]], 1.0), rows))
    assert "rises with speed: +7.4 % of F(0.68) per 0.1 m/s" in text
    assert "moves its reduction by +11.9 percentage points" in text and "average 5.2 %" in text
    assert "the pairing matters beside" in text and "chi^2" not in text
    text = "\n".join(sweep_meaning(SpeedLine(100.0, 5.0, [[1.0, 0.0], [0.0, 400.0]], 3.5), rows))
    assert "cannot tell the rigid draught's speed dependence from none" in text
    assert "by +0.8 percentage points" in text and "matters little" in text
    assert "reduced chi^2 3.5" in text


def test_the_speed_mechanisms_are_candidates_only_where_the_speeds_differ() -> None:
    # At one speed a rigid reference at another speed moves every reduction by nearly one amount (the analytic
    # soil above: the rigid draught is one number, the passive ones differ by 1.6-5.8 %), and a resistance b v is one
    # force: each is a free offset that would absorb any other cause under its name, and its signature (residuals
    # with the speed) cannot show. So they are candidates on Table 3's speeds (0.57-0.70 m/s; the test above names
    # one there) and not on the same configurations run at one speed, unless named explicitly.
    speed_mechanisms = {"rigid_reference_speed", "speed_dependence"}
    varied = _table7_like(0.68, seed=5)
    one = Measured({**varied.summary, "speed": np.full(varied.n_configs, 0.62)}, {})
    for data, expected in ((varied, speed_mechanisms), (one, set())):
        rig = SoilBinRigModel(data, simulator=analytic_soil_bin)
        names = {m.name for m in diagnosis.mechanisms_for(rig, diagnosis.DiagnosisSettings())}
        assert names & speed_mechanisms == expected and "sensor_offset" in names
    rig = SoilBinRigModel(one, simulator=analytic_soil_bin)
    asked = diagnosis.DiagnosisSettings(mechanisms=("speed_dependence",))
    assert [m.name for m in diagnosis.mechanisms_for(rig, asked)] == ["speed_dependence"]
