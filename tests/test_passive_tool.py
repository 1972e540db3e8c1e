"""The passive tool described once (scenes/passive_tool.py), checked against closed forms on the simulated rigs.

References:
- ringing: the linear one-degree-of-freedom rig, J theta'' + c a^2 theta' + (k_e a^2 + K_g) theta = 0, whose damped
  frequency sqrt(K / J) sqrt(1 - zeta^2) / (2 pi) the simulated ringing rig must give, and
  ``scenes.ringing.analytic_frequency`` (the ringing rig's own closed form, written separately) for DIN rates;
- statics: a known backward moment about the pivot (a dashpot of rate b pulled at the carriage's speed v from the
  blade tip, M = b v L with L the tip's depth below the pivot) against the stack through its lever: the sensor's
  reading from the moment balance M + a T(o - r) + m g (y_c + z_c r / a) = 0, with and without a preload;
- pose: a rigid rotation about the pivot's axis (the pitched tool's points against the rotation matrix);
- the soil's lever about the pivot: a force's moment about a point raised by dL grows by its horizontal component
  times dL (rigid-body statics), read on two committed paper-scale runs that differ only in the shank length;
- a mount pitch: the rest pose of the tool in the air from the exact moment balance about the pivot (the spring's
  force along its line from the carriage's anchor to the seat, the weight at the turned centre of mass), solved here
  by root finding.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import warpdem as wd
from calibration.passive_study import (
    PRELOAD_TABLE3,
    beds_table,
    displacement_noise,
    passive_table,
    quasi_static_sensitivity,
    reduction_slope,
    rigid_by_speed,
    soil_levers,
)
from calibration.tool_fit import fit_joint, fit_table2
from scenes import paper
from scenes import soil_bin as sb
from scenes.assemblies import AssemblySpec, Bed
from scenes.passive_tool import BOUNDS, PassiveTool, from_dict, lever, load_toml, parse
from scenes.ringing import analytic_frequency, build_ringing, run_ringing
from scenes.sweep import build_sweep, pitch_matrix
from warpdem.errors import InputError


def test_din_tool_frequency_equals_the_ringing_rigs_own_closed_form() -> None:
    """Two closed forms written apart (the description's and scenes.ringing's) agree for the DIN tool with a
    massless load: same stiffness, gravity and inertia terms (to rounding)."""
    tool = PassiveTool()
    rig = build_ringing(tool.ringing_config())
    for k, n in enumerate(paper.SPRING_COUNTS):
        f_rig, _ = analytic_frequency(rig, tool.rate(n), float(rig.overrides["spring:spring:damping"][k]),
                                      load_mass_fraction=0.0)
        assert tool.ringing_frequency(n) == pytest.approx(f_rig, rel=1e-9)


def test_simulated_ringing_rig_rings_at_the_descriptions_closed_form(device: str) -> None:
    """warpdem's ringing rig built from a description with every tool number away from its default (rate factor,
    inertia factor, series compliance, riding load) rings at the closed form's frequency with its damping ratio.
    Tolerance 1 %: the record's fit by eqs. (3)-(5) on 2400 Hz samples and the neglected geometric stiffness of
    the preload (< 0.2 %) (measured agreement: 0.1 %)."""
    tool = PassiveTool(rate_factor=1.1, inertia_factor=0.95, series_stiffness=5e5, load_mass_fraction=0.3,
                       shank_length=0.5)
    springs = (4, 16, 32)
    res = run_ringing(tool.ringing_config(springs, ring_time=1.5), device=device, tool=tool.sweep())
    for k, n in enumerate(springs):
        assert res.frequency_hz[k] == pytest.approx(tool.ringing_frequency(n), rel=0.01), n
        assert res.damping_ratio[k] == pytest.approx(tool.zeta(n), rel=0.05), n


def _empty_bed() -> Bed:
    """One particle in a far corner of the ci bin, out of the tool's reach: a soil bin without soil."""
    size = sb.SCALES["ci"]["bin"]
    r = 0.01
    return Bed(AssemblySpec(kind="A", radius=r), size, 0.2, np.array([[0.2, 0.6, r]]), np.array([r]), np.array([0]))


