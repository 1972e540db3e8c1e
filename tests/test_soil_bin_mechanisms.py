"""Soil-bin mechanisms (issue #39, item 3): the stacks' load line and the sensor's lever, the soil-steel contact,
the bonds' strength and rule (fragile or yielding) and the bed's density.

References: the moment balance about the pivot (closed form) for the DEM's equivalent spring, and an independent
quasi-static model of the passive tool in soil (written here, not warpdem's DEM) that carries a hidden geometry the
rig model's baseline lacks. The diagnosis on that model's data is an inverse of a forward model the test also
writes, so it shows that the search, its bounds and the knob's wiring work together; the physics of the equivalence
is the closed-form test's.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import DEVICE, quasi_static_bin

from calibration import diagnosis
from calibration import mechanisms as mech
from calibration.measured import Measured
from calibration.rig_models import SoilBinRigModel, lever_scaling
from scenes import paper
from scenes.passive_tool import DISC_OUTER_RADIUS, SENSOR_MOUNT_TOLERANCE

A = 0.1
"""the DEM's lever of the spring and the sensor about the pivot [m] (the paper's sensor lever)."""
H = 0.25
"""depth of the draught's line of action below the pivot [m] in the quasi-static model."""


def test_a_spring_at_the_sensor_lever_turns_like_the_stack_at_its_own() -> None:
    """Closed form: a stack of rate k, dashpot c, cubic term k3 and preload p at lever lam a, against the DEM's
    spring at a with lever_scaling's factors: the same moment about the pivot at every rotation and rate, and the
    same threshold moment at which the tool leaves its stop."""
    k, c, k3, p = 1.87e5, 350.0, 4e10, 0.8e-3
    for lam in (0.875, 1.0, 1.125):
        f = lever_scaling(lam)
        for theta, omega in ((1e-3, 0.0), (0.02, 0.3), (-0.01, -1.0)):
            u = lam * A * theta  # the stack's compression at its own lever
            true = lam * A * (k * u + k3 * u**3 + c * lam * A * omega)
            v = A * theta
            dem = A * (k * f["stiffness"] * v + k3 * f["progressive"] * v**3 + c * f["dashpot"] * A * omega)
            assert dem == pytest.approx(true, rel=1e-12)
        assert k * f["stiffness"] * p * f["stack_preload"] * A == pytest.approx(k * p * lam * A, rel=1e-12)
    with pytest.raises(ValueError, match="spring_lever must be a positive ratio, got -1"):
        lever_scaling(-1.0)


def _quasi_static(seat: float, sensor: float):  # noqa: ANN202
    """A soil bin whose passive tool is held by a stack bearing at ``seat`` x A and read at ``sensor`` x A: the draught
    F = 300 N (1 - reduction) at the lever H turns it by F H / (k (seat A)^2) (moment balance, small angles); the
    reduction grows by 0.2 points per spring. What the rig model runs (the DEM's geometry: seat = sensor = 1) is this
    with the knobs the model passes (its stiffness already scaled by spring_lever)."""

    def run(config, springs, speeds, knobs, soil):  # noqa: ANN001, ANN202
        draught = [300.0 * (1 - (0.002 * n if n else 0.0)) for n in springs]
        stiffness = [float(knobs["stiffness"][w]) if n else math.inf for w, n in enumerate(springs)]
        # theta = F H / (k (seat A)^2), read at sensor A: x = F (H sensor / (seat^2 A)) / k
        return quasi_static_bin(springs, speeds, draught, stiffness, arm_ratio=H * sensor / (seat**2 * A))

    return run


def _measured(seat: float, sensor: float, seed: int) -> Measured:
    """Table 3's configurations with the DIN rates, displacements of the quasi-static tool (1-8 mm) with 0.02 mm of
    noise."""
    springs = np.array(paper.SPRING_COUNTS)
    k = np.array([paper.ringing_row(int(n))["stiffness_n_per_m"] for n in springs])
    speeds = np.full(len(springs), 0.62)
    run = _quasi_static(seat, sensor)(None, list(springs), list(speeds), {"stiffness": list(k)}, None)
    x = np.array([r["displacement_mean"] for r in run.steady])
    rng = np.random.default_rng(seed)
    return Measured({"springs": springs.astype(float), "speed": speeds, "stiffness": k,
                     "displacement_mean": x + 2e-5 * rng.standard_normal(len(x))}, {})


