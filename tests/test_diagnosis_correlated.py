"""Generalized least squares in the diagnosis: reductions that share a rigid reference run share its error.

References the code does not produce: the covariance of reductions against one rigid draught R in closed form,
Cov(red_i, red_j) = (100 P_i / R^2)(100 P_j / R^2) var(R) (first-order propagation of red = 100 (1 - P / R)); the
chi^2 distribution of r^T C^-1 r for r ~ N(0, C) and the variance 2 tr(C^2) of the unwhitened sum r^T r; linear
algebra by ``numpy.linalg.solve`` for the marginal (fold) losses; and a quasi-static soil bin written here (not
warpdem's DEM) whose data carry nothing but one rigid reference's error.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import quasi_static_bin
from scipy import stats

from calibration import diagnosis
from calibration.measured import Measured, from_paper, load
from calibration.rig_models import SoilBinRigModel
from scenes import paper

SPRINGS = np.array(paper.SPRING_COUNTS)
"""Table 3's spring counts (4-32)."""


def _shared_reference_corr(passive: np.ndarray, passive_se: np.ndarray, rigid: float, rigid_se: float
                           ) -> tuple[np.ndarray, np.ndarray]:
    """Closed form: reductions red_i = 100 (1 - P_i / R) [%] of passive draughts P_i (n,) [N] with standard errors
    passive_se (n,) [N] against one rigid draught R [N] of standard error rigid_se [N]. Returns each reduction's
    standard error sigma (n,) [percentage points] and their correlation (n, n)."""
    grad_p = 100.0 / rigid  # |d red / d P_i|
    grad_r = 100.0 * passive / rigid**2  # d red_i / d R
    cov = np.diag((grad_p * passive_se) ** 2) + np.outer(grad_r, grad_r) * rigid_se**2
    sigma = np.sqrt(np.diag(cov))
    return sigma, cov / np.outer(sigma, sigma)


def test_a_shared_reference_is_whitened_to_chi2() -> None:
    """Monte Carlo against the closed form. The Yade twin's shape (eight passive draughts of 91-124 N, 2-5 N each,
    against one rigid draught of 126 +- 5.3 N): reductions correlate by about 0.5-0.6. Residuals drawn with that
    correlation (Cholesky factor, not the diagnosis' transform), 20000 draws:

    - whitened, r^T C^-1 r has mean n = 8 (|mean - 8| < 4 SE, SE = sqrt(2 n / N) = 0.028) and its chi^2(8)
      p-values are uniform (Kolmogorov-Smirnov p > 0.01: the seed is fixed, and a uniform sample falls below that
      once in a hundred seeds);
    - unwhitened, r^T r keeps the mean 8 (unit diagonal) but its variance is 2 tr(C^2), not 2 n: inflated by
      tr(C^2) / n, here 3.1 (within 10 %: the sample variance of a quadratic form of this kurtosis has a
      relative SE below 3 % at N = 20000), and its chi^2(8) p-values are far from uniform (KS p < 1e-6)."""
    passive = np.array([123.5, 108.3, 113.3, 111.4, 105.5, 101.9, 91.5, 96.3])
    passive_se = np.array([4.8, 4.2, 3.3, 5.2, 4.0, 3.7, 3.3, 3.9])
    _, corr = _shared_reference_corr(passive, passive_se, 126.25, 5.27)
    n, draws = len(passive), 20000
    rng = np.random.default_rng(1)
    r = rng.standard_normal((draws, n)) @ np.linalg.cholesky(corr).T  # (draws, n) ~ N(0, C)
    white = diagnosis.Whitening(corr, np.zeros((n, 1)))
    loss = white.losses(r[:, :, None]).sum(axis=-1)
    assert abs(loss.mean() - n) < 4 * math.sqrt(2 * n / draws)
    assert stats.kstest(stats.chi2.sf(loss, n), "uniform").pvalue > 0.01
    plain = np.sum(r**2, axis=1)
    inflation = np.trace(corr @ corr) / n
    assert inflation == pytest.approx(3.1, abs=0.05)
    assert abs(plain.mean() - n) < 4 * math.sqrt(2 * np.trace(corr @ corr) / draws)
    assert plain.var(ddof=1) / (2 * n) == pytest.approx(inflation, rel=0.10)
    assert stats.kstest(stats.chi2.sf(plain, n), "uniform").pvalue < 1e-6