@pytest.mark.parametrize("preload", [0.0, 1.5e-3])
def test_static_deflection_under_a_known_moment_matches_the_moment_balance(device: str, preload: float) -> None:
    """The passive soil-bin rig in the air (no soil), a dashpot b from a static anchor far ahead pulled at the
    carriage's speed v from the blade tip: a backward moment M = b v L about the pivot. The lab-zeroed sensor
    reading after the ring-down equals :meth:`PassiveTool.lab_reading` (small rotations: the readings stay under
    4 mm at the 0.1 m lever, theta < 0.04 rad, so the arc and the lines' tilt add < 0.5 %; tolerance 3 %, or
    0.02 mm for a reading held on the stop)."""
    tool_desc = PassiveTool(rate_factor=1.1, series_stiffness=8e5, preload=preload, inertia_factor=1.05,
                            shank_length=0.5)
    springs = [4, 32]
    speed, b = 0.25, 300.0
    sweep = tool_desc.sweep().moved(np.array([0.0, 0.3, 0.8]))  # in the air above the bin
    cfg = sb.SoilBinConfig(scale="ci", springs=tuple(springs), speed=(speed,) * 2, travel=0.2,
                           steady_travel=0.1, sample_rate=200.0, settle_time=0.1)  # the tool settles in the reading
    run = sb.run_soil_bin(cfg, springs, bed=_empty_bed(), device=device, tool=sweep, place=False,
                          knobs={"soil_viscosity": [b] * 2}, passive_tool=tool_desc)
    depth = float(sweep.pivot[2] - sweep.tip[2])
    moment = b * speed * depth
    for w, n in enumerate(springs):
        expected = tool_desc.lab_reading(n, moment, sweep)
        late = run.series["displacement"][-21:-1, w]  # the last record follows the carriage's stop
        assert np.ptp(late) < 0.01 * max(abs(expected), 1e-3), "not at rest"
        assert late.mean() == pytest.approx(expected, rel=0.03, abs=2e-5), (n, expected)
    if preload == 0.0:
        assert all(abs(tool_desc.lab_reading(n, moment, sweep)) > 5e-4 for n in springs)
    else:  # the 4-unit stack's preload (610 N at the 0.1 m lever) holds against the 37.5 N m, the 32-unit's (137 N) not
        assert abs(tool_desc.lab_reading(4, moment, sweep)) < 2e-5 < 5e-4 < tool_desc.lab_reading(32, moment, sweep)
    assert tool_desc.sweep().pivot[2] - tool_desc.sweep().tip[2] == pytest.approx(0.5)


def test_rest_reading_with_an_offset_and_a_preload_is_the_offset() -> None:
    """A preloaded stack whose seat is moved by o rests on its stop: the sensor sits at o (within the stop's
    compliance, 1 % of the preload's travel), whatever the rate."""
    tool = PassiveTool(preload=1.5e-3, support_offsets=True)
    for n in paper.SPRING_COUNTS:
        o = 1e-3 * paper.ringing_row(n)["support_offset_mm"]
        assert tool.sensor_reading(n, 0.0, offset=o) == pytest.approx(o, abs=0.02 * 1.5e-3)


def test_pitched_tool_starts_rotated_about_its_pivot(device: str) -> None:
    """Each world's tool starts turned back about the pivot axis by its pitch: the blade tip, read through the
    engine's body pose, lies where the rotation matrix puts it (to float32 mesh offsets, 1e-6 m)."""
    bed = _empty_bed()
    cfg = sb.SoilBinConfig(scale="ci", springs=(0, 0), speed=(0.5, 0.5), travel=0.01, steady_travel=0.005)
    sweep = build_sweep().moved(np.array([0.0, 0.3, 0.8]))
    pitches = [-4.0, 9.0]
    tip_point = wd.observers.body_point("sweep_lower", sweep.tip)
    tip_point(wd.Simulation(*sb.build_scene(cfg, bed, sweep, [0, 0], [0.5, 0.5], device)[:2], dt=1e-5))  # drawing pose
    model, state, _ = sb.build_scene(cfg, bed, sweep, [0, 0], [0.5, 0.5], device, pitch=np.array(pitches))
    tip = tip_point(wd.Simulation(model, state, dt=1e-5))  # the same material point on the pitched tools
    for w, angle in enumerate(pitches):
        expected = sweep.pivot + pitch_matrix(angle) @ (sweep.tip - sweep.pivot)
        assert np.allclose(tip[w], expected, atol=1e-6)
        assert np.allclose(sweep.pitched(angle).tip, expected, atol=1e-12)
    # a backward pitch moves a point below the pivot against travel
    assert tip[1, 1] < sweep.tip[1] - 0.05