def test_the_lever_mechanisms_are_bounded_by_the_rig() -> None:
    """The stated geometry bounds them: the seat within the 25 mm discs' radius of the stack's axis at the 100 mm
    lever (0.875-1.125), the sensor within its assumed 10 mm (0.9-1.1)."""
    rig = SoilBinRigModel(_measured(1.0, 1.0, 0), simulator=_quasi_static(1.0, 1.0))
    facts = rig.facts()
    assert facts.lever == pytest.approx(A, rel=0.05)
    lever = mech.get("lever_geometry").physical(facts)["spring_lever"]
    sensor = mech.get("sensor_lever").physical(facts)["sensor_lever"]
    assert (lever.low, lever.high) == pytest.approx((1 - DISC_OUTER_RADIUS / facts.lever,
                                                     1 + DISC_OUTER_RADIUS / facts.lever))
    assert (sensor.low, sensor.high) == pytest.approx((1 - SENSOR_MOUNT_TOLERANCE / facts.lever,
                                                       1 + SENSOR_MOUNT_TOLERANCE / facts.lever))
    assert "DIN 2093" in lever.source and "assumption" in sensor.source


def test_a_stack_seated_off_the_sensor_lever_is_named_and_the_sensor_at_its_bound_is_not() -> None:
    """Hidden: the stacks bear at 0.9 x the sensor's lever (every deflection 1 / 0.81 = 1.23 x the stated
    geometry's). lever_geometry explains it inside its bound (0.875-1.125); a sensor lever would need 1.23, beyond
    its 1.1 bound, so it is not named. The fitted ratio: within 1 % (0.02 mm of noise on eight displacements of
    1-8 mm fixes the factor 1 / lambda^2 to ~0.1 %)."""
    data = _measured(0.9, 1.0, seed=2)
    rig = SoilBinRigModel(data, simulator=_quasi_static(1.0, 1.0), uncertainty={"displacement_mean": 2e-5})
    settings = diagnosis.DiagnosisSettings(rounds=4, mechanisms=("lever_geometry", "sensor_lever", "sensor_offset",
                                                                 "stack_preload"))
    d = diagnosis.diagnose(rig, settings)
    assert d.cause == ("lever_geometry",), (d.verdict, d.cause, d.at_bound)
    fit = d.fits["lever_geometry"]
    assert fit.candidate.values(fit.z_all)["spring_lever"] == pytest.approx(0.9, rel=0.01)
    bound = [b for b in d.at_bound if b["mechanism"] == "sensor_lever"]
    assert bound and bound[0]["side"] == "high", d.at_bound
    assert bound[0]["value"] == pytest.approx(1 + SENSOR_MOUNT_TOLERANCE / rig.facts().lever, rel=1e-3)


SHARED_OFF = {"tool_adhesion": 0.0, "tool_friction": 20.0, "soil_cohesion_scale": 1.0}
"""the scene's values of the knobs the rigid runs share (a soil of 20 deg on 40 deg steel, no adhesion, the soil's
own bonds)."""


def _tool_bin(seen: list[tuple], scale: object, beds: list[tuple] | None = None) -> object:
    """A quasi-static soil bin (``conftest.quasi_static_bin``, a simulator for SoilBinRigModel) whose draught is
    300 N x scale(k) less 0.2 % per spring, k the world's values of the shared knobs (:data:`SHARED_OFF` where a run
    has none) and its config's ``deposit_friction``, ``settle_time`` and ``fragile`` (one of each a simulation), the
    displacement following the draught through the stack's rate; it notes each world's (springs, adhesion, angle,
    cohesion scale) in ``seen`` and each simulation's (bed friction, settling time, springs) in ``beds`` (and its
    fragile flag after them where it is not the default's)."""

    def run(config, springs, speeds, knobs, soil):  # noqa: ANN001, ANN202
        assert not {"deposit_friction", "settle_time", "fragile"} & set(knobs or {})  # the config's, not a world's
        assert isinstance(config.fragile, bool)
        if beds is not None:
            beds.append((config.deposit_friction, config.settle_time, tuple(springs))
                        + (() if config.fragile else (False,)))
        draught = []
        for w, n in enumerate(springs):
            k = {name: float((knobs or {}).get(name, [off] * len(springs))[w]) for name, off in SHARED_OFF.items()}
            k["deposit_friction"], k["settle_time"] = config.deposit_friction, config.settle_time
            k["fragile"] = float(config.fragile)
            seen.append((n, k["tool_adhesion"], k["tool_friction"], k["soil_cohesion_scale"]))
            draught.append(300.0 * scale(k) * (1 - (0.002 * n if n else 0.0)))
        stiffness = [float(knobs["stiffness"][w]) if n else math.inf for w, n in enumerate(springs)]
        return quasi_static_bin(springs, speeds, draught, stiffness, arm_ratio=H / A)

    return run


