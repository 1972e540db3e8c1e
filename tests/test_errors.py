"""Bad input raises an InputError naming the parameter and its value; instability stops with step, body, cause."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DEVICE, square

import warpdem as wd

GOOD = dict(young=1e7, poisson=0.3, density=2700.0, friction_angle=30.0)


@pytest.mark.parametrize(
    "field,value,words",
    [
        ("young", 0.0, "young"),
        ("young", -1e7, "young"),
        ("density", -5.0, "density"),
        ("density", 0.0, "density"),
        ("poisson", 1.5, "poisson"),
        ("poisson", -0.1, "poisson"),
        ("friction_angle", 90.0, "friction_angle"),
        ("friction_angle", -1.0, "friction_angle"),
        ("young", float("nan"), "young"),
        ("normal_cohesion", float("inf"), "normal_cohesion"),
        ("eta_roll", float("nan"), "eta_roll"),
    ],
)
def test_bad_material(field: str, value: float, words: str) -> None:
    with pytest.raises(wd.InputError, match=words) as e:
        wd.Material(**{**GOOD, field: value})
    assert repr(value) in str(e.value) or "finite" in str(e.value)


def builder() -> wd.ModelBuilder:
    b = wd.ModelBuilder()
    b.add_material("m", wd.Material(**GOOD))
    return b


def test_bad_bodies_and_meshes() -> None:
    b = builder()
    with pytest.raises(wd.InputError, match=r"sphere radius must be > 0, got -0\.01"):
        b.add_sphere((0, 0, 0), -0.01, "m")
    with pytest.raises(wd.InputError, match="radius"):
        b.add_sphere((0, 0, 0), 0.0, "m")
    with pytest.raises(wd.InputError, match="sphere positions must be finite"):
        b.add_sphere((0, np.nan, 0), 0.01, "m")
    with pytest.raises(wd.InputError, match="velocit"):
        b.add_sphere((0, 0, 0), 0.01, "m", velocity=(np.inf, 0, 0))
    with pytest.raises(wd.InputError, match="mesh faces must have shape"):
        b.add_mesh("empty", np.zeros((3, 3)), np.zeros((0, 3), dtype=int), "m")
    with pytest.raises(wd.InputError, match="material 'clay' is not defined"):
        b.add_sphere((0, 0, 0), 0.01, "clay")
    with pytest.raises(wd.InputError, match="blocked"):
        b.add_sphere((0, 0, 0), 0.01, "m", blocked="xq")
    with pytest.raises(wd.InputError, match="gravity must be finite"):
        wd.ModelBuilder(gravity=(0, 0, np.nan))
    with pytest.raises(wd.InputError, match=r"clump sizes must be >= 1 and sum to the 3 members, got sum 4"):
        b.add_clumps(np.zeros((3, 3)), [0.01] * 3, [2, 2], "m")
    with pytest.raises(wd.InputError, match=r"clump sizes .* min 0"):
        b.add_clumps(np.zeros((3, 3)), [0.01] * 3, [3, 0], "m")


def test_bad_mesh_file(tmp_path) -> None:
    path = tmp_path / "empty.stl"
    path.write_text("solid empty\nendsolid empty\n")
    with pytest.raises((wd.InputError, ValueError)):
        builder().add_mesh_file("tool", str(path), "m")


def test_bad_device_and_world_table() -> None:
    b = builder()
    b.add_sphere((0, 0, 0), 0.01, "m")
    with pytest.raises(wd.InputError, match="device 'tpu:3'"):
        b.finalize("tpu:3")
    with pytest.raises(wd.InputError, match=r"material:m:young.*shape \(3,\).*\(2,\)"):
        b.finalize(DEVICE, n_worlds=3, overrides={"material:m:young": [1e7, 2e7]})
    with pytest.raises(wd.InputError, match="friction_angle must be in"):
        b.finalize(DEVICE, n_worlds=2, overrides={"material:m:friction_angle": [30.0, 95.0]})
    with pytest.raises(wd.InputError, match="unknown override 'speed'"):
        b.finalize(DEVICE, n_worlds=2, overrides={"speed": [1.0, 2.0]})
    with pytest.raises(wd.InputError, match="n_worlds must be an integer >= 1, got 0"):
        b.finalize(DEVICE, n_worlds=0)


def test_time_step_above_critical_is_refused() -> None:
    b = builder()
    b.add_sphere((0, 0, 0), 0.01, "m")
    model, state = b.finalize(DEVICE)
    crit = wd.pwave_timestep(model)
    assert crit == pytest.approx(0.01 / np.sqrt(1e7 / 2700.0))
    with pytest.raises(wd.InputError, match="exceeds the critical time step"):
        wd.Simulation(model, state, dt=2 * crit)
    wd.Simulation(model, state, dt=2 * crit, force_dt=True)  # explicitly forced


def test_unstable_run_stops_with_step_body_and_cause() -> None:
    # Two deeply overlapping stiff spheres with a forced step 30x the critical one blow up.
    b = builder()
    b.add_sphere((0, 0, 0), 0.01, "m")
    b.add_sphere((0.012, 0, 0), 0.01, "m")
    v, f = square((0, 0, -0.05), 0.2)
    b.add_mesh("floor", v, f, "m")
    model, state = b.finalize(DEVICE)
    sim = wd.Simulation(model, state, dt=30 * wd.pwave_timestep(model), force_dt=True)
    with pytest.raises(wd.SimulationError) as e:
        sim.advance(200)
    err = e.value
    assert err.cause in ("speed", "nan", "escaped")
    assert err.body in (0, 1) and 0 < err.step <= 200
    assert f"body {err.body}" in str(err) and f"step {err.step}" in str(err)


def test_an_unstable_world_is_named() -> None:
    """Three worlds of one scene; only world 1 gets a sphere pushed deep into its partner (the blow-up of the test
    above, per world): the error names world 1 and a body of it, so a calibration can set that individual aside."""
    b = wd.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    b.add_material("m", wd.Material(**GOOD))
    b.add_sphere((0, 0, 0), 0.01, "m", name="a")
    b.add_sphere((0.03, 0, 0), 0.01, "m", name="b")
    model, state = b.finalize(DEVICE, n_worlds=3)
    pos = state.body_pos.numpy()
    per = model.bodies_per_world
    pos[1 * per + 1] = pos[1 * per] + np.array([0.012, 0.0, 0.0])
    state.body_pos.assign(pos)
    sim = wd.Simulation(model, state, dt=30 * wd.pwave_timestep(model), force_dt=True)
    with pytest.raises(wd.SimulationError) as e:
        sim.advance(200)
    assert e.value.world == 1 and e.value.body // per == 1 and "(world 1)" in str(e.value)


def test_step_count_check_counts_and_refuses() -> None:
    """Closed form: 1 s at 1e-4 s is 10,000 steps (accepted); 1 s at 1e-8 s is 1e8 > MAX_STEPS = 5e7 (refused before
    anything runs, naming the step, the count and what sets it); a NaN or zero step is refused."""
    assert wd.check_step_count("run", 1.0, 1e-4, "x") == 10_000
    with pytest.raises(wd.InputError, match=r"run: dt = 1e-08 s for 1 s of simulated time is 1e\+08 steps.*set by "
                                            r"the spring"):
        wd.check_step_count("run", 1.0, 1e-8, "the spring")
    for dt in (float("nan"), 0.0):
        with pytest.raises(wd.InputError, match="time step must be finite and > 0"):
            wd.check_step_count("run", 1.0, dt, "x")


def _tiny_bed():  # noqa: ANN202
    from scenes.assemblies import AssemblySpec, Bed

    n = 20
    rng = np.random.default_rng(0)
    centres = np.column_stack([rng.uniform(-0.2, 0.2, n), rng.uniform(0.05, 0.6, n), rng.uniform(0.03, 0.17, n)])
    return Bed(AssemblySpec(kind="A", radius=0.02), (0.5, 0.65, 0.45), 0.2, centres, np.full(n, 0.02), np.arange(n))


def test_runs_whose_time_step_would_make_them_crawl_are_refused_before_they_start() -> None:
    """A carriage speed of 1e-9 m/s (0.3 m of travel: 3e8 s of simulated time), a spring-sphere Young's modulus of
    1e22 Pa (ringing; critical step ~ sqrt(m / (E r)) ~ 1e-11 s) and a deposition given 1e6 s each need far more
    than MAX_STEPS steps: each is refused with an InputError naming the run, instead of hanging."""
    from scenes.assemblies import AssemblySpec, deposit
    from scenes.ringing import RingingConfig, run_ringing
    from scenes.soil_bin import SoilBinConfig, run_soil_bin

    with pytest.raises(wd.InputError, match=r"soil-bin run: dt = .* steps, more than 5e\+07"):
        run_soil_bin(SoilBinConfig(scale="ci"), [0], bed=_tiny_bed(), device=DEVICE, speeds=[1e-9])
    cfg = RingingConfig(springs=(16,), spring_model="paper", spring_young=(1e22,), local_damping=(0.01,))
    with pytest.raises(wd.InputError, match=r"ringing run: dt = .* steps, more than 5e\+07.*critical step"):
        run_ringing(cfg, device=DEVICE)
    with pytest.raises(wd.InputError, match=r"deposition: dt = .* steps, more than 5e\+07"):
        deposit(AssemblySpec(kind="A", radius=0.02), (0.3, 0.3, 0.3), 0.1, device=DEVICE, max_time=1e6)


def test_a_shear_box_whose_shear_would_crawl_is_refused() -> None:
    """A shear rate of 1e-12 m/s over 15 % of a 0.1 m box is 1.5e10 s of shearing: refused before it starts."""
    from scenes.shear_box import ShearBoxConfig, run_shear_boxes

    with pytest.raises(wd.InputError, match=r"shear box: dt = .* steps, more than 5e\+07"):
        run_shear_boxes([ShearBoxConfig(shear_rate=1e-12)], DEVICE, bed=_tiny_bed())


@pytest.mark.parametrize("kw,words", [
    ({"travel": 0.12}, r"steady_travel \(0.15 m\) must be shorter than travel \(0.12 m\)"),
    ({"travel": -0.3}, "travel must be finite and > 0"),
    ({"steady_travel": float("nan")}, "steady_travel must be finite and > 0"),
    ({"dt": 0.0}, "dt must be finite and > 0"),
    ({"sample_rate": float("inf")}, "sample_rate must be finite and > 0 Hz"),
])
def test_a_soil_bin_config_whose_travel_or_sampling_makes_no_sense_is_refused(kw: dict, words: str) -> None:
    """Refused when the config is made, not after the run: a travel shorter than the steady-state start (ci scale:
    0.15 m) would run the whole simulation and then find no steady samples."""
    from scenes.soil_bin import SoilBinConfig

    with pytest.raises(wd.InputError, match=words):
        SoilBinConfig(scale="ci", **kw)