def test_a_mount_pitch_turns_the_tool_but_not_its_seat_and_rests_where_the_moments_balance(device: str) -> None:
    """The sweep clamped turned back and forward by 6 deg (knob mount_pitch), in the air on 16 springs, against the
    same tool without it. At the start the clamp's seat and sensor target sit where the drawing has them (the spring
    unloaded) while the blade is turned; after the ring-down the clamp's reading (from the start) equals the exact
    moment balance about the pivot: k (|p - A| - L0) along the spring's line at the seat p turned by phi, and the
    weight m g at the centre of mass turned by the mount and phi. Tolerance 1 um on readings of ~0.1-0.3 mm (the
    record's residual ring-down after 1 s at Table 2's damping ratio 0.2 is below 1e-9 m; float32 offsets 1e-7 m)."""
    from scipy.optimize import brentq

    cfg = sb.SoilBinConfig(scale="ci", springs=(16,), speed=(0.5,), travel=0.5, steady_travel=0.4,
                           support_offset=False)
    sweep = build_sweep().moved(np.array([0.0, 0.3, 0.8]))
    mounts = (0.0, 6.0, -6.0)
    run = sb.run_soil_bin(cfg, [16, 16, 16], bed=_empty_bed(), device=device, tool=sweep, place=False,
                          knobs={"mount_pitch": list(mounts)})
    k, length, m, g = paper.ringing_row(16)["stiffness_n_per_m"], 0.1, sweep.mass, 9.81
    pivot, seat = sweep.pivot, np.asarray(sweep.sensor_point)
    anchor = seat - (0.0, length, 0.0)  # the carriage's end of the spring (it moves with the pivot)

    def moment(phi: float, turn: float) -> float:
        """Moment about +x on the tool [N m] turned by phi about +x from its start (a backward turn is -phi)."""
        rot = pitch_matrix(-math.degrees(phi))
        p = pivot + rot @ (seat - pivot)
        d = p - anchor
        force = -k * (np.linalg.norm(d) - length) * d / np.linalg.norm(d)
        c = rot @ pitch_matrix(turn) @ (sweep.com - pivot)
        weight = np.array([0.0, 0.0, -m * g])
        return float(np.cross(p - pivot, force)[0] + np.cross(c, weight)[0])

    for w, turn in enumerate(mounts):
        phi = brentq(moment, -0.2, 0.2, args=(turn,), xtol=1e-14)
        target = pivot + pitch_matrix(-math.degrees(phi)) @ (seat - pivot)
        expected = -(target[1] - seat[1])  # the reading: the clamp's motion against travel since the start
        assert run.steady[w]["displacement_mean"] == pytest.approx(expected, abs=1e-6), (w, expected)
    # turned back, the centre of mass hangs further back and its weight turns the clamp forward (a negative
    # reading); turned forward, the other way
    assert run.steady[1]["displacement_mean"] < run.steady[0]["displacement_mean"] - 5e-5
    assert run.steady[2]["displacement_mean"] > run.steady[0]["displacement_mean"] + 5e-5
    with pytest.raises(ValueError, match="mount_pitch must lie within"):
        sb.run_soil_bin(cfg, [16], bed=_empty_bed(), device=device, tool=sweep, place=False,
                        knobs={"mount_pitch": [20.0]})


def test_bounded_fit_stays_within_the_physical_ranges_and_reports_its_bounds() -> None:
    """Every fitted number lies within BOUNDS, and what sits on a bound is reported so. Bookkeeping of the fit,
    and a property of Table 2 measured by it: no tool within the bounds gives the 24-spring stack's 6.80 Hz
    (softer than the 20-spring stack, it rings 13 % higher), so at least one configuration stays outside 5 %."""
    fit = fit_table2("one rate", starts=2)
    t = fit.tool
    for name in ("rate_factor", "inertia_factor", "series_stiffness", "load_mass_fraction"):
        lo, hi = BOUNDS[name]
        v = getattr(t, name)
        assert lo * (1 - 1e-9) <= v <= hi * (1 + 1e-9), name
        on_bound = math.isclose(v, lo, rel_tol=1e-6, abs_tol=1e-9) or math.isclose(v, hi, rel_tol=1e-6)
        assert (fit.bounds[name] != "inside") == on_bound, name
    row24 = next(r for r in fit.rows if r["springs"] == 24)
    assert abs(row24["error_pct"]) > 5.0
    assert fit.within_5pct < 8


def test_the_soil_bins_own_series_compliance_acts_only_in_the_soil_bin() -> None:
    """A ringing instrument's compliance (3e5 N/m) with a soil-bin holder of none: the ringing rig's rate is
    k k_s / (k + k_s), the soil bin's stack law the bare rate (F = k u with no preload), and no series knob reaches
    the soil bin; JSON keeps "none" (inf) apart from "the ringing rig's" (None)."""
    import json

    from scenes.passive_tool import from_dict

    k_s, n = 3e5, 8
    tool = PassiveTool(series_stiffness=k_s, bin_series_stiffness=math.inf)
    k = tool.rate(n)
    sweep = tool.sweep()
    assert tool.effective_rate(n) == pytest.approx(k * k_s / (k + k_s), rel=1e-12)
    shared = PassiveTool(series_stiffness=k_s)
    assert tool.ringing_stiffness_inertia(n, sweep) == shared.ringing_stiffness_inertia(n, sweep)
    assert tool.tension(n, 1e-3) == pytest.approx(k * 1e-3, rel=1e-12)
    assert "series_stiffness" not in tool.soil_bin_knobs([n], sweep)
    assert shared.tension(n, 1e-3) == pytest.approx(k * k_s / (k + k_s) * 1e-3, rel=1e-12)
    assert shared.soil_bin_knobs([n], sweep)["series_stiffness"] == [k_s]
    for t in (tool, shared):
        assert from_dict(json.loads(json.dumps(sb.json_safe(t.to_dict())))) == t
    with pytest.raises(InputError, match="bin_series_stiffness"):
        PassiveTool(bin_series_stiffness=-1.0)