def test_the_soil_steel_friction_knob_reaches_the_rigid_and_the_passive_runs() -> None:
    """Reference: a quasi-static soil bin (written here, ``_tool_bin``) whose draught is 300 N (1 + tan(delta)) less
    0.2 % per spring, delta the soil-steel friction angle the runs get (the scene's 20 deg without the knob: a soil
    of 20 deg on 40 deg steel): with tool_friction the rigid reference runs at the same angle, so the reduction
    stays the spring count's alone (0.2 % per spring) while the displacement follows the draught; the knob's bound
    comes from the laboratory's internal friction angle (Potyondy's ratios)."""
    seen: list[tuple] = []
    run = _tool_bin(seen, lambda k: 1 + math.tan(math.radians(k["tool_friction"])))
    from calibration.rig_models import Case

    m = _measured(1.0, 1.0, 0)
    data = Measured({**m.summary, "reduction": np.zeros(len(m.summary["springs"]))}, {})
    rig = SoilBinRigModel(data, simulator=run, observables=("reduction", "displacement_mean"),
                          soil={"friction_angle": 20.0})  # the scene's soil-steel angle without the knob: 20 deg
    base, rough = rig.simulate([Case(3, {}), Case(3, {"tool_friction": 30.0})]).values
    assert {d for n, _, d, _ in seen if n == 0} == {20.0, 30.0}  # a rigid run at each angle
    assert {d for n, _, d, _ in seen if n == 16} == {20.0, 30.0}  # a case without the knob keeps the scene's angle
    assert base[0] == pytest.approx(rough[0]) == pytest.approx(100 * 0.002 * 16)  # springs 16: 3.2 %
    ratio = (1 + math.tan(math.radians(30.0))) / (1 + math.tan(math.radians(20.0)))
    assert rough[1] / base[1] == pytest.approx(ratio)
    bound = mech.get("soil_tool_friction").physical(rig.facts())["tool_friction"]
    assert (bound.low, bound.high) == pytest.approx((0.5 * 32.3, 32.3)) and "Potyondy" in bound.source


