"""Direct shear box (scenes/shear_box.py): a cohesionless and a cohesive sample, three normal stresses each, in one
batched CPU run of the ``ci`` preset (assembly A, ~580 spheres per world, six worlds).

Physics checked, with the reasoning at each assertion: the Mohr-Coulomb fit of the cohesionless sample passes
through the origin and the cohesive sample's lies clearly above it; both friction angles are plausible for a dense
packing of frictional grains with rolling resistance; peaks rise with the normal stress along a line; the test is
quasi-static (inertial number, force balance of the two box halves); the dead-weight load and the plate's dilation
behave as they must.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from conftest import DEVICE

from scenes import shear_box as sb

#: the cohesive sample's bonds: 5 x GA set 1's Cn = 42.2 kPa, Cs = 21.1 kPa. Its bond strengths Cs r^2 = 2.6 N and
#: Cn r^2 = 5.3 N (r = 5 mm) exceed the mean contact normal force even at the highest stress (~sigma d^2 = 2 N at
#: 20 kPa), so the bonds, not friction, govern the first failure and the cohesion they give stands clear of the
#: peak scatter. (With GA set 1's own values and fragile bonds the bonds are weaker than the contact forces, break
#: within the first millimetre of shear and the fitted cohesion, about 1 kPa, is within the scatter.)
COHESION_FACTOR = 5.0
#: |c| of a cohesionless sample, as a fraction of its mean peak shear stress. A cohesionless envelope passes through
#: the origin; the fitted intercept moves by the scatter of the peaks times sqrt(1/n + mean(sigma)^2 / S_xx) = 1.25
#: for sigma ~ 5, 10, 20 kPa (peaks of samples ~10 grains wide scatter by 5-10 %), and dilatancy falling with stress
#: bends the envelope, which adds a positive intercept. Measured over six deposition seeds (CPU, session 3): -0.4 %
#: to +14.3 % of the mean peak (mean 6.4 %, standard deviation 5.5 %; a CUDA realization exceeded the former 15 %
#: bound). The bound is the mean + 3 standard deviations, rounded up: 25 %.
COHESIONLESS_TOL = 0.25


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    from warpdem.vtk import VtkWriter

    t0 = time.perf_counter()
    cfg = sb.preset("ci")
    bed = sb.make_bed(cfg, DEVICE)
    t_bed = time.perf_counter() - t0
    wet = cfg.replace(normal_cohesion=COHESION_FACTOR * cfg.normal_cohesion,
                      shear_cohesion=COHESION_FACTOR * cfg.shear_cohesion, label="cohesive")
    vtk = tmp_path_factory.mktemp("vtk")
    dry, wet = sb.run_shear_boxes([cfg.cohesionless(), wet], DEVICE, bed=bed, vtk=(VtkWriter(vtk), 10))
    print(f"\ndeposition {t_bed:.1f} s, shear box {dry.wall_s:.1f} s")
    print(dry.table())
    print(wet.table())
    return {"dry": dry, "wet": wet, "bed": bed, "vtk": vtk}


def test_cohesionless_sample_fits_through_the_origin(results: dict) -> None:
    dry = results["dry"]
    tau_scale = float(np.mean(dry.peak_shear_stress))
    assert abs(dry.fit.cohesion) < COHESIONLESS_TOL * tau_scale, dry.table()


def test_cohesive_sample_has_the_larger_cohesion(results: dict) -> None:
    dry, wet = results["dry"], results["wet"]
    tau_scale = float(np.mean(dry.peak_shear_stress))
    # ordered beyond the cohesionless tolerance three times over: the difference is not scatter
    assert wet.fit.cohesion > dry.fit.cohesion + 3 * COHESIONLESS_TOL * tau_scale, (dry.table(), wet.table())
    # and bounded by the bonds: the bonds crossing a plane hold at most Cn times the part of the plane their areas
    # min(R)^2 cover, which is less than the whole plane (a grain of cross-section pi R^2 has a few bonds of R^2
    # spread over both of its hemispheres), so the macroscopic cohesion stays below Cn
    assert wet.fit.cohesion < wet.config.normal_cohesion


@pytest.mark.parametrize("sample", ["dry", "wet"])
def test_friction_angles_are_plausible(results: dict, sample: str) -> None:
    res = results[sample]
    # lower bound: the contact friction angle (13.2 deg). A dense packing's peak strength adds dilatancy and rolling
    # resistance (eta = 0.105) to the interparticle friction, so the internal friction angle exceeds it (Rowe's
    # stress-dilatancy: phi_peak > phi_cv > phi_mu for phi_mu well below ~25 deg). Upper bound: 60 deg, beyond the
    # densest granular soils (~50 deg).
    assert res.config.friction_angle < res.fit.friction_angle_deg < 60.0, res.table()


@pytest.mark.parametrize("sample", ["dry", "wet"])
def test_peaks_lie_on_a_rising_line(results: dict, sample: str) -> None:
    res = results[sample]
    # shear strength grows with the normal stress (friction), and the peaks lie close to a straight line: the
    # paper's Fig. 10 fits have R^2 = 0.85-0.99; a fit below 0.9 would mean a peak is off by more than the scatter
    assert np.all(np.diff(res.peak_shear_stress) > 0), res.table()
    assert res.fit.r2 > 0.9, res.table()
    assert res.fit.n_points == 3


def test_shear_is_quasi_static(results: dict) -> None:
    for res in (results["dry"], results["wet"]):
        for c in res.curves:
            # inertial number < 1e-2: by mu(I) the friction coefficient is within ~0.01 of its quasi-static value
            assert c.inertial_number < 1e-2
            # the soil between the halves barely accelerates, so on average the lower half pushes as hard as the
            # upper half and the plate hold: the momentum given to the lower soil (~1 kg x 0.05 m/s) is ~0.2 % of
            # the impulse (~100 N x 0.3 s); 2 % leaves room for the end intervals. (Local damping during shear would
            # show here as a drag on the moving soil: 1-5 % with 0.2.)
            upper, lower = float(np.mean(c.shear_stress)), float(np.mean(c.shear_stress_lower))
            assert lower == pytest.approx(upper, rel=0.02)


def test_normal_load_and_dilation(results: dict) -> None:
    dry, bed = results["dry"], results["bed"]
    cfg = dry.config
    for c in dry.curves:
        # the plane carries the plate's weight plus the soil above it: less than a solid column of half the sample
        extra = c.normal_stress_plane - c.normal_stress
        assert 0 < extra < cfg.density * sb.GRAVITY * cfg.sample_height / 2
        # ... and roughly (solid fraction 1 - porosity of the bed) that column; 0.3 covers the consolidation
        assert extra == pytest.approx((1 - bed.porosity) * cfg.density * sb.GRAVITY * cfg.sample_height / 2, rel=0.3)
        # displacement is recorded over the whole test
        assert c.displacement[-1] == pytest.approx(cfg.shear_displacement * cfg.box_side, rel=0.05)
    # a dense sample dilates when sheared at a low normal stress: the plate ends higher than it started
    assert dry.curves[0].vertical_displacement[-1] > 0


def test_default_parameters_come_from_the_ga_set() -> None:
    cfg = sb.preset("ci")
    row = sb.ga_set(cfg.ga_set)
    assert row["assembly"] == cfg.assembly.kind
    assert cfg.friction_angle == row["friction_angle_deg"]
    assert cfg.normal_cohesion == row["normal_cohesion_pa"] and cfg.shear_cohesion == row["shear_cohesion_pa"]
    assert cfg.eta_roll == cfg.eta_twist == row["eta_roll_twist"]
    for kind in ("A", "B", "C"):
        assert sb.ga_set(sb.closest_ga_set(kind))["assembly"] == kind


def test_config_validation() -> None:
    cfg = sb.preset("ci")
    with pytest.raises(ValueError, match="three distinct"):
        cfg.replace(normal_stresses=(5e3, 10e3))
    with pytest.raises(ValueError, match="particle lengths"):
        cfg.replace(box_side=0.05)
    with pytest.raises(ValueError, match="same shear_rate"):
        sb.run_shear_boxes([cfg, cfg.replace(shear_rate=0.1)])


def test_report_keeps_every_curve_and_states_the_fit(results: dict, tmp_path) -> None:
    """write_report: series.npz holds every curve as run (the same arrays), and report.md states the fit's c and phi
    and the laboratory's (section 2.3), which the peaks' own Mohr-Coulomb fit gives again from the saved series."""
    wet = results["wet"]
    sb.write_report(wet, tmp_path)
    text = (tmp_path / "report.md").read_text()
    with np.load(tmp_path / "series.npz") as d:
        for k, c in enumerate(wet.curves):
            np.testing.assert_array_equal(d[f"shear_stress_{k}"], c.shear_stress)
            np.testing.assert_array_equal(d[f"displacement_{k}"], c.displacement)
        np.testing.assert_array_equal(d["normal_stress_plane"], wet.normal_stress)
    assert f"c = {wet.fit.cohesion / 1e3:.2f} kPa" in text and f"phi = {wet.fit.friction_angle_deg:.1f} deg" in text
    c_lab, phi_lab = sb.lab_strength()
    assert f"c = {c_lab:.1f} kPa, phi = {phi_lab:.1f} deg" in text
    assert (tmp_path / "fig_shear_box.png").stat().st_size > 10_000


def test_vtk_frames_show_every_sample_while_it_is_sheared(results: dict) -> None:
    # Reference: the run's own record count and sizes: a frame at the start of shearing and at every 10th record;
    # every world's sample (the bed in each of the 2 x 3 worlds) and its box (triangles) in the last frame; the lower
    # half's triangles moved by the shear displacement between the first and the last frame (its velocity is set).
    import meshio

    dry = results["dry"]
    n_rec = len(dry.curves[0].displacement)
    frames = sorted(results["vtk"].glob("spheres_*.vtu"), key=lambda p: int(p.stem.split("_")[1]))
    assert len(frames) == 1 + n_rec // 10
    n_worlds = 2 * len(dry.curves)
    last = meshio.read(frames[-1])
    per_world = np.bincount(last.point_data["world"].astype(int), minlength=n_worlds)
    assert len(per_world) == n_worlds and np.all(per_world == per_world[0])  # every world, the same spheres
    assert per_world[0] >= len(results["bed"].radii)  # the sample (and any sphere of the rig)
    mesh0 = meshio.read(str(frames[0]).replace("spheres_", "meshes_"))
    mesh1 = meshio.read(str(frames[-1]).replace("spheres_", "meshes_"))
    assert len(mesh1.cells_dict["triangle"]) == len(mesh0.cells_dict["triangle"]) > 0
    moved = np.abs(mesh1.points[:, 0] - mesh0.points[:, 0]).max()
    shear = dry.config.shear_rate * (int(frames[-1].stem.split("_")[1]) - int(frames[0].stem.split("_")[1])) * dry.dt
    assert moved == pytest.approx(shear, rel=1e-3)


def test_a_cohesionless_envelope_bends_so_its_intercept_depends_on_the_stresses(results: dict) -> None:
    """Reference: the peak strength envelope of a dense granular sample is curved (dilatancy, which adds to the
    peak, is suppressed as the normal stress grows: Bolton 1986, Geotechnique 36(1)), so a Mohr-Coulomb line through
    peaks at higher stresses has a positive intercept without any bond, and a lower slope. The same ci sample,
    cohesionless, at 5/10/20 kPa (the fixture's) and at 50/100/200 kPa: measured in docs/runs/shear_box_stress_range
    (seeds 0-2, CPU) an intercept 12.7-16.0 kPa higher and a friction angle 13.4-17.4 deg lower at the higher
    stresses; the bounds (5 kPa, 5 deg) keep about a third of the smallest."""
    dry = results["dry"]
    high = sb.run_shear_boxes([dry.config.replace(normal_stresses=(50e3, 100e3, 200e3))], DEVICE,
                              bed=results["bed"])[0]
    assert high.fit.cohesion > dry.fit.cohesion + 5e3, (dry.table(), high.table())
    assert high.fit.friction_angle_deg < dry.fit.friction_angle_deg - 5.0, (dry.table(), high.table())


def test_with_a_fixed_consolidation_a_configs_result_does_not_depend_on_its_batch(results: dict) -> None:
    """Reference: the worlds of a batch are independent samples (no contact, force or body crosses between them),
    so a config's result must be a function of that config alone; a calibration ranks individuals by results that
    are batched with others. What couples them is the protocol's clock: with the adaptive end a batch consolidates
    until its slowest sample has settled (and a config's worlds wait in the servo for the others'). A companion
    that settles slowly (contact friction 5 deg, eta 0.8) must therefore change the cohesive sample's peaks when
    the end is adaptive (measured on this CPU: its consolidation 0.070 -> 0.103 s, c 10.72 -> 10.84 kPa) and leave
    them equal to the bit when every world consolidates for the same fixed time."""
    wet, bed = results["wet"].config, results["bed"]
    slow = wet.replace(friction_angle=5.0, eta_roll=0.8, eta_twist=0.8, label="slow")
    alone = sb.run_shear_boxes([wet], DEVICE, bed=bed)[0]
    paired = sb.run_shear_boxes([wet, slow], DEVICE, bed=bed)[0]
    assert paired.consolidation_time > alone.consolidation_time
    assert not np.array_equal(paired.peak_shear_stress, alone.peak_shear_stress)
    t = sb.BATCH_CONSOLIDATION
    fixed = [c.replace(consolidation_time=(t, t)) for c in (wet, slow)]
    alone = sb.run_shear_boxes(fixed[:1], DEVICE, bed=bed)[0]
    paired = sb.run_shear_boxes(fixed, DEVICE, bed=bed)[0]
    assert alone.consolidation_time == paired.consolidation_time == pytest.approx(t, abs=alone.dt)
    assert alone.settled and paired.settled
    np.testing.assert_array_equal(paired.peak_shear_stress, alone.peak_shear_stress)
    assert paired.fit.cohesion == alone.fit.cohesion