def test_the_soils_lever_about_the_pivot_moves_with_the_pivot() -> None:
    """Statics: raising the pivot by dL (a longer shank, the blade and the soil unchanged) raises the soil's moment
    about it by the draught times dL, so its lever per unit of draught grows by dL. Read on two committed runs of
    one H100 (docs/runs/passive-tool-paper-h100 and -short-shank-h100: the workflow soil, bed seed 0, the DIN +
    preload tool, shank 0.6 and 0.44 m): their levers differ by dL = 0.16 m within 0.02 m a configuration and
    0.01 m on average. The tolerance is the tool's pose: at the same sensor reading the longer shank's blade has
    moved back 0.6 / 0.44 times as far, which changes the soil's force (the pitch sweep: under 2 % over 9 deg)."""
    runs = Path(__file__).resolve().parents[1] / "docs" / "runs"
    long, shank_long = soil_levers([runs / "passive-tool-paper-h100"])
    short, shank_short = soil_levers([runs / "passive-tool-short-shank-h100"])
    d_l = shank_long - shank_short
    assert d_l == pytest.approx(0.16)
    diff = np.array([long[n] - short[n] for n in paper.SPRING_COUNTS])
    assert np.all(np.abs(diff - d_l) < 0.02)
    assert abs(float(diff.mean()) - d_l) < 0.01


def test_the_soils_lever_measured_with_one_tool_predicts_another_tools_displacement() -> None:
    """The soil's moment about the pivot per unit of draught belongs to the soil and the blade, not to the springs:
    read off the DIN + preload tool's runs on four beds (docs/runs/passive-tool-bonded-short-shank-h100*), it gives
    through the closed-form statics (:meth:`PassiveTool.lab_reading` under the run's own draught times that lever)
    the mean displacement of another tool (the joint fit's: rates 1.2x DIN, preload 0.93 mm instead of 1.44,
    inertia 1.1x) simulated on three other runs (docs/runs/passive-tool-described-h100, one H100). Tolerance 0.05 mm
    (the displacement's own standard error) + 2 % (twice the levers' largest bed-to-bed spread, 1.1 %)."""
    runs = Path(__file__).resolve().parents[1] / "docs" / "runs"
    levers, shank = soil_levers([runs / f"passive-tool-bonded-short-shank-h100{s}" for s in ("", "_s1", "_s2", "_s3")])
    for bed in ("s0", "s1", "s3"):
        data = json.loads((runs / "passive-tool-described-h100" / bed / "passive_described.json").read_text())
        tool = from_dict(data["tool"])
        assert tool.shank_length == shank and tool.preload != PRELOAD_TABLE3
        sweep = tool.sweep()
        for r in data["rows"]:
            n = int(r["springs"])
            predicted = tool.lab_reading(n, r["draught_mean"] * levers[n], sweep)
            assert abs(r["displacement_mean"] - predicted) <= 5e-5 + 0.02 * abs(predicted), (bed, n)