def test_the_soil_steel_adhesion_and_bond_strength_knobs_reach_the_rigid_and_the_passive_runs() -> None:
    """Reference: a quasi-static soil bin (written here, ``_tool_bin``) whose draught is 300 N (1 + Ca / 10 kPa)
    less 0.2 % per spring, Ca the soil-steel adhesion the runs get (0 without the knob): with tool_adhesion the
    rigid reference runs with the same adhesion, so the reduction stays the spring count's alone while the draught
    and the displacement follow the adhesion; together with tool_friction the rigid run gets both. The knob's bound
    is the soil's own contact cohesion (no interface stronger than the soil), here the ``soil`` given to the rig
    model. The soil's bond strength (soil_cohesion_scale, the draught in proportion) reaches both alike, its bound
    the shear box's 25 % tolerance on c taken onto the contact cohesion."""
    seen: list[tuple] = []
    run = _tool_bin(seen, lambda k: (1 + k["tool_adhesion"] / 1e4) * k["soil_cohesion_scale"])
    from calibration.rig_models import Case

    m = _measured(1.0, 1.0, 0)
    data = Measured({**m.summary, "reduction": np.zeros(len(m.summary["springs"]))}, {})
    rig = SoilBinRigModel(data, simulator=run, observables=("reduction", "displacement_mean"),
                          soil={"friction_angle": 20.0, "normal_cohesion": 3e4})
    base, sticky, both = rig.simulate([Case(3, {}), Case(3, {"tool_adhesion": 5e3}),
                                       Case(3, {"tool_adhesion": 5e3, "tool_friction": 30.0})]).values
    assert {(ca, d) for n, ca, d, _ in seen if n == 0} == {(0.0, 20.0), (5e3, 20.0), (5e3, 30.0)}  # a rigid run each
    assert {ca for n, ca, _, _ in seen if n == 16} == {0.0, 5e3}  # a case without the knob has no adhesion
    assert base[0] == pytest.approx(sticky[0]) == pytest.approx(both[0]) == pytest.approx(100 * 0.002 * 16)
    assert sticky[1] / base[1] == pytest.approx(1.5)
    bound = mech.get("soil_tool_adhesion").physical(rig.facts())["tool_adhesion"]
    assert (bound.low, bound.high) == pytest.approx((10.0, 3e4)) and "soil's own contact cohesion" in bound.source
    # the soil's bond strength: the same, and its bound the shear box's tolerance on c taken onto the bonds
    strong = rig.simulate([Case(3, {"soil_cohesion_scale": 1.2})]).values[0]
    assert (0.0, 20.0, 1.2) in {(ca, d, c) for n, ca, d, c in seen if n == 0}
    assert strong[0] == pytest.approx(base[0]) and strong[1] / base[1] == pytest.approx(1.2)
    bound = mech.get("soil_bond_strength").physical(rig.facts())["soil_cohesion_scale"]
    assert (bound.low, bound.high) == pytest.approx((0.75, 1.25)) and "shear box's tolerance" in bound.source


def test_a_rows_own_standard_error_weighs_it_in_the_fit() -> None:
    """Reference: weighted least squares in closed form. Quasi-static data (written here) read 0.3 mm low at every
    spring count, and the 4-spring row is 1 mm off besides but says so: its ``displacement_mean_se`` is 2 mm
    against 0.02 mm for the others. A sensor offset, which shifts every reading alike, is then the weighted mean of
    the residuals, sum(r / s^2) / sum(1 / s^2) with s the rig's sigma (the row's SE and the runs' SEM in quadrature):
    -0.3 mm within the noise, where equal weights would be pulled 0.125 mm towards the bad row. A caller's
    ``uncertainty`` replaces the column."""
    data = _measured(1.0, 1.0, seed=5)
    x = data.summary["displacement_mean"]
    x += -3e-4 + np.where(data.summary["springs"] == 4, 1e-3, 0.0)
    data.summary["displacement_mean_se"] = np.where(data.summary["springs"] == 4, 2e-3, 2e-5)
    rig = SoilBinRigModel(data, simulator=_quasi_static(1.0, 1.0))
    assert rig.row_se == ("displacement_mean",)
    np.testing.assert_array_equal(rig.stated_sigma[:, 0], data.summary["displacement_mean_se"])
    d = diagnosis.diagnose(rig, diagnosis.DiagnosisSettings(rounds=3, mechanisms=("sensor_offset",)))
    fit = d.fits["sensor_offset"]
    offset = fit.candidate.values(fit.z_all)["sensor_offset"]
    model = np.array([r["displacement_mean"] for r in _quasi_static(1.0, 1.0)(
        None, [c["springs"] for c in rig.configs], [c["speed"] for c in rig.configs],
        {"stiffness": [c["stiffness"] for c in rig.configs]}, None).steady])
    w = 1.0 / rig.sigma[:, 0] ** 2
    expected = float(np.sum(w * (x - model)) / np.sum(w))
    assert offset == pytest.approx(expected, abs=2e-6)
    assert offset == pytest.approx(-3e-4, abs=3e-5)
    equal = SoilBinRigModel(data, simulator=_quasi_static(1.0, 1.0), uncertainty={"displacement_mean": 2e-5})
    assert equal.row_se == () and np.all(equal.stated_sigma == 2e-5)