def test_whitened_losses_are_the_generalized_least_squares_losses() -> None:
    """Against numpy.linalg.solve: the configurations' shares sum to r^T C^-1 r, a fold's training loss is
    r_-j^T (C_-j,-j)^-1 r_-j (C marginalized over the training configurations), an unmeasured value drops out (its
    rows and columns marginalized), and the shares of a permuted problem are the permuted shares (the symmetric
    square root does not depend on the configurations' order)."""
    rng = np.random.default_rng(3)
    n, n_obs = 5, 2
    a = rng.standard_normal((n * n_obs, n * n_obs))
    cov = a @ a.T + n * n_obs * np.eye(n * n_obs)
    d = np.sqrt(np.diag(cov))
    corr = cov / np.outer(d, d)
    measured = np.ones((n, n_obs))
    measured[2, 1] = np.nan
    r = rng.standard_normal((n, n_obs))
    r[2, 1] = 0.0  # ``residuals`` scores a missing measurement 0
    white = diagnosis.Whitening(corr, measured)
    ok = ~np.isnan(measured).reshape(-1)

    def gls(mask: np.ndarray) -> float:
        m = mask & ok
        x = r.reshape(-1)[m]
        return float(x @ np.linalg.solve(corr[np.ix_(m, m)], x))

    assert white.losses(r).sum() == pytest.approx(gls(np.ones(n * n_obs, bool)), rel=1e-12)
    assert white.chi2(r) == pytest.approx(gls(np.ones(n * n_obs, bool)), rel=1e-12)
    for j in range(n):
        train = np.repeat(np.arange(n) != j, n_obs)
        assert white.train_losses(r)[j] == pytest.approx(gls(train), rel=1e-12)
    perm = rng.permutation(n)
    idx = (perm[:, None] * n_obs + np.arange(n_obs)).reshape(-1)
    permuted = diagnosis.Whitening(corr[np.ix_(idx, idx)], measured[perm])
    np.testing.assert_allclose(permuted.losses(r[perm]), white.losses(r)[perm], rtol=1e-10)
    with pytest.raises(ValueError, match="positive definite"):
        diagnosis.Whitening(np.ones((2, 2)), np.zeros((2, 1)))


def _bin(pitch_gain: float = 0.01, sem: float = 0.3):  # noqa: ANN202
    """A quasi-static soil bin (``conftest.quasi_static_bin``, a simulator for SoilBinRigModel): the rigid tool draws
    300 N, the passive one 300 N (1 - 0.004 n) (1 + pitch_gain x mount_pitch [deg]) (the clamp's attitude acts on
    the passive runs alone), every steady mean with standard error ``sem`` [N]; the displacement follows the
    draught."""

    def run(config, springs, speeds, knobs, soil):  # noqa: ANN001, ANN202
        pitch = [float((knobs or {}).get("mount_pitch", [0.0] * len(springs))[w]) if n else 0.0
                 for w, n in enumerate(springs)]
        draught = [300.0 * (1 - 0.004 * n) * (1 + pitch_gain * p) if n else 300.0 for n, p in zip(springs, pitch,
                                                                                                strict=True)]
        stiffness = [float(knobs["stiffness"][w]) if n else math.inf for w, n in enumerate(springs)]
        return quasi_static_bin(springs, speeds, draught, stiffness, sem=sem, arm_ratio=0.25 / 0.1)

    return run