def test_table3_over_beds_pairs_each_bed_with_its_own_rigid_run(tmp_path) -> None:
    """Table 3 over several beds (:func:`beds_table`) against the arithmetic done here from the records: each
    reduction 100 (R - P) / R with R the rigid draught of the same bed at the passive run's speed, then the beds'
    mean and sample standard error. A folder without its rigid stage is refused by name."""
    runs = Path(__file__).resolve().parents[1] / "docs" / "runs" / "passive-tool-described-h100"
    folders = [runs / b for b in ("s0", "s1", "s3")]
    rows = beds_table(folders)
    per_bed = []
    for f in folders:
        stage = json.loads((f / "rigid.json").read_text())
        pitch = stage["pitch"] or [0.0] * len(stage["rows"])
        rigid = {round(r["speed"], 2): r["draught_mean"] for r, p in zip(stage["rows"], pitch, strict=True) if p == 0}
        passive = json.loads((f / "passive_described.json").read_text())["rows"]
        per_bed.append([100.0 * (rigid[round(r["speed"], 2)] - r["draught_mean"]) / rigid[round(r["speed"], 2)]
                        for r in passive])
    per_bed = np.array(per_bed)
    assert [r["springs"] for r in rows] == list(paper.SPRING_COUNTS)
    np.testing.assert_allclose([r["per_bed_pct"] for r in rows], per_bed.T, rtol=1e-12)
    np.testing.assert_allclose([r["reduction_pct"] for r in rows], per_bed.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose([r["reduction_se"] for r in rows], per_bed.std(axis=0, ddof=1) / math.sqrt(3),
                               rtol=1e-12)
    disp = np.array([[r["displacement_mean"] for r in json.loads((f / "passive_described.json").read_text())["rows"]]
                     for f in folders])
    np.testing.assert_allclose([r["disp_between_std_mm"] for r in rows], 1e3 * disp.std(axis=0, ddof=1), rtol=1e-9)
    one = passive_table(json.loads((folders[0] / "rigid.json").read_text()),
                        json.loads((folders[0] / "passive_described.json").read_text()))
    assert [r["disp_mm"] for r in beds_table(folders[:1])] == [r["disp_mm"] for r in one]
    # the rigid draught by speed: each bed's one rigid run at that speed, their mean and sample SE
    by_speed = {q["speed"]: q for q in rigid_by_speed(rows)}
    rig = np.array([[r["draught_mean"] for r, p in zip(st["rows"], st["pitch"] or [0.0] * len(st["rows"]),
                                                         strict=True) if p == 0 and round(r["speed"], 2) == 0.52]
                    for st in (json.loads((f / "rigid.json").read_text()) for f in folders)]).ravel()
    assert by_speed[0.52]["rigid_n"] == pytest.approx(rig.mean(), rel=1e-12)
    assert by_speed[0.52]["rigid_se_n"] == pytest.approx(rig.std(ddof=1) / math.sqrt(3), rel=1e-12)
    assert by_speed[0.68]["lab_rigid_n"] == pytest.approx((332.5 + 341.56) / 2)  # Table 3's two rows at 0.68 m/s
    lone = tmp_path / "lone"
    lone.mkdir()
    (lone / "passive_described.json").write_text((folders[0] / "passive_described.json").read_text())
    with pytest.raises(InputError, match="holds no finished rigid stage"):
        beds_table([folders[0], lone])


def test_the_reduction_against_displacement_line_is_weighted_least_squares() -> None:
    """Reference: the closed form of a weighted straight line, slope = sum w (x - xw)(y - yw) / sum w (x - xw)^2
    with xw, yw the weighted means and SE 1 / sqrt(sum w (x - xw)^2), w = 1 / se^2; on points exactly on a line the
    slope is that line's. The lab's line: ordinary least squares, slope and SE by the textbook formulas."""
    rng = np.random.default_rng(3)
    x = np.linspace(0.5, 12.0, 8)
    se = rng.uniform(0.5, 1.5, 8)
    y = 2.0 - 0.3 * x + se * rng.standard_normal(8)
    lab_x, lab_y = np.linspace(0.2, 12.5, 8), 5.0 - 0.8 * np.linspace(0.2, 12.5, 8) + rng.standard_normal(8)
    rows = [{"disp_mm": a, "reduction_pct": b, "reduction_se": c, "lab_disp_mm": d, "lab_reduction_pct": e}
            for a, b, c, d, e in zip(x, y, se, lab_x, lab_y, strict=True)]
    sl = reduction_slope(rows)
    w = 1 / se**2
    xw, yw = np.sum(w * x) / w.sum(), np.sum(w * y) / w.sum()
    sxx = np.sum(w * (x - xw) ** 2)
    assert sl["slope_pp_per_mm"] == pytest.approx(np.sum(w * (x - xw) * (y - yw)) / sxx, rel=1e-10)
    assert sl["slope_se"] == pytest.approx(1 / math.sqrt(sxx), rel=1e-10)
    dx = lab_x - lab_x.mean()
    b = np.sum(dx * (lab_y - lab_y.mean())) / np.sum(dx**2)
    resid = lab_y - lab_y.mean() - b * dx
    assert sl["lab_slope_pp_per_mm"] == pytest.approx(b, rel=1e-10)
    assert sl["lab_slope_se"] == pytest.approx(math.sqrt(np.sum(resid**2) / 6 / np.sum(dx**2)), rel=1e-10)
    exact = [{**r, "reduction_pct": 1.0 - 0.5 * r["disp_mm"]} for r in rows]
    assert reduction_slope(exact)["slope_pp_per_mm"] == pytest.approx(-0.5, rel=1e-12)


def test_joint_fit_recovers_the_tables_of_a_tool_within_its_bounds() -> None:
    """Table 2's frequencies and Table 3's displacements computed by the closed forms for a known tool (its own
    ringing compliance, a soil-bin holder without one, a preload) are fitted back to within 1e-3 of each
    tolerance, every number within BOUNDS; with one shared mount the same data are missed. This checks that the
    fit inverts its own forward model and its bookkeeping, not the physics (the closed forms are checked against
    the simulated rigs above)."""
    truth = PassiveTool(rate_factor=1.1, inertia_factor=0.95, series_stiffness=4e5, bin_series_stiffness=math.inf,
                        preload=0.8e-3, load_mass_fraction=0.2, shank_length=0.5)
    sweep = truth.sweep()
    arms = {n: 0.40 + 0.001 * i for i, n in enumerate(paper.SPRING_COUNTS)}
    draught = [330.0 + 2.0 * i for i in range(8)]
    lever_at = {n: arms[n] + truth.shank_length - 0.44 for n in paper.SPRING_COUNTS}
    targets = {"freq_hz": [truth.ringing_frequency(n, sweep) for n in paper.SPRING_COUNTS],
               "disp_m": [truth.lab_reading(n, d * lever_at[n], sweep) for n, d in zip(paper.SPRING_COUNTS, draught,
                                                                                      strict=True)],
               "draught_n": draught}
    fit = fit_joint(arms, 0.44, "per rig", starts=3, profile=(), targets=targets)
    assert fit.cost < 1e-6
    assert all(abs(r["error_pct"]) < 5e-3 for r in fit.frequency_rows)
    assert all(r["within"] == 1.0 for r in fit.displacement_rows)
    t = fit.tool
    for name in ("shank_length", "rate_factor", "inertia_factor", "preload", "load_mass_fraction"):
        lo, hi = BOUNDS[name]
        assert lo * (1 - 1e-9) - 1e-12 <= getattr(t, name) <= hi * (1 + 1e-9), name
    shared = fit_joint(arms, 0.44, "shared", starts=3, profile=(), targets=targets)
    assert shared.cost > 100 * fit.cost + 1e-3


def test_a_described_tool_of_another_shank_than_the_study_is_refused(tmp_path) -> None:
    """The rigid reference is built with the study's shank: a described tool with another shank is refused, naming
    both lengths; the same shank is taken as the variant 'described'."""
    from calibration.passive_study import PassiveStudy

    p = tmp_path / "tool.toml"
    p.write_text(PassiveTool(shank_length=0.5, preload=1e-3).to_toml())
    with pytest.raises(InputError, match="shank_length 0.5 m is not the study's --shank-length 0.44 m"):
        PassiveStudy(tmp_path / "a", scale="ci", shank_length=0.44, tool_file=p)
    study = PassiveStudy(tmp_path / "b", scale="ci", shank_length=0.5, tool_file=p)
    assert study.tool("described") == load_toml(p)
    # 'described_offsets': the same tool with Table 2's support offsets (its support_offset_mm column, per stack)
    offsets = study.tool("described_offsets")
    assert offsets == replace(load_toml(p), support_offsets=True)
    springs = list(paper.SPRING_COUNTS)
    assert offsets.offsets(springs) == [1e-3 * paper.ringing_row(n)["support_offset_mm"] for n in springs]
    assert study.tool("described").offsets(springs) == [0.0] * len(springs)


def test_description_file_round_trip_and_refusals(tmp_path) -> None:
    tool = PassiveTool(rate_factor=1.2, series_stiffness=4e5, preload=1e-3, rate_factors={8: 0.95},
                       damping_ratio={16: 0.2}, support_offsets=True)
    p = tmp_path / "tool.toml"
    p.write_text(tool.to_toml())
    assert replace(load_toml(p), source="") == tool
    with pytest.raises(InputError, match="unknown keys"):
        parse({"rate_factr": 1.0})
    with pytest.raises(InputError, match="preload"):
        PassiveTool(preload=3e-3)  # beyond the 4-unit stack's 2.1 mm service travel
    with pytest.raises(InputError, match="rate_factors names spring count 5"):
        PassiveTool(rate_factors={5: 1.0})
    with pytest.raises(InputError, match="load_mass_fraction"):
        PassiveTool(load_mass_fraction=1.5)


def test_a_pitch_per_world_is_checked() -> None:
    cfg = sb.SoilBinConfig(scale="ci", springs=(0, 0), speed=(0.5, 0.5), travel=0.01, steady_travel=0.005)
    for bad in ([1.0], [0.0, 45.0], [0.0, math.nan]):
        with pytest.raises(InputError, match="pitch needs one angle per world"):
            sb.run_soil_bin(cfg, [0, 0], bed=_empty_bed(), device="cpu", pitch=bad)


def test_soil_bin_command_refuses_a_bad_tool_file_before_claiming_its_folder(tmp_path, capsys) -> None:
    from calibration.cli import main

    bad = tmp_path / "bad.toml"
    bad.write_text("rate_factr = 1.0\n")
    for path, words in ((tmp_path / "missing.toml", "cannot be read"), (bad, "unknown keys ['rate_factr']")):
        out = tmp_path / "out"
        capsys.readouterr()
        assert main(["soil-bin", "--scale", "ci", "--device", "cpu", "--tool", str(path), "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("warpdem soil-bin: error: tool description") and words in err[0]
        assert not out.exists()
    capsys.readouterr()
    assert main(["reproduce", "--scale", "ci", "--tool", str(bad), "--out", str(tmp_path / "q")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "used by --workflow full" in err[0] and not (tmp_path / "q").exists()


def test_workflow_passive_job_runs_the_described_tool(tmp_path) -> None:
    """The full workflow's Table 3 passive job with a described tool is the soil-bin run with that tool: the same
    records to the bit as ``run_soil_bin(passive_tool=...)`` on the job's bed (CPU runs are deterministic), the
    offsets of an "offset" job applied, the displacement zeroed at rest. Bookkeeping of the wiring: the tool's
    physics is checked against closed forms above."""
    from calibration.paper_workflow import Budget, Workflow
    from calibration.workflow_config import WorkflowConfig

    desc = PassiveTool(preload=1e-3, shank_length=0.5)
    cfg = WorkflowConfig(scale="ci", assembly="A", springs=(16, 32), replicas_min=1, replicas_max=1, settle_time=0.0,
                         travel=0.12, steady_travel=0.06, passive_tool=desc.to_dict())
    wf = Workflow(tmp_path / "wf", cfg, device="cpu", log=lambda m: None)
    soil = {"friction_angle": 30.0, "normal_cohesion": 1000.0, "eta_roll": 0.01}
    job = {"name": "r0_offset_0", "kind": "offset", "replica": 0, "springs": [16, 32], "speeds": [0.68, 0.52]}
    out = wf.run_job(job, soil, None, Budget(None))
    bed = sb.bed_for(sb.SoilBinConfig(scale="ci", assembly="A", seed=0), cache_dir=tmp_path / "wf" / "beds")
    n = 2
    run = sb.run_soil_bin(
        sb.SoilBinConfig(scale="ci", assembly="A", springs=(16, 32), speed=(0.68, 0.52), travel=0.12,
                         steady_travel=0.06), [16, 32], bed=bed, device="cpu", speeds=[0.68, 0.52],
        soil_overrides={"friction_angle": [30.0] * n, "normal_cohesion": [1000.0] * n, "shear_cohesion": [500.0] * n,
                        "eta_roll": [0.01] * n, "eta_twist": [0.01] * n},
        tool=sb.place_tool(bed, paper.WORKING_DEPTH, desc.sweep()), place=False,
        passive_tool=replace(desc, support_offsets=True))
    assert [r["draught_mean"] for r in out["rows"]] == [r["draught_mean"] for r in run.steady]
    assert [r["displacement_mean"] for r in out["rows"]] == [r["displacement_mean"] for r in run.steady]
    assert out["tool_tip_z"] == pytest.approx(float(sb.place_tool(bed, paper.WORKING_DEPTH, desc.sweep()).tip[2]))


def test_displacement_noise_reads_the_slow_draught_through_the_closed_form_sensitivity() -> None:
    """The quasi-static sensitivity against its closed form in the stack's linear range, arm a / (k a^2 + K_g); and
    the draught's fluctuation below the tool's natural frequency against a synthetic record of known parts: a 2 Hz
    swing of 20 N (below f_n = 8 Hz for 16 springs: kept) and a 60 Hz one of 50 N (filtered out), each over whole
    cycles of the steady window, so their stds are amplitude / sqrt(2)."""
    tool = PassiveTool(preload=PRELOAD_TABLE3, shank_length=0.44)
    sweep = tool.sweep()
    a, n, draught, arm = lever(sweep), 16, 330.0, 0.39  # stack force ~1.3 kN, past the 0.25 kN preload: linear
    closed = arm * a / (tool.effective_rate(n) * a**2 + tool.tool_gravity_stiffness(sweep))
    assert quasi_static_sensitivity(tool, n, draught, arm) == pytest.approx(closed, rel=1e-6)

    fs, speed = 500.0, 0.5
    t = np.arange(0.0, 3.0, 1.0 / fs)
    travel = np.minimum(t * speed, 1.2)[:, None]  # the carriage stops at 2.4 s; the window is 0.4-2.4 s
    f = draught + 20.0 * np.sin(2 * np.pi * 2.0 * t) + 50.0 * np.sin(2 * np.pi * 60.0 * t)
    series = {"time": t, "travel": travel, "draught": f[:, None], "displacement": np.zeros((len(t), 1))}
    rows = [{"springs": n, "passive_n": draught, "arm_m": arm, "lab_arm_m": arm}]
    q = displacement_noise(series, rows, tool, steady_travel=0.2)[0]
    assert q["f_n"] == pytest.approx(tool.ringing_frequency(n, load_force=0.0))
    assert 2.0 < q["f_n"] < 60.0
    assert q["draught_std"] == pytest.approx(math.hypot(20.0, 50.0) / math.sqrt(2), rel=0.01)
    assert q["draught_slow_std"] == pytest.approx(20.0 / math.sqrt(2), rel=0.02)
    assert q["predicted_std_mm"] == pytest.approx(1e3 * closed * 20.0 / math.sqrt(2), rel=0.02)


def test_the_full_workflow_takes_the_joint_tool_unless_told_or_continuing_a_ringing_folder(tmp_path,
                                                                                             full_workflow_start
                                                                                             ) -> None:
    """`reproduce --workflow full`: Table 3's passive jobs take the packaged tool (the committed joint fit's
    tool_joint.toml, number for number) by default; `--tool ringing` the ringing calibration's springs (None); a
    folder whose workflow.json has no described tool (made before this default) goes on with its springs."""
    from scenes.passive_tool import JOINT_TOOL_FILE, joint_tool

    committed = load_toml(Path(__file__).resolve().parents[1] / "docs" / "runs" / "passive-tool-joint-fit" /
                          "tool_joint.toml")
    assert replace(load_toml(JOINT_TOOL_FILE), source="") == replace(committed, source="")
    seen = [full_workflow_start(tmp_path / "new").passive_tool,
            full_workflow_start(tmp_path / "ringing", "--tool", "ringing").passive_tool]
    old = tmp_path / "old"
    seen.append(full_workflow_start(old, "--tool", "ringing").passive_tool)
    claim = json.loads((old / ".warpdem-run.json").read_text())
    (old / ".warpdem-run.json").write_text(json.dumps({**claim, "tool": None}))  # as written before the default
    seen.append(full_workflow_start(old).passive_tool)
    assert seen == [joint_tool().to_dict(), None, None, None]
    assert seen[0]["source"] == "scenes/data/passive_tool_joint.toml"


def test_table3_over_beds_says_whether_the_draught_is_steady_in_its_window(tmp_path) -> None:
    """`--beds-from` fits where the records' draught is heading (scenes.analysis.plateau_fit, checked against a
    closed form in tests/test_analysis.py) over every world of every bed: its window mean is the mean over the runs of
    each run's 5 cm bins from 0.5 m, done here by hand from the records. In the GA-calibrated soil (six beds, 84
    worlds) the window lies more than 1 % below the plateau and the report says the window starts too early."""
    from calibration.passive_study import write_beds

    runs = Path(__file__).resolve().parents[1] / "docs" / "runs" / "passive-tool-calibrated-soil-h100x4"
    folders = [runs / f"s{b}" for b in (0, 1, 2, 3, 4, 7)]
    write_beds(tmp_path, folders)
    fit = json.loads((tmp_path / "beds.json").read_text())["draught_plateau"]
    edges = np.arange(0.3, 1.0 + 1e-12, 0.05)
    bins = []
    for f in folders:
        for name in ("rigid", "passive_described"):
            with np.load(f / f"{name}.npz") as rec:
                for w in range(rec["travel"].shape[1]):
                    x, y = rec["travel"][:, w], rec["draught"][:, w]
                    bins.append([y[(x >= a) & (x < b)].mean() for a, b in zip(edges[:-1], edges[1:], strict=True)])
    centre = 0.5 * (edges[:-1] + edges[1:])
    assert fit["n_worlds"] == len(bins) == 84
    assert fit["window_mean"] == pytest.approx(np.mean(np.array(bins)[:, centre >= 0.5]), rel=1e-12)
    assert fit["window_mean"] < 0.99 * fit["plateau"]
    assert "the window starts before the approach has ended" in (tmp_path / "beds.md").read_text()


def test_one_tool_against_another_is_paired_on_the_beds_holding_both(tmp_path) -> None:
    """The support offsets' change (:func:`paired_changes`) against the arithmetic done here from the records of
    two committed beds that ran both tools (docs/runs/passive-tool-described-h100/s9, s10): per bed and configuration
    100 (P_offsets / P_none - 1) and 1e3 (x_offsets - x_none), then the beds' mean and sample standard error, and
    over all pairs. A folder without the other tool's run is left out and named; with none holding both, refused."""
    from calibration.passive_study import paired_changes

    runs = Path(__file__).resolve().parents[1] / "docs" / "runs" / "passive-tool-described-h100"
    folders = [runs / "s9", runs / "s10"]
    lone = tmp_path / "lone"
    lone.mkdir()
    (lone / "passive_described_offsets.json").write_text((folders[0] / "passive_described_offsets.json").read_text())
    p = paired_changes([*folders, lone], "described_offsets", "described")
    assert p["folders"] == [str(f) for f in folders] and p["left_out"] == [str(lone)]
    rec = [[json.loads((f / f"passive_{v}.json").read_text())["rows"] for v in ("described_offsets", "described")]
           for f in folders]
    drag = np.array([[100 * (a["draught_mean"] / b["draught_mean"] - 1) for a, b in zip(x, y, strict=True)]
                     for x, y in rec])
    disp = np.array([[1e3 * (a["displacement_mean"] - b["displacement_mean"]) for a, b in zip(x, y, strict=True)]
                     for x, y in rec])
    np.testing.assert_allclose([r["draught_change_mean"] for r in p["rows"]], drag.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose([r["draught_change_se"] for r in p["rows"]], drag.std(axis=0, ddof=1) / math.sqrt(2),
                               rtol=1e-12)
    np.testing.assert_allclose([r["disp_change_mean"] for r in p["rows"]], disp.mean(axis=0), rtol=1e-12)
    assert p["draught_change_all"][0] == pytest.approx(drag.mean(), rel=1e-12)
    assert p["disp_change_all"][1] == pytest.approx(disp.std(ddof=1) / math.sqrt(16), rel=1e-12)
    with pytest.raises(InputError, match="no folder holds both"):
        paired_changes([lone], "described_offsets", "described")