def test_realizations_are_averaged_with_the_larger_standard_error() -> None:
    """Reference: numpy's mean and standard deviation of what an independent model (written here) returns for each
    world. The rig model given three realizations runs every case three times (consecutive worlds) and takes each
    observable's mean, and as its standard error the larger of the realizations' scatter, std(ddof=1) / sqrt(3),
    and their own SEs combined, sqrt(sum sem^2) / 3: here the scatter's for the displacement (0.1 mm noise, own SE
    1e-5 m) and the own SE's for the draught (no scatter, own SE 0.5 N each)."""
    rng = np.random.default_rng(11)
    seen: list[np.ndarray] = []

    def run(config, springs, speeds, knobs, soil):  # noqa: ANN001, ANN202
        out = _quasi_static(1.0, 1.0)(config, springs, speeds, knobs, soil)
        noise = 1e-4 * rng.standard_normal(len(springs)) * np.array([n != 0 for n in springs])
        for row, e in zip(out.steady, noise, strict=True):
            row["displacement_mean"] += e
        seen.append(np.array([r["displacement_mean"] for r in out.steady]))
        return out

    data = _measured(1.0, 1.0, seed=1)
    data.summary["draught_mean"] = np.full(len(data.summary["springs"]), 250.0)
    rig = SoilBinRigModel(data, simulator=run, bed=["a", "b", "c"], observables=("draught_mean", "displacement_mean"))
    assert rig.realizations == 3
    from calibration.rig_models import Case

    cases = [Case(j, {}) for j in range(rig.n_configs)]
    values = rig.simulate(cases).values
    sem = rig.simulate(cases, _sem=True).values
    passive = seen[-1].reshape(rig.n_configs, 3)  # the passive simulation (after the rigid one), realization-minor
    np.testing.assert_allclose(values[:, 1], passive.mean(axis=1), rtol=1e-12)
    np.testing.assert_allclose(sem[:, 1], np.maximum(passive.std(axis=1, ddof=1) / math.sqrt(3),
                                                     math.sqrt(3) * 1e-5 / 3), rtol=1e-12)
    np.testing.assert_allclose(sem[:, 0], math.sqrt(3) * 0.5 / 3, rtol=1e-12)
    f = 300.0 * (1 - 0.002 * data.summary["springs"])
    np.testing.assert_allclose(values[:, 0], f, rtol=1e-12)


def test_the_pivot_friction_is_bounded_by_the_springs_moment_at_work() -> None:
    """Reference: the moment balance at the measured mean deflection x (at the sensor, where the DEM's spring is):
    the springs' moment k x a must exceed a Coulomb friction torque for a tool pushed back by the soil to swing
    forward again, so the bound is the smallest k x a over the configurations (in this quasi-static model k x a is
    the draught's moment F H, smallest at 32 springs: 280.8 N x 0.25 m = 70.2 N m, noise aside)."""
    data = _measured(1.0, 1.0, 0)
    rig = SoilBinRigModel(data, simulator=_quasi_static(1.0, 1.0))
    facts = rig.facts()
    bound = mech.get("pivot_friction").physical(facts)["pivot_friction"]
    k, x = data.summary["stiffness"], data.summary["displacement_mean"]
    assert bound.high == pytest.approx(float(np.min(k * np.abs(x) * facts.lever)), rel=1e-12)
    assert bound.high == pytest.approx(300.0 * (1 - 0.002 * 32) * H, rel=0.01)
    assert bound.low == pytest.approx(1e-3) and "moment" in bound.source