def test_the_soil_bin_states_its_shared_rigid_references() -> None:
    """The rig model's correlation against the closed form from the tables' own columns. Yade's clean twin table:
    one rigid ensemble (126.25 +- 5.27 N) for all eight rows (correlations 0.48-0.62), and the quasi-static bin's
    one rigid run at 0.62 m/s (300 +- 0.3 N) on the simulation's side, added; rows' passive draughts P from the
    table's draught_mean (the code uses the P each reduction implies: equal to the table's rounding, 1e-3).
    Table 3: each row has a rigid run of its own (the data's reductions independent); the simulation's rigid run
    at 0.68 m/s serves 8 and 16 springs, at 0.62 m/s 12 and 28, nothing else."""
    m = load("benchmarks/yade/passive_twin_table_clean")
    rig = SoilBinRigModel(m, simulator=_bin(), observables=("reduction",))
    s = m.summary
    passive_sim = 300.0 * (1 - 0.004 * SPRINGS)
    data_load = 100 * s["draught_mean"] * s["rigid_draught_mean_se"] / s["rigid_draught_mean"] ** 2
    sim_load = 100 * passive_sim * 0.3 / 300.0**2
    sim_sigma = 100 * np.hypot(0.3, passive_sim / 300.0 * 0.3) / 300.0
    sigma = np.hypot(s["reduction_se"], sim_sigma)
    np.testing.assert_allclose(rig.sigma[:, 0], sigma, rtol=1e-12)
    expected = (np.outer(data_load, data_load) + np.outer(sim_load, sim_load)) / np.outer(sigma, sigma)
    np.fill_diagonal(expected, 1.0)
    np.testing.assert_allclose(rig.residual_correlation(), expected, rtol=1e-3)
    assert 0.47 < expected[~np.eye(8, dtype=bool)].min() and expected[~np.eye(8, dtype=bool)].max() < 0.63

    t3 = SoilBinRigModel(from_paper("soil-bin"), simulator=_bin())
    assert t3.observables == ("reduction", "displacement_mean")
    corr = t3.residual_correlation()[::2, ::2]  # the reductions (observable 0 of 2)
    sigma = t3.sigma[:, 0]
    load3 = 100 * passive_sim * 0.3 / 300.0**2
    pairs = {(1, 3), (3, 1), (2, 6), (6, 2)}  # 8 & 16 springs (0.68 m/s), 12 & 28 (0.62 m/s)
    for i in range(8):
        for j in range(8):
            want = 1.0 if i == j else load3[i] * load3[j] / (sigma[i] * sigma[j]) if (i, j) in pairs else 0.0
            assert corr[i, j] == pytest.approx(want, rel=1e-12, abs=1e-15), (i, j)
    np.testing.assert_array_equal(t3.residual_correlation()[1::2, :][:, 1::2], np.eye(8))  # displacements


def test_a_rigid_reference_below_its_stated_share_is_refused() -> None:
    """A row's stated reduction uncertainty must hold its rigid reference's share, 100 P s_R / R^2: a caller's
    0.5 points against a rigid SE of 5.27 N (about 3-4 points of each reduction) is refused."""
    m = load("benchmarks/yade/passive_twin_table_clean")
    with pytest.raises(Exception, match="below its rigid reference's own part"):
        SoilBinRigModel(m, simulator=_bin(), observables=("reduction",), uncertainty={"reduction": 0.5})


def _one_reference_data(seed: int, rigid_error: float) -> Measured:
    """Table 3's spring counts at 0.62 m/s, the quasi-static bin's draughts (:func:`_bin`, no hidden effect), each
    passive draught measured with 2 N of noise (``seed``) and every reduction taken against one rigid draught of
    300 N measured ``rigid_error`` standard errors (3 N) off; reduction_se propagated from both, as the twin's
    tables are."""
    rng = np.random.default_rng(seed)
    se_p, se_r = 2.0, 3.0
    rigid = 300.0 + rigid_error * se_r
    passive = 300.0 * (1 - 0.004 * SPRINGS) + se_p * rng.standard_normal(len(SPRINGS))
    k = np.array([paper.ringing_row(int(n))["stiffness_n_per_m"] for n in SPRINGS])
    return Measured({"springs": SPRINGS.astype(float), "speed": np.full(len(SPRINGS), 0.62), "stiffness": k,
                     "reduction": 100 * (1 - passive / rigid),
                     "reduction_se": 100 * np.hypot(se_p, passive / rigid * se_r) / rigid,
                     "draught_mean": passive, "rigid_draught_mean": np.full(len(SPRINGS), rigid),
                     "rigid_draught_mean_se": np.full(len(SPRINGS), se_r)}, {})


