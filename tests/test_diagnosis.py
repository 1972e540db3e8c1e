"""Model criticism (calibration.diagnosis) on data with a hidden effect.

Reference: "measured" ringing records synthesised by the DEM rig with one effect switched on that the baseline
(linear springs of nominal DIN rate, one dashpot) lacks, plus a real test's imperfections: each configuration's
true stiffness off its nominal rate by 2 % (1 sigma), sensor noise of 1 % of the first swing, a 0.2 mm zero error,
a rest period before the hit, 2400 Hz sampling. The diagnosis is not told the effect; it must name it among all
registered mechanisms, and the re-simulated extension must at least halve the held-out loss. On a set with the
same imperfections and no hidden effect it must not invent a cause.

The soil-bin test hides a sensor offset in a Table 3-like summary simulated at CI scale (see its comment).

Stated uncertainties of the ringing tests (what the synthetic imperfections give): frequency 1 % (2 % stiffness
scatter -> 1 % in frequency), damping 3 % (1 % from the scatter, zeta ~ k^-1/2, plus the fit on a noisy record),
5 % from the second half of a decay. Four configurations (4, 12, 20, 32 springs) and 1.5 s records keep a
diagnosis near 1.5 min on CPU; ``warpdem diagnose`` on eight configurations is the larger version (README).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import DEVICE

from calibration import diagnosis, mechanisms, synthetic
from calibration.genes import Gene
from calibration.rig_models import RingingRigModel, SoilBinRigModel

SPRINGS = (4, 12, 20, 32)
UNCERTAINTY = {"damping": 0.03, "damping_late": 0.05}
DASHPOT = 1000.0  # N s/m: damping ratios 0.02-0.05, five to ten cycles in 1.5 s


def run(truth: dict[str, float], seed: int) -> diagnosis.Diagnosis:
    data = synthetic.ringing_data(SPRINGS, {"dashpot": DASHPOT, **truth}, seed=seed, device=DEVICE, ring_time=1.5)
    return diagnosis.diagnose(RingingRigModel(data, device=DEVICE, uncertainty=UNCERTAINTY))


@pytest.mark.parametrize(("effect", "truth"), [
    ("pivot_friction", {"pivot_friction": 0.05}),
    ("extra_mass", {"extra_mass": 6.0}),
])
def test_hidden_effect_is_named_and_the_extension_gains_on_held_out_data(effect: str, truth: dict) -> None:
    d = run(truth, seed=1)
    assert d.verdict == "cause" and d.cause == (effect,), (d.verdict, d.cause, d.ranking)
    # re-simulated held-out loss at least halved, and what is left is consistent with the stated noise
    assert d.verification["gain_rel"] > 0.5
    assert d.noise_p_best > 1e-3
    assert d.baseline.heldout_loss.sum() > 4 * d.named.heldout_loss.sum()
    if effect == "extra_mass":
        # the static-deflection covariate is the simulated one: an extra mass (distributed like the tool's) adds
        # (extra / M) x the tool's weight moment about the pivot to the spring's load, so the extended rig's spring
        # deflects by that / (lever k) more than the baseline's (the rig's equilibrium in closed form; 1 %)
        from scenes.ringing import gravity_moment
        from scenes.sweep import build_sweep

        tool = build_sweep()
        lever = abs(tool.sensor_point[2] - tool.pivot[2])
        moment = gravity_moment(tool, 200.0 / 9.81, tool.tip)
        extra = d.named.params_all()["extra_mass"] / tool.mass * gravity_moment(tool, 0.0, tool.tip)
        k = np.array([c["stiffness"] for c in d.configs])
        v = d.verification
        np.testing.assert_allclose(d.covariates["static_deflection"], v["baseline"]["static_deflection"])
        np.testing.assert_allclose(v["extra_mass"]["static_deflection"] - v["baseline"]["static_deflection"],
                                   (abs(moment + extra) - abs(moment)) / lever / k, rtol=0.01)


def test_noise_only_data_get_no_cause() -> None:
    # the baseline is the truth: whatever a mechanism gains on held-out data is noise, which the thresholds reject;
    # the baseline's held-out residuals must be consistent with the stated uncertainties
    d = run({}, seed=3)
    assert d.verdict == "no significant discrepancy", (d.verdict, d.cause, d.ranking)
    assert d.noise_p_baseline >= diagnosis.DiagnosisSettings().noise_p
    assert d.baseline.params_all()["dashpot"] == pytest.approx(DASHPOT, rel=0.1)


def test_hidden_series_compliance_through_the_command(tmp_path: pytest.TempPathFactory) -> None:
    # the same through `warpdem diagnose` on files in the MEASURED format; the fitted series stiffness and dashpot
    # must be the truth's within 10 % (the only scatter left is the 2 % stiffness scatter and the noise)
    from calibration.cli import main

    synthetic.ringing_data(SPRINGS, {"dashpot": DASHPOT, "series_stiffness": 1e6}, seed=2, device=DEVICE,
                           ring_time=1.5, out=tmp_path / "measured")
    out = tmp_path / "diag"
    assert main(["diagnose", str(tmp_path / "measured"), "--rig", "ringing", "--device", DEVICE, "--out", str(out),
                 "--uncertainty", ",".join(f"{k}={v}" for k, v in UNCERTAINTY.items())]) == 0
    js = json.loads((out / "diagnosis.json").read_text())
    assert js["verdict"] == "cause" and js["cause"] == ["series_compliance"]
    assert js["parameters"]["series_stiffness"] == pytest.approx(1e6, rel=0.1)
    assert js["parameters"]["dashpot"] == pytest.approx(DASHPOT, rel=0.1)
    assert js["errors_after"]["heldout_loss"] < 0.1 * js["errors_before"]["heldout_loss"]
    assert {r["candidate"] for r in js["ranking"]} >= {"baseline", "pivot_friction", "progressive_spring",
                                                       "series_compliance", "extra_mass", "pose_change"}
    report = (out / "report.md").read_text()
    assert "series_compliance" in report and (out / "observables.png").exists() and (out / "series.png").exists()
    assert (out / "decay.png").exists()


def test_hidden_sensor_offset_in_the_soil_bin() -> None:
    # soil bin at CI scale (assembly C bed, 0.22 m of travel, steady after 0.1 m), three configurations at Table
    # 3's speeds; the truth reads the displacement 1.5 mm low (the zero set with the tool leaning on a stop), its
    # springs scatter by 2 % and its observables carry noise of 1 percentage point and 0.1 mm. The uncertainties
    # are the defaults plus the simulation's own standard errors (rig_models.SOIL_BIN_UNCERTAINTY). One grid round
    # (9 points per gene, the offset's spacing 1.25 mm) and one Levenberg-Marquardt round, 177 s alone on the
    # 2-core CPU (session 32): with the grid alone the truth, between two grid points, and a preloaded spring stack
    # (which also lowers the readings by a constant) came out within the noise of each other on one build of the
    # bed (held-out losses 13.6 and 11.6; session 14); refined, the offset is named clearly (6.7 against 15.2). The
    # candidates are the offset and the mechanisms that also move the mean reading by a near-constant or a
    # proportional amount (its confounders) and pivot friction (a sticking tool reads low): the other soil-bin
    # mechanisms change the draught or the vibration, which the offset leaves alone (all 15 candidates took 867 s in
    # session 31's loaded CI).
    from scenes import paper
    from scenes import soil_bin as sb

    springs = (4, 16, 32)
    t3 = paper.table("soil_bin_measured")
    speeds = tuple(float(t3["speed_mean_m_s"][t3["springs"] == n][0]) for n in springs)
    bed = sb.bed_for(sb.SoilBinConfig(scale="ci", assembly="C"), device=DEVICE)
    scene = {"bed": bed, "travel": 0.22, "steady_travel": 0.1}  # the shortest run with a steady window
    data = synthetic.soil_bin_data(springs, speeds, {"sensor_offset": -1.5e-3}, seed=4, device=DEVICE, **scene)
    rig = SoilBinRigModel(data, device=DEVICE, **scene)
    confounders = ("sensor_offset", "stack_preload", "mount_pitch", "sensor_lever", "lever_geometry",
                   "pivot_friction")
    d = diagnosis.diagnose(rig, diagnosis.DiagnosisSettings(rounds=2, first_grid={0: 1, 1: 9}, mechanisms=confounders))
    assert d.verdict == "cause" and d.cause == ("sensor_offset",), (d.verdict, d.cause, d.ranking)
    # the offset is recovered to within the displacement's uncertainty (stated 0.2 mm and the runs' SEM)
    sigma_disp = float(np.median(rig.sigma[:, rig.observables.index("displacement_mean")]))
    assert d.named.params_all()["sensor_offset"] == pytest.approx(-1.5e-3, abs=2 * sigma_disp)
    assert d.verification["gain_rel"] > 0.5


def test_decay_curve_of_a_viscous_decay_is_flat() -> None:
    # Reference: x = A exp(-zeta wn t) cos(wd t) + c has the damping ratio zeta in every cycle (log decrement
    # 2 pi zeta / sqrt(1 - zeta^2) between consecutive peaks); sampled at 2400 Hz, peaks are refined by the ringdown
    # fit, so each cycle's ratio must be zeta within 2 %; the amplitudes fall by exp(-zeta wn T) per cycle.
    from calibration.diagnosis_report import decay_curve

    zeta, f_d = 0.03, 5.0
    wd = 2 * np.pi * f_d
    wn = wd / np.sqrt(1 - zeta**2)
    t = np.arange(0.0, 2.0, 1 / 2400)
    a, z = decay_curve(t, 1e-3 * np.exp(-zeta * wn * t) * np.cos(wd * t) + 2e-4)
    assert a.size >= 8
    np.testing.assert_allclose(z, zeta, rtol=0.02)
    np.testing.assert_allclose(a[1:] / a[:-1], np.exp(-zeta * wn / f_d), rtol=0.01)


def test_registry() -> None:
    with pytest.raises(ValueError, match="already registered"):
        mechanisms.register(mechanisms.get("pivot_friction"))
    with pytest.raises(ValueError, match="unknown mechanism"):
        mechanisms.get("no_such_thing")
    # a user's mechanism on a knob the rig has becomes a candidate; one on a knob it lacks is refused by name
    user = mechanisms.Mechanism("bushing", "Pivot bushing", "a bushing with dry friction",
                                genes=(Gene("bushing_torque", 0.01, 1.0, log=True, unit="N m"),),
                                knobs=lambda p: {"pivot_friction": p["bushing_torque"]}, rigs=("ringing",))
    alien = mechanisms.Mechanism("wind", "Wind", "a breeze", genes=(Gene("wind", 0.0, 1.0),),
                                 knobs=lambda p: {"wind_force": p["wind"]}, rigs=("ringing",))
    try:
        mechanisms.register(user)
        mechanisms.register(alien)
        data = synthetic.ringing_data((4, 32), {"dashpot": DASHPOT}, device=DEVICE, ring_time=0.5)
        rig = RingingRigModel(data, device=DEVICE)
        names = [c.name for c in diagnosis.candidates_for(rig, diagnosis.DiagnosisSettings())]
        assert "bushing" in names and "wind" not in names and "speed_dependence" not in names
        with pytest.raises(ValueError, match="wind_force"):
            diagnosis.candidates_for(rig, diagnosis.DiagnosisSettings(mechanisms=("wind",)))
        cand = next(c for c in diagnosis.candidates_for(rig, diagnosis.DiagnosisSettings()) if c.name == "bushing")
        p = cand.params(np.array([0.5, 1.0]))
        assert p["pivot_friction"] == pytest.approx(1.0) and "bushing_torque" not in p
    finally:
        mechanisms.REGISTRY.pop("bushing", None)
        mechanisms.REGISTRY.pop("wind", None)


class _Killed(Exception):
    pass


class _DiesAfter:
    """A rig model whose run is killed after ``calls`` batched simulations."""

    def __init__(self, rig: RingingRigModel, calls: int) -> None:
        self._inner, self.left = rig, calls

    def __getattr__(self, name: str) -> object:
        return getattr(self._inner, name)

    def simulate(self, cases: list, **kw: object) -> object:
        if self.left == 0:
            raise _Killed
        self.left -= 1
        return self._inner.simulate(cases, **kw)


def test_a_killed_diagnosis_resumes_to_the_same_result(tmp_path: pytest.TempPathFactory) -> None:
    # Reference: the uninterrupted diagnosis. Killed after three batched simulations and resumed from its
    # checkpoint, it must simulate only what it had not and end with the same fits, bit for bit (CPU worlds are
    # deterministic and the resumed batches are the same as the uninterrupted run's).
    data = synthetic.ringing_data((4, 16, 32), {"dashpot": DASHPOT, "extra_mass": 6.0}, seed=5, device=DEVICE,
                                  ring_time=0.8)
    settings = diagnosis.DiagnosisSettings(rounds=2, first_grid={0: 1, 1: 5}, mechanisms=("extra_mass",),
                                           batch_worlds=12)

    def rig() -> RingingRigModel:
        return RingingRigModel(data, device=DEVICE, uncertainty=UNCERTAINTY)

    whole = diagnosis.diagnose(rig(), settings)
    ck = tmp_path / "checkpoint.json"
    with pytest.raises(_Killed):
        diagnosis.diagnose(_DiesAfter(rig(), 3), settings, checkpoint=ck)
    saved = json.loads(ck.read_text())
    assert saved["n_sims"] == 3 * len(saved["cache"]) > 0
    assert saved["wall_s"] > 0.0 and not saved["wall_untimed"]
    resumed = diagnosis.diagnose(rig(), settings, checkpoint=ck)
    assert (resumed.verdict, resumed.cause) == (whole.verdict, whole.cause)
    assert resumed.n_simulations == whole.n_simulations
    # the wall time adds the killed call's (as its checkpoint recorded it) to the resumed call's
    assert resumed.wall_s > saved["wall_s"] and not resumed.wall_untimed
    for name, f in whole.fits.items():
        np.testing.assert_array_equal(resumed.fits[name].z_fold, f.z_fold)
        np.testing.assert_array_equal(resumed.fits[name].heldout_loss, f.heldout_loss)
    with pytest.raises(ValueError, match="belongs to another diagnosis"):
        diagnosis.diagnose(rig(), diagnosis.DiagnosisSettings(rounds=3), checkpoint=ck)


class _MassOnSpring:
    """A closed-form rig: a 20 kg body on a spring of stiffness k rings at f = sqrt(k / (M + m)) / (2 pi), m the
    extra-mass knob. Its "measured" data come from the same formula with a hidden extra mass and 0.3 % noise."""

    rig, observables, units, genes = "ringing", ("frequency",), {"frequency": "Hz"}, ()
    knobs = frozenset({"extra_mass"})
    mass = 20.0

    def __init__(self, extra: float, seed: int = 0) -> None:
        self.configs = [{"stiffness": k} for k in (1e5, 2e5, 4e5, 8e5, 1.6e6)]
        self.n_configs = len(self.configs)
        noise = 1.0 + 0.003 * np.random.default_rng(seed).standard_normal(self.n_configs)
        self.measured = self._f(np.array([c["stiffness"] for c in self.configs]), extra)[:, None] * noise[:, None]
        self.sigma = 0.005 * self.measured

    def _f(self, k: np.ndarray, extra: float) -> np.ndarray:
        return np.sqrt(k / (self.mass + extra)) / (2 * np.pi)

    def describe_uncertainty(self) -> dict[str, str]:
        return {"frequency": "0.5 %"}

    def covariates(self) -> dict[str, np.ndarray]:
        return {"stiffness": np.array([c["stiffness"] for c in self.configs])}

    def simulate(self, cases: list, keep_series: bool = False) -> object:
        from calibration.rig_models import SimOutput

        k = np.array([self.configs[c.config]["stiffness"] for c in cases])
        return SimOutput(self._f(k, np.array([c.params.get("extra_mass", 0.0) for c in cases]))[:, None])


@pytest.mark.parametrize("extra", [12.0, 60.0])
def test_a_fit_at_the_end_of_its_range_is_reported(extra: float, tmp_path: pytest.TempPathFactory) -> None:
    # Closed form (no DEM): the extra-mass gene searches 0-30 kg. A hidden 12 kg is recovered inside the range
    # (to the 0.3 % frequency noise: 2 x 0.3 % of M + m = 0.2 kg) and named; a hidden 60 kg explains most of the
    # misfit at 30 kg but sits on its bound: it is not named (issue #39, item 1: "at its bound: the cause is likely
    # outside this mechanism"), and the report says so rather than present 30 kg as measured.
    from calibration import diagnosis_report

    d = diagnosis.diagnose(_MassOnSpring(extra))
    js = diagnosis_report.to_json(d)
    text = diagnosis_report.write(d, tmp_path).read_text()
    if extra < 30.0:
        assert d.cause == ("extra_mass",), (d.verdict, d.ranking)
        assert d.named.params_all()["extra_mass"] == pytest.approx(extra, abs=0.2)
        assert d.named.at_bound() == [] and d.at_bound == [] and "its bound" not in text
    else:
        assert d.cause == () and d.verdict == "unexplained residual", (d.verdict, d.ranking)
        assert [(b["mechanism"], b["gene"], b["side"]) for b in d.at_bound] == [("extra_mass", "extra_mass", "high")]
        assert d.at_bound[0]["value"] == pytest.approx(30.0, rel=0.01) and d.at_bound[0]["folds"] == 5
        assert js["at_bound"] == d.at_bound
        assert "At its bound: the cause is likely outside this mechanism:** extra_mass" in text


@pytest.mark.parametrize(("extra", "named"), [(0.3, False), (0.4, True)])
def test_a_baseline_within_the_noise_gets_no_name(extra: float, named: bool) -> None:
    # Closed form (no DEM). Reference: the baseline's chi^2 computed here from the formula, f(k, 0) against the data,
    # in their stated 0.5 % (the baseline has no genes: its held-out residuals are its residuals); p from chi^2 with
    # one dof per configuration. A hidden 0.3 kg shifts each frequency by 0.75 % (1.5 sigma): p = 0.05, the baseline
    # is within the stated uncertainties, and although extra_mass fits it (0.3 kg, significant by the likelihood
    # ratio) nothing is named. 0.4 kg (2 sigma each): p = 0.0015 < noise_p = 0.01, named.
    from scipy import stats

    rig = _MassOnSpring(extra)
    k = np.array([c["stiffness"] for c in rig.configs])
    chi2 = float(np.sum(((rig._f(k, 0.0)[:, None] - rig.measured) / rig.sigma) ** 2))
    p = float(stats.chi2.sf(chi2, rig.n_configs))
    d = diagnosis.diagnose(rig)
    assert d.noise_p_baseline == pytest.approx(p, rel=1e-4)
    assert (p < diagnosis.DiagnosisSettings().noise_p) == named
    fit = d.fits["extra_mass"]
    assert fit.significant and fit.params_all()["extra_mass"] == pytest.approx(extra, abs=0.02)
    if named:
        assert d.cause == ("extra_mass",), (d.verdict, d.ranking)
    else:
        assert d.cause == () and d.verdict == "no significant discrepancy", (d.verdict, d.ranking)


class _Counting:
    """A rig that counts the worlds its fits simulate (one per configuration per point; the verification's
    re-simulation, with series kept, is not counted: it runs after every diagnosis)."""

    def __init__(self, inner: object) -> None:
        self._inner, self.worlds = inner, 0

    def __getattr__(self, name: str) -> object:
        return getattr(self._inner, name)

    def simulate(self, cases: list, keep_series: bool = False) -> object:
        self.worlds += 0 if keep_series else len(cases)
        return self._inner.simulate(cases, keep_series=keep_series)


def test_another_number_of_rounds_refits_from_the_checkpoint(tmp_path: pytest.TempPathFactory) -> None:
    # Closed form (no DEM). Round r's points follow from rounds 1..r-1 alone, so a checkpoint serves any number of
    # rounds. Reference: the same diagnosis from scratch at each number of rounds. Fewer rounds on a checkpoint of
    # more simulate nothing; more rounds on one of fewer simulate only what they add; every result equals the one
    # from scratch bit for bit (the fits see only the points they request).
    def fresh(rounds: int, ck: object = None) -> tuple[diagnosis.Diagnosis, int]:
        rig = _Counting(_MassOnSpring(12.0))
        # the convergence check off: it adds rounds until the loss stops falling, which this test does not count
        return diagnosis.diagnose(rig, diagnosis.DiagnosisSettings(rounds=rounds, converge_rounds=0),
                                  checkpoint=ck), rig.worlds

    def same(a: diagnosis.Diagnosis, b: diagnosis.Diagnosis) -> None:
        assert (a.verdict, a.cause, a.ranking) == (b.verdict, b.cause, b.ranking)
        for name, f in a.fits.items():
            np.testing.assert_array_equal(b.fits[name].z_all, f.z_all)
            np.testing.assert_array_equal(b.fits[name].heldout_loss, f.heldout_loss)

    ck = tmp_path / "checkpoint.json"
    three, n3 = fresh(3, ck)
    one_alone, n1 = fresh(1)
    one, n = fresh(1, ck)
    assert n == 0 and 0 < n1 < n3
    same(one_alone, one)
    two_alone, n2 = fresh(2)
    ck2 = tmp_path / "one.json"
    fresh(1, ck2)
    two, n = fresh(2, ck2)
    assert n == n2 - n1 > 0  # only what the second round adds
    same(two_alone, two)
    for name in ("baseline", "extra_mass"):  # a fit of step 1 chooses among more points with more rounds
        assert three.fits[name].chi2_in <= one.fits[name].chi2_in
    # a checkpoint written while the rounds were part of its key is read under the present key
    saved = json.loads(ck2.read_text())
    saved["key"] = diagnosis._checkpoint_key(_MassOnSpring(12.0),
                                             diagnosis.DiagnosisSettings(rounds=2, converge_rounds=0), 2)
    ck2.write_text(json.dumps(saved))
    again, n = fresh(2, ck2)
    assert n == 0
    same(two_alone, again)


@pytest.mark.parametrize(("after", "named", "refined"), [
    ({"A": 9.0}, "A", {"A"}),                            # the leader improves: nobody else is refined
    ({"A": 12.0, "B": 10.5}, "B", {"A", "B"}),           # refined, the leader falls behind B; B refined wins
    ({"A": 12.0, "B": 13.0, "C": 11.0}, "C", {"A", "B", "C"}),  # each one below the best refined gets its turn
    ({"A": 11.2, "B": 12.0}, "A", {"A", "B"}),           # B's rounds cost it: A, refined first, stays named
])
def test_the_cause_is_named_among_candidates_refined_alike(after: dict, named: str, refined: set) -> None:
    """The naming rule of equal refinement (calibration.diagnosis.refine_equally), isolated: candidates A, B, C
    with held-out losses 10, 11, 11.5 before refinement and the losses refinement gives them (``after``). The
    leader is refined; any candidate below the best refined loss is refined next; the best refined is named; one
    never below it is never refined. Reference: the rule as docs/case-studies.md states it, on losses given by hand
    (no rig)."""
    from types import SimpleNamespace

    before = {"A": 10.0, "B": 11.0, "C": 11.5}
    pool = [SimpleNamespace(name=n, heldout_loss=np.array([v / 2, v / 2])) for n, v in before.items()]
    calls = []

    def refine(f: SimpleNamespace) -> tuple[SimpleNamespace, dict]:
        calls.append(f.name)
        return SimpleNamespace(name=f.name, heldout_loss=np.array([after[f.name]])), {"converged": True}

    fits, records, lead = diagnosis.refine_equally(pool, refine)
    assert lead.name == named
    assert set(fits) == set(records) == refined == set(calls)
    assert len(calls) == len(set(calls))  # each at most once