def test_the_bed_and_bond_protocol_knobs_run_rigid_and_passive_on_their_own_bed() -> None:
    """Reference: a quasi-static soil bin (written here) whose draught is 300 N (1 + (30 deg - phi_d) / 100 deg)
    (1 + t_s / 2 s) less 0.2 % per spring, phi_d the contact friction its bed was deposited with and t_s the time it
    settled before its bonds were set (the config each simulation gets): with deposit_friction or settle_time the
    rigid reference runs on the same bed and protocol as its passive case, so the reduction stays the spring
    count's alone (0.2 % per spring) while the draught and the displacement follow the bed; a simulation never mixes
    two (its worlds share one config); a case without the knobs runs on the config's. With a bed given to the rig
    model (a twin's export) it cannot deposit or settle another, and the mechanisms are not offered."""
    from calibration.rig_models import Case

    calls: list[tuple[float, float, tuple[int, ...]]] = []
    run = _tool_bin([], lambda k: (1 + (30.0 - k["deposit_friction"]) / 100.0) * (1 + k["settle_time"] / 2.0), calls)

    m = _measured(1.0, 1.0, 0)
    data = Measured({**m.summary, "reduction": np.zeros(len(m.summary["springs"]))}, {})
    rig = SoilBinRigModel(data, simulator=run, observables=("reduction", "displacement_mean"))
    base, dense, denser, settled = rig.simulate([
        Case(3, {}), Case(3, {"deposit_friction": 10.0}), Case(5, {"deposit_friction": 0.0}),
        Case(3, {"settle_time": 1.0})]).values
    assert {(f, t) for f, t, springs in calls if springs == (0,)} == {(30.0, 0.0), (10.0, 0.0), (0.0, 0.0),
                                                                      (30.0, 1.0)}  # a rigid run on each
    assert {c for c in calls if c[2] != (0,)} == {(30.0, 0.0, (16,)), (10.0, 0.0, (16,)), (0.0, 0.0, (24,)),
                                                 (30.0, 1.0, (16,))}
    for red in (base, dense, settled):  # springs 16: 3.2 %
        assert red[0] == pytest.approx(100 * 0.002 * 16)
    assert denser[0] == pytest.approx(100 * 0.002 * 24)
    assert dense[1] / base[1] == pytest.approx(1.2 / 1.0)
    assert settled[1] / base[1] == pytest.approx(1.5 / 1.0)
    offered = {x.name for x in diagnosis.mechanisms_for(rig, diagnosis.DiagnosisSettings())}
    assert {"bed_density", "bond_settling"} <= offered
    given = SoilBinRigModel(data, simulator=run, observables=("reduction", "displacement_mean"), bed=object())
    assert not {"bed_density", "bond_settling"} & {
        x.name for x in diagnosis.mechanisms_for(given, diagnosis.DiagnosisSettings())}
    with pytest.raises(ValueError, match="needs knobs"):
        diagnosis.candidates_for(given, diagnosis.DiagnosisSettings(mechanisms=("bed_density",)))


def test_a_bed_deposited_denser_for_the_knob_draws_more() -> None:
    """Reference: a granular bed packed denser has more contacts per particle and must dilate more to shear, so the
    rigid blade draws more. The rig model's deposit_friction knob deposits the ``ci`` bed again without contact
    friction: its porosity falls by more than 0.03, and its rigid draught rises by more than two standard errors of
    the difference. Measured on this project's CPU: porosity 0.425 -> 0.347, draught 154.7 +- 13.9 -> 382.9 +- 77.5
    N at 0.6 m/s (the depositions about 25 s)."""
    rig = SoilBinRigModel(_measured(1.0, 1.0, 0), scale="ci", assembly="A", travel=0.2, steady_travel=0.1,
                          device=DEVICE)
    assert rig.bed(0.0).porosity < rig.bed().porosity - 0.03
    loose, loose_se = rig.rigid_reference(0.6)
    dense, dense_se = rig.rigid_reference(0.6, None, {"deposit_friction": 0.0})
    assert dense > loose + 2 * math.hypot(loose_se, dense_se), (loose, loose_se, dense, dense_se)