def test_one_rigid_references_error_is_no_discrepancy(tmp_path) -> None:  # noqa: ANN001
    """Data with no hidden effect whose eight reductions share one rigid draught measured 2.5 of its standard
    errors high (a 1-in-80 draw, once for all rows): every measured reduction is high by about 2.3 points against
    1.1-1.2 of stated uncertainty. The clamp's attitude (mount_pitch, within its 3 deg) lowers the passive
    draughts in proportion, the same pattern as a rigid draught that is too high.

    Taken as independent, the residuals fail the noise gate (seed 0: chi^2 28 on 8, p 5e-4) and mount_pitch is
    named. With the shared reference's covariance the baseline's loss is r^T C^-1 r (checked against
    numpy.linalg.solve on the closed-form covariance, to 1e-3: the simulation's SE enters through the rig's
    rounding-free propagation), seed 0: 7.5, p 0.48, above the gate's 0.01, and the verdict is "no significant
    discrepancy". Over seeds 0-19 of the passive noise (not run here): independent, p 2e-9 to 7e-4 and mount_pitch
    named 19 times (once it is left at its bound); correlated, mount_pitch never named, "no significant
    discrepancy" 17 times and "unexplained residual" 3 times (p 0.004-0.007: conditional on a 2.5-SE reference
    the whitened loss has mean about 8 + 2.5^2 s / (1 + s) = 14, s = u^T D^-1 u, about 15, the shared part's weight, so
    its tail crosses the gate more often than 1 %)."""
    data = _one_reference_data(seed=0, rigid_error=2.5)
    settings = diagnosis.DiagnosisSettings(rounds=3, mechanisms=("mount_pitch",))
    indep = SoilBinRigModel(data, simulator=_bin(), observables=("reduction",))
    indep.residual_correlation = lambda: None  # the residuals taken as independent
    d_indep = diagnosis.diagnose(indep, settings)
    assert d_indep.noise_p_baseline < 1e-3
    assert d_indep.cause == ("mount_pitch",), (d_indep.verdict, d_indep.cause)

    rig = SoilBinRigModel(data, simulator=_bin(), observables=("reduction",))
    d = diagnosis.diagnose(rig, settings)
    assert d.verdict == "no significant discrepancy" and d.cause == ()
    passive_sim = 300.0 * (1 - 0.004 * SPRINGS)
    red_sim = 100 * (1 - passive_sim / 300.0)
    sim_sem = 100 * np.hypot(0.3, passive_sim / 300.0 * 0.3) / 300.0
    s = data.summary
    sigma_data, _ = _shared_reference_corr(s["draught_mean"], np.full(8, 2.0), float(s["rigid_draught_mean"][0]),
                                           3.0)
    grad = 100 * s["draught_mean"] / s["rigid_draught_mean"] ** 2
    grad_sim = 100 * passive_sim / 300.0**2
    cov = (np.diag(sigma_data**2 - grad**2 * 9.0) + np.outer(grad, grad) * 9.0
           + np.diag(sim_sem**2 - grad_sim**2 * 0.09) + np.outer(grad_sim, grad_sim) * 0.09)
    e = red_sim - s["reduction"]
    chi2 = float(e @ np.linalg.solve(cov, e))
    assert d.baseline.heldout_loss.sum() == pytest.approx(chi2, rel=1e-3)
    assert d.noise_p_baseline == pytest.approx(stats.chi2.sf(chi2, 8), rel=1e-2)
    assert d.noise_p_baseline > 0.01
    from calibration import diagnosis_report

    assert "generalized least-squares r^T C^-1 r" in diagnosis_report.write(d, tmp_path).read_text()


def test_independent_residuals_are_scored_as_before() -> None:
    """A rig without correlated residuals (the soil bin's displacements alone) is diagnosed with plain sums of
    squares: every fit's held-out loss and chi^2 are sum r^2 of its residuals, to the bit."""
    k = np.array([paper.ringing_row(int(n))["stiffness_n_per_m"] for n in SPRINGS])
    run = _bin()(None, list(SPRINGS), [0.62] * 8, {"stiffness": list(k)}, None)
    x = np.array([r["displacement_mean"] for r in run.steady])
    data = Measured({"springs": SPRINGS.astype(float), "speed": np.full(8, 0.62), "stiffness": k,
                     "displacement_mean": x - 3e-4 + 2e-5 * np.random.default_rng(4).standard_normal(8)}, {})
    rig = SoilBinRigModel(data, simulator=_bin(), uncertainty={"displacement_mean": 2e-5})
    assert rig.residual_correlation() is None
    d = diagnosis.diagnose(rig, diagnosis.DiagnosisSettings(rounds=3, mechanisms=("sensor_offset",)))
    assert d.correlation is None and d.cause == ("sensor_offset",)
    for f in d.fits.values():
        r_held = diagnosis.residuals(f.pred_heldout, rig.measured, rig.sigma)
        r_in = diagnosis.residuals(f.pred_all, rig.measured, rig.sigma)
        np.testing.assert_array_equal(f.heldout_loss, np.sum(r_held**2, axis=1))
        assert f.chi2_in == float(np.sum(r_in**2))