def test_yielding_bonds_are_a_discrete_alternative_named_where_the_data_ask_for_it() -> None:
    """Reference: a quasi-static soil bin (written here, ``_tool_bin``) whose soil draws 300 N less 0.2 % per spring,
    1.4 x that where its bonds yield (the config's ``fragile`` False) and x the bond-strength knob. The knob
    ``fragile`` is the simulation's config (a bool, rigid reference alike), so the reduction stays the spring
    count's while the displacement follows the draught. The mechanisms are offered where they change the rig
    (yielding_bonds on a fragile soil, fragile_bonds on a yielding one). On displacements measured from the yielding
    soil (0.02 mm of noise on 1-10 mm) the diagnosis of the fragile rig names yielding_bonds: a choice without a
    gene, counted as one degree of freedom (its chi^2 falls by thousands), while the bond strength, bounded to
    0.75-1.25 x (the shear box's tolerance), cannot give 1.4 and ends at its bound. On the fragile soil's own
    displacements it names nothing."""
    from dataclasses import replace

    from calibration.rig_models import Case

    calls: list[tuple] = []
    run = _tool_bin([], lambda k: (1.4 - 0.4 * k["fragile"]) * k["soil_cohesion_scale"], calls)
    m = _measured(1.0, 1.0, 0)
    data = Measured({**m.summary, "reduction": np.zeros(len(m.summary["springs"]))}, {})
    rig = SoilBinRigModel(data, simulator=run, observables=("reduction", "displacement_mean"))
    base, yielding = rig.simulate([Case(3, {}), Case(3, {"fragile": 0.0})]).values
    assert (30.0, 0.0, (0,), False) in calls and (30.0, 0.0, (16,), False) in calls  # rigid and passive, yielding
    assert base[0] == pytest.approx(yielding[0]) == pytest.approx(100 * 0.002 * 16)
    assert yielding[1] / base[1] == pytest.approx(1.4)
    offered = {x.name for x in diagnosis.mechanisms_for(rig, diagnosis.DiagnosisSettings())}
    assert "yielding_bonds" in offered and "fragile_bonds" not in offered
    other = SoilBinRigModel(data, simulator=run, observables=("reduction", "displacement_mean"), fragile=False)
    offered = {x.name for x in diagnosis.mechanisms_for(other, diagnosis.DiagnosisSettings())}
    assert "fragile_bonds" in offered and "yielding_bonds" not in offered
    with pytest.raises(ValueError, match="changes nothing"):
        diagnosis.candidates_for(other, diagnosis.DiagnosisSettings(mechanisms=("yielding_bonds",)))

    springs = [int(n) for n in m.summary["springs"]]
    rng = np.random.default_rng(3)
    settings = diagnosis.DiagnosisSettings(rounds=3, mechanisms=("yielding_bonds", "soil_bond_strength"))
    for fragile, named in ((False, ("yielding_bonds",)), (True, ())):
        soil = run(replace(rig.config, fragile=fragile), springs, list(m.summary["speed"]),
                   {"stiffness": list(m.summary["stiffness"])}, None)
        x = np.array([r["displacement_mean"] for r in soil.steady])
        measured = Measured({**m.summary, "displacement_mean": x + 2e-5 * rng.standard_normal(len(x))}, {})
        d = diagnosis.diagnose(SoilBinRigModel(measured, simulator=run, uncertainty={"displacement_mean": 2e-5}),
                               settings)
        assert d.cause == named, (fragile, d.verdict, d.cause, d.at_bound)
        if named:
            assert any(b["mechanism"] == "soil_bond_strength" and b["side"] == "high" for b in d.at_bound), d.at_bound
        else:
            assert d.verdict == "no significant discrepancy"


def test_yielding_bonds_for_the_knob_draw_more_and_are_the_configs_own() -> None:
    """Reference: Yade's cohesive-frictional law (tests/test_bond_protocols.py checks warpdem's fragile and ductile
    bonds against Yade's): a bond that yields keeps its cohesion where a fragile one breaks, so more of the soil's
    bonds reach the blade and the rigid blade draws more (paper scale, dense bed: 285.9 N fragile, 369.4 N yielding,
    docs/fidelity.md). The knob ``fragile`` = 0 on the fragile ``ci`` rig raises the rigid draught by more than two
    standard errors of the difference, and gives the bits of a rig configured with yielding bonds. Measured on this
    project's CPU: 154.7 +- 13.9 N fragile, 267.0 +- 17.5 N yielding at 0.6 m/s (about 10 s a run)."""
    rig = SoilBinRigModel(_measured(1.0, 1.0, 0), scale="ci", assembly="A", travel=0.2, steady_travel=0.1,
                          device=DEVICE)
    fragile, fragile_se = rig.rigid_reference(0.6)
    yielding, yielding_se = rig.rigid_reference(0.6, None, {"fragile": 0.0})
    assert yielding > fragile + 2 * math.hypot(fragile_se, yielding_se), (fragile, fragile_se, yielding, yielding_se)
    own = SoilBinRigModel(_measured(1.0, 1.0, 0), scale="ci", assembly="A", travel=0.2, steady_travel=0.1,
                          device=DEVICE, fragile=False, bed=rig.bed())
    assert own.rigid_reference(0.6) == (yielding, yielding_se)
