"""Tests of scenes.analysis: ringing test eqs. (3)-(5), calibration errors and fitness eqs. (7)-(11), the FFT
analysis of section 2.4, the steady state after 0.5 m of travel and the Mohr-Coulomb fit.

Reference paper: shared/paper/000_f83b7bc97235a7fb.txt; Table 2 values from shared/data/ringing_test_table2.csv.
Synthetic signals are sampled at 2400 Hz, the rate of the paper's ringing-test strain gauge (section 2.1.1).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest

from scenes import analysis

FS = 2400.0  # Hz, the paper's sampling rate (section 2.1.1)

#: Table 2 of the paper (ringing test, 200 N preload), copied from ringing_test_table2.csv:
#: springs, measured f_d [Hz], measured zeta [-], calibrated (simulated) f_d [Hz], calibrated zeta [-],
#: fitness [-], RE_freq [-], RE_damp [-] (fractions, relative to the simulated value, see the CSV's comments)
TABLE2 = [
    (4, 9.37499, 0.12396, 9.43821, 0.12296, 18304.2, 0.00669, 0.00815),
    (8, 7.00389, 0.08929, 7.02043, 0.08848, 46544.9, 0.00235, 0.00912),
    (12, 6.11854, 0.04162, 5.98601, 0.04151, 17831.7, 0.02213, 0.00253),
    (16, 6.09137, 0.20270, 6.14112, 0.19256, 2344.3, 0.00810, 0.05264),
    (20, 6.02258, 0.07071, 5.83839, 0.07118, 4743.8, 0.03154, 0.00668),
    (24, 6.80369, 0.27364, 6.88610, 0.28501, 2096.1, 0.01196, 0.03986),
    (28, 5.48195, 0.11458, 5.38528, 0.11465, 93484.5, 0.01795, 0.00059),
    (32, 4.78087, 0.17708, 4.84508, 0.17803, 14082.1, 0.01325, 0.00535),
]
ROW16 = TABLE2[3]
MEASURED = [pytest.param(row[1], row[2], id=f"{row[0]}springs") for row in TABLE2]

PRELOAD = 200.0  # N, the ringing test's static load (section 2.1.1): the unknown offset of the force signal
AMPLITUDE = 40.0  # N, initial ringing amplitude of the synthetic force signal
NOISE = 0.01 * AMPLITUDE  # N, Gaussian noise of 1 % of the amplitude


def _table2_csv() -> Path | None:
    root = Path(__file__).resolve().parents[1]
    for candidate in (root / "scenes" / "data", root.parent / "shared" / "data"):
        path = candidate / "ringing_test_table2.csv"
        if path.is_file():
            return path
    return None


def _ringing(
    f_d: float, zeta: float, *, seed: int = 0, rest: float = 0.0, hit: bool = False, noise: float = NOISE
) -> tuple[np.ndarray, np.ndarray]:
    """Force [N] of a free damped vibration PRELOAD + A exp(-zeta w_n s) sin(w_d s + phi) + noise, s = t - rest,
    at rest (PRELOAD + noise) before; with hit=True a hammer impulse at s = 0 adds a 3 A, 2 ms spike and a 0.5 A
    150 Hz shank ringing decaying in 5 ms. Lasts until the envelope is down by exp(-6). Returns t (n,), x (n,)."""
    omega_d = 2.0 * math.pi * f_d
    omega_n = omega_d / math.sqrt(1.0 - zeta**2)
    t = np.arange(0.0, rest + max(2.0, 6.0 / (zeta * omega_n)), 1.0 / FS)
    s = t - rest
    free = s >= 0.0
    phase = 0.0 if hit else 0.3  # a hammer hit starts the vibration from equilibrium
    x = np.where(free, AMPLITUDE * np.exp(-zeta * omega_n * s) * np.sin(omega_d * s + phase), 0.0)
    if hit:
        x += 3.0 * AMPLITUDE * np.exp(-0.5 * (s / 0.002) ** 2)
        x += np.where(free, 0.5 * AMPLITUDE * np.exp(-s / 0.005) * np.sin(2.0 * math.pi * 150.0 * s), 0.0)
    rng = np.random.default_rng(seed)
    return t, PRELOAD + x + noise * rng.standard_normal(t.size)


def test_table2_constants_match_csv():
    # Reference: ringing_test_table2.csv (Table 2); guards the copy above against transcription slips.
    path = _table2_csv()
    if path is None:
        pytest.skip("ringing_test_table2.csv not found next to the repository")
    with path.open() as handle:
        rows = list(csv.DictReader(line for line in handle if not line.startswith("#")))
    columns = (
        "springs",
        "measured_freq_hz",
        "measured_damping",
        "calibrated_freq_hz",
        "calibrated_damping",
        "fitness",
        "re_freq",
        "re_damp",
    )
    from_csv = [tuple(float(row[c]) for c in columns) for row in rows]
    assert from_csv == [tuple(float(v) for v in row) for row in TABLE2]


# ---------------------------------------------------------------------------------------------------------------------
# Ringing test, eqs. (3)-(5)
# ---------------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("f_d", "zeta"), MEASURED)
def test_ringdown_recovers_table2_frequency_and_damping(f_d, zeta):
    # Reference: the measured f_d and zeta of each Table 2 row, synthesised as x = offset + A e^(-zeta w_n t)
    # sin(w_d t + phi) + 1 % noise. Tolerance 1 %: over 100 noise seeds the estimator's scatter is at most 0.15 %
    # (f) and 0.4 % (zeta, worst for the 24-spring zeta = 0.27 that rings for barely two cycles), so 1 % is
    # about 2.5 standard deviations there and far more elsewhere; the offset scatters by < 0.15 % of A.
    t, x = _ringing(f_d, zeta)
    result = analysis.ringdown(t, x)
    assert result.frequency_hz == pytest.approx(f_d, rel=0.01)
    assert result.damping_ratio == pytest.approx(zeta, rel=0.01)
    assert result.offset == pytest.approx(PRELOAD, abs=0.005 * AMPLITUDE)
    assert result.period_s == pytest.approx(1.0 / result.frequency_hz, rel=1e-12)  # eq. (3)
    assert result.damping_ratio == pytest.approx(  # eq. (5)
        result.log_decrement / math.sqrt(4.0 * math.pi**2 + result.log_decrement**2), rel=1e-12
    )
    assert result.peak_times.shape == result.peak_amplitudes.shape == (result.n_cycles_used + 1,)
    assert result.n_cycles_used >= 1


@pytest.mark.parametrize(("f_d", "zeta"), [MEASURED[2], MEASURED[3], MEASURED[5]])  # zeta 0.04, 0.20, 0.27
def test_ringdown_skips_rest_and_hammer_hit(f_d, zeta):
    # Reference: as above, after 0.25 s at rest and a hammer hit (3 A spike, 150 Hz shank ringing) that starts
    # the vibration. The hit must not be taken as a peak: the first peak used is the first maximum of the free
    # vibration, a quarter period after the hit (within the 2 ms spike width). Tolerances as above (1 %).
    rest = 0.25
    t, x = _ringing(f_d, zeta, rest=rest, hit=True)
    result = analysis.ringdown(t, x)
    assert result.frequency_hz == pytest.approx(f_d, rel=0.01)
    assert result.damping_ratio == pytest.approx(zeta, rel=0.01)
    assert result.offset == pytest.approx(PRELOAD, abs=0.005 * AMPLITUDE)
    first_max = rest + math.atan(math.sqrt(1.0 - zeta**2) / zeta) / (2.0 * math.pi * f_d)  # d/dt(e^-at sin wt) = 0
    assert result.peak_times[0] == pytest.approx(first_max, abs=0.002)


def test_ringdown_paper_formula_on_noise_free_peaks():
    # Reference: eq. (4) on the refined peaks of a noise-free 12-spring signal (zeta = 0.0416, the lightest damping,
    # where the most peaks are used) must equal Lambda = 2 pi zeta / sqrt(1 - zeta^2) of the synthetic signal.
    # Tolerance 1e-3: the parabola windows sit differently on the sample grid at each peak, which was measured to
    # change Lambda by 1e-4; peak spacing gives T_d to 1e-5. The fit (n_cycles=None) is exact to round-off (1e-9).
    f_d, zeta = TABLE2[2][1], TABLE2[2][2]
    exact = 2.0 * math.pi * zeta / math.sqrt(1.0 - zeta**2)
    t, x = _ringing(f_d, zeta, noise=0.0)
    for n in (1, 3):
        result = analysis.ringdown(t, x, n_cycles=n)
        assert result.n_cycles_used == n
        assert result.log_decrement == pytest.approx(exact, rel=1e-3)
        assert result.frequency_hz == pytest.approx(f_d, rel=1e-4)
        a = result.peak_amplitudes
        assert result.log_decrement == pytest.approx(math.log(a[0] / a[n]) / n, rel=1e-12)  # eq. (4) verbatim
    fitted = analysis.ringdown(t, x, offset=PRELOAD)
    assert fitted.log_decrement == pytest.approx(exact, rel=1e-9)
    assert fitted.frequency_hz == pytest.approx(f_d, rel=1e-9)
    assert fitted.offset == PRELOAD
    # successive peaks decay by exactly e^-Lambda (eq. 4 for every n)
    np.testing.assert_allclose(np.diff(np.log(fitted.peak_amplitudes)), -exact, rtol=1e-3)


def test_ringdown_rejects_a_single_peak():
    # Reference: eq. (4) needs A_1 and A_{n+1}, n >= 1: a single bump has no decrement.
    t = np.arange(0.0, 1.0, 1.0 / FS)
    x = 5.0 + np.exp(-0.5 * ((t - 0.5) / 0.05) ** 2)
    with pytest.raises(ValueError, match="at least 2 peaks"):
        analysis.ringdown(t, x)


def test_ringdown_rejects_bad_inputs():
    # Reference: the input contract of ringdown (messages name the parameter and the value).
    t, x = _ringing(6.0, 0.1)
    x_nan = x.copy()
    x_nan[100] = np.nan
    with pytest.raises(ValueError, match=r"x has 1 non-finite value\(s\), first at index 100"):
        analysis.ringdown(t, x_nan)
    with pytest.raises(ValueError, match="shapes must match"):
        analysis.ringdown(t, x[:-1])
    t_bad = t.copy()
    t_bad[10] = t_bad[9]
    with pytest.raises(ValueError, match=r"t must be strictly increasing, but t\[9\]"):
        analysis.ringdown(t_bad, x)
    with pytest.raises(ValueError, match="n_cycles=50 needs 51 peaks"):
        analysis.ringdown(t, x, n_cycles=50)
    with pytest.raises(ValueError, match="n_cycles must be None or an integer >= 1, got 0"):
        analysis.ringdown(t, x, n_cycles=0)


def test_noise_std_estimates_white_noise_on_a_smooth_signal():
    # Reference: std 0.3 Gaussian noise on a 6 Hz tone at 2400 Hz. Tolerance 5 %: the MAD-based estimate from
    # 12000 samples scatters by about 1.1 % (relative std 1.1/sqrt(n)); the tone adds (2 pi 6/2400)^3 A, negligible.
    t = np.arange(0.0, 5.0, 1.0 / FS)
    x = 10.0 * np.sin(2.0 * math.pi * 6.0 * t) + 0.3 * np.random.default_rng(3).standard_normal(t.size)
    assert analysis.noise_std(x) == pytest.approx(0.3, rel=0.05)


def test_log_decrement_and_damping_ratio_are_inverse():
    # Reference: eq. (5) and its inverse Lambda = 2 pi zeta / sqrt(1 - zeta^2); zeta = 0.5 gives Lambda = 2 pi/sqrt(3).
    assert analysis.log_decrement_from_damping_ratio(0.5) == pytest.approx(2.0 * math.pi / math.sqrt(3.0), rel=1e-14)
    assert analysis.damping_ratio_from_log_decrement(2.0 * math.pi / math.sqrt(3.0)) == pytest.approx(0.5, rel=1e-14)
    zetas = np.array([row[2] for row in TABLE2])
    lams = analysis.log_decrement_from_damping_ratio(zetas)
    np.testing.assert_allclose(analysis.damping_ratio_from_log_decrement(lams), zetas, rtol=1e-14)
    with pytest.raises(ValueError, match="zeta must be finite with"):
        analysis.log_decrement_from_damping_ratio(1.0)


# ---------------------------------------------------------------------------------------------------------------------
# Calibration errors and fitness, eqs. (7)-(11)
# ---------------------------------------------------------------------------------------------------------------------


def test_relative_error_conventions_against_table2_row16():
    # Reference: Table 2, 16 springs. Its RE columns are |sim - target| / sim (fractions): re_damp = 0.05264, while
    # eqs. (8)-(9) (relative to the target) give 0.0500. Tolerance 2e-3: sim and target are printed to 5 decimals,
    # i.e. the damping difference 0.01014 is known to +-1e-5 (0.1 %); the two conventions differ by 5 %.
    _, f_target, d_target, f_sim, d_sim, fitness, re_freq, re_damp = ROW16
    assert analysis.relative_error(d_sim, d_target, relative_to="sim") == pytest.approx(re_damp, rel=2e-3)
    assert analysis.relative_error(f_sim, f_target, relative_to="sim") == pytest.approx(re_freq, rel=2e-3)
    by_target = analysis.relative_error(d_sim, d_target)
    assert by_target == pytest.approx(abs(d_sim - d_target) / d_target, rel=1e-14)
    assert by_target == pytest.approx(0.0500, abs=1e-4)
    assert by_target != pytest.approx(re_damp, rel=0.02)
    sims = np.array([row[4] for row in TABLE2])
    targets = np.array([row[2] for row in TABLE2])
    np.testing.assert_allclose(analysis.relative_error(sims, targets), np.abs(sims - targets) / targets, rtol=1e-14)
    with pytest.raises(ValueError, match='relative_to must be "target" or "sim"'):
        analysis.relative_error(1.0, 2.0, relative_to="mean")


def test_ringing_fitness_reproduces_table2_row16():
    # Reference: eq. (7) with Table 2's 16-spring REs gives its fitness 2344.3. Tolerance 1e-3: re_freq = 0.00810
    # has 3 significant figures (+-0.06 %).
    _, _, _, _, _, fitness, re_freq, re_damp = ROW16
    assert analysis.ringing_fitness(re_freq, re_damp) == pytest.approx(fitness, rel=1e-3)
    assert analysis.ringing_fitness(0.0, re_damp) == math.inf
    with pytest.raises(ValueError, match="re_freq must be a finite relative error >= 0"):
        analysis.ringing_fitness(-0.1, re_damp)


def test_draught_fitness_is_inverse_relative_error():
    # Reference: eqs. (10)-(11): fitness = 1/RE; a 5 % over- or under-prediction of a 341.56 N draught (Table 3,
    # rigid tool, 16 springs) scores 20 either way.
    target = 341.56
    for sim in (1.05 * target, 0.95 * target):
        assert analysis.draught_fitness(analysis.relative_error(sim, target)) == pytest.approx(20.0, rel=1e-12)
    assert analysis.draught_fitness(-0.05) == pytest.approx(20.0, rel=1e-12)


# ---------------------------------------------------------------------------------------------------------------------
# FFT analysis, section 2.4
# ---------------------------------------------------------------------------------------------------------------------


def test_lowpass_is_zero_phase_and_removes_300_hz():
    # Reference: 4th-order Butterworth at 100 Hz run forward and backward: gain |H|^2 = 1/(1 + (f/100)^8), no phase.
    # 10 Hz passes with gain 1 - 1e-8; 300 Hz is attenuated by 20 log10(1 + 3^8) = 76 dB (> 40 dB asked). Checked
    # away from the ends (0.25 s, many time constants of the filter's edge transient). Tolerance 1e-3 on the 10 Hz
    # tone: the 300 Hz residue is 1.6e-4, while a one-way filter's 15 deg lag at 10 Hz would give an error of 0.26.
    t = np.arange(0.0, 4.0, 1.0 / FS)
    slow = np.sin(2.0 * math.pi * 10.0 * t + 0.4)
    fast = np.sin(2.0 * math.pi * 300.0 * t)
    inner = (t > 0.25) & (t < t[-1] - 0.25)
    y = analysis.lowpass(slow + fast, FS, cutoff_hz=100.0)
    assert np.max(np.abs(y - slow)[inner]) < 1e-3
    residue = analysis.lowpass(fast, FS, cutoff_hz=100.0)
    assert 20.0 * math.log10(np.std(residue[inner]) / np.std(fast)) < -40.0
    with pytest.raises(ValueError, match="Nyquist"):
        analysis.lowpass(slow, FS, cutoff_hz=1200.0)


def test_spectrum_amplitude_of_a_tone_on_a_bin():
    # Reference: a tone A sin(2 pi f t) on a bin (8 Hz over 5 s = 40 bins) reads A after the Hann coherent-gain
    # correction; the offset and drift are removed by detrending. Tolerance 1e-5: the straight line fitted to the
    # tone itself (it is not orthogonal to a ramp) leaks 4e-7 into the bin.
    t = np.arange(0.0, 5.0, 1.0 / FS)
    x = 300.0 + 2.0 * t + 1.5 * np.sin(2.0 * math.pi * 8.0 * t)
    freqs, amplitude = analysis.spectrum(t, x)
    k = int(np.argmax(amplitude))
    assert freqs[k] == pytest.approx(8.0, rel=1e-12)
    assert amplitude[k] == pytest.approx(1.5, rel=1e-5)
    assert amplitude[0] < 1e-3  # the 300 N offset is gone
    t_bad = t.copy()
    t_bad[7] += 0.1 / FS
    with pytest.raises(ValueError, match="uniformly sampled"):
        analysis.spectrum(t_bad, x)


def test_dominant_frequencies_find_tones_harmonic_and_drop_300_hz():
    # Reference: 2 sin(2 pi 3.2 t) + 0.7 sin(2 pi 8.34 t) + 0.3 sin(2 pi 16.68 t) (16.68 = 2 x 8.34, the 16-spring
    # tool's displacement peak in section 3.5.2) + 1.0 sin(2 pi 300 t) + 320 N + noise 0.05 over 7.3 s: the
    # tones fall 0.36, -0.12 and -0.24 bins off the 0.137 Hz grid, so without interpolation the Hann scalloping
    # would misread amplitudes by up to 15 %. Tolerance 1 %: the interpolation is exact for an isolated tone
    # (leakage between tones > 30 bins apart is < 1e-5); noise adds about 7e-4 per bin, 0.25 % of the weakest tone.
    t = np.arange(0.0, 7.3, 1.0 / FS)
    expected = [(3.2, 2.0, 0.1), (8.34, 0.7, 1.0), (16.68, 0.3, 2.0)]
    x = 320.0 + sum(a * np.sin(2.0 * math.pi * f * t + p) for f, a, p in expected)
    x += np.sin(2.0 * math.pi * 300.0 * t) + 0.05 * np.random.default_rng(1).standard_normal(t.size)
    tones = analysis.dominant_frequencies(t, x, n=5, cutoff_hz=100.0)
    for tone, (f, a, _) in zip(tones[:3], expected, strict=True):
        assert tone.frequency_hz == pytest.approx(f, rel=0.01)
        assert tone.amplitude == pytest.approx(a, rel=0.01)
    assert [(tone.harmonic_of, tone.multiple) for tone in tones[:3]] == [(None, 1), (None, 1), (1, 2)]
    assert all(tone.frequency_hz <= 100.0 and tone.amplitude < 0.01 for tone in tones[3:])  # noise, no 300 Hz


# ---------------------------------------------------------------------------------------------------------------------
# Steady state (section 2.2.2) and Mohr-Coulomb (section 2.3)
# ---------------------------------------------------------------------------------------------------------------------


def test_steady_state_after_half_a_metre():
    # Reference: Table 3, 16 springs: draught 317.71 +- 8.69 N at 0.68 m/s, here with a start-up transient that has
    # died out (to 5e-5) by 0.5 m of travel. Statistics must equal numpy's over travel >= 0.5 m (to round-off) and
    # the true mean within 1 N (6 standard errors 8.69/sqrt(3000)) and std within 5 % (4 x 1/sqrt(2 n)).
    speed, mean, std = 0.68, 317.71, 8.69
    t = np.arange(0.0, 2.0, 1.0 / FS)
    travel = speed * t
    x = mean * (1.0 - np.exp(-travel / 0.05)) + std * np.random.default_rng(7).standard_normal(t.size)
    result = analysis.steady_state(t, x, travel, start_travel=0.5)
    steady = travel >= 0.5
    assert result.n == np.count_nonzero(steady)
    assert result.mean == pytest.approx(np.mean(x[steady]), rel=1e-12)
    assert result.std == pytest.approx(np.std(x[steady]), rel=1e-12)
    assert result.t_start == pytest.approx(0.5 / speed, abs=1.0 / FS)
    assert result.mean == pytest.approx(mean, abs=1.0)
    assert result.std == pytest.approx(std, rel=0.05)
    with pytest.raises(ValueError, match=r"start_travel=5\.0"):
        analysis.steady_state(t, x, travel, start_travel=5.0)


def test_mohr_coulomb_recovers_cohesion_and_friction_angle():
    # Reference: the soil-bin sand at 3.96 % moisture, c = 6.4 kPa and phi = 32.3 deg (section 2.1.2). Noise-free
    # peaks must give them back to round-off and R^2 = 1; 0.5 kPa noise on 8 points must give R^2 < 1 with c within
    # 1.2 kPa and phi within 0.5 deg, 3 standard errors of the least-squares estimates (0.39 kPa and 0.16 deg).
    cohesion, phi = 6.4e3, 32.3
    sigma = np.linspace(20e3, 160e3, 8)
    tau = cohesion + sigma * math.tan(math.radians(phi))
    exact = analysis.mohr_coulomb(sigma, tau)
    assert exact.cohesion == pytest.approx(cohesion, rel=1e-9)
    assert exact.friction_angle_deg == pytest.approx(phi, rel=1e-12)
    assert exact.r2 == pytest.approx(1.0, abs=1e-12)
    noisy = analysis.mohr_coulomb(sigma, tau + 0.5e3 * np.random.default_rng(5).standard_normal(sigma.size))
    assert noisy.r2 < 1.0 - 1e-6
    assert noisy.cohesion == pytest.approx(cohesion, abs=1.2e3)
    assert noisy.friction_angle_deg == pytest.approx(phi, abs=0.5)
    with pytest.raises(ValueError, match="at least 2 samples"):
        analysis.mohr_coulomb([50e3], [40e3])
    with pytest.raises(ValueError, match="two distinct values"):
        analysis.mohr_coulomb([50e3, 50e3], [40e3, 41e3])


@pytest.mark.parametrize("phi", [0.0, 0.8])
def test_standard_error_of_a_correlated_record(phi: float) -> None:
    # Reference: an AR(1) series x_k = phi x_{k-1} + e_k has n_eff -> n (1 - phi) / (1 + phi) and its mean a
    # standard error sigma_x / sqrt(n_eff). Over 200 records of 4000 samples the spread of the means must match the
    # average reported sem within 15 % (the spread of 200 means is itself uncertain by 1/sqrt(400) = 5 %, and
    # the truncated autocorrelation sum is biased low by a few % at phi = 0.8). The same for the trend: a drift
    # b = 0.3 /s under the noise is recovered without bias (within 3 standard errors of the average) and the spread
    # of the fitted slopes matches the reported trend_sem within 15 % (OLS slope variance sigma^2 / (n_eff var t)).
    rng = np.random.default_rng(1)
    n, reps, drift = 4000, 200, 0.3
    means, sems, neffs, trends, trend_sems = [], [], [], [], []
    for _ in range(reps):
        e = rng.normal(size=n + 200)
        x = np.empty_like(e)
        x[0] = e[0]
        for k in range(1, len(e)):
            x[k] = phi * x[k - 1] + e[k]
        x = x[200:]
        t = np.arange(n) * 1e-3
        st = analysis.steady_state(t, x, np.ones(n), start_travel=0.5)
        means.append(st.mean)
        sems.append(st.sem)
        neffs.append(analysis.effective_samples(x))
        tr = analysis.steady_state(t, x + drift * t, np.ones(n), start_travel=0.5)
        trends.append(tr.trend)
        trend_sems.append(tr.trend_sem)
    assert np.mean(neffs) == pytest.approx(n * (1 - phi) / (1 + phi), rel=0.15)
    assert np.mean(sems) == pytest.approx(np.std(means), rel=0.15)
    assert np.mean(trends) == pytest.approx(drift, abs=3 * np.std(trends) / np.sqrt(reps))
    assert np.mean(trend_sems) == pytest.approx(np.std(trends), rel=0.15)


def test_plateau_fit_recovers_a_known_approach_and_its_uncertainty():
    # Reference: the closed form D(x) = 350 - 250 exp(-x / 0.25) N sampled by 40 runs at 2 mm of travel each, plus
    # white noise of 60 N per sample (a 7 mm soil's draught scatter). Each 5 cm bin of one run averages 25 samples
    # (bin noise 12 N, 1.9 N for 40 runs), so the fit must land within 3 of its own standard errors of the true
    # plateau and length, and those errors must be of the size the noise implies (not tiny, not huge). A window
    # mean from 0.5 m (two lengths) lies below the plateau by the closed form's mean gap over its bins (0.5-1.15 m:
    # the last whole bin ends there).
    rng = np.random.default_rng(3)
    x = np.tile(np.arange(0.0, 1.2, 0.002)[:, None], (1, 40))
    truth = 350.0 - 250.0 * np.exp(-x / 0.25)
    fit = analysis.plateau_fit(x, truth + rng.normal(0.0, 60.0, x.shape))
    assert abs(fit.plateau - 350.0) < 3 * fit.plateau_se and 0.3 < fit.plateau_se < 3.0, fit
    assert abs(fit.length - 0.25) < 3 * fit.length_se and fit.length_se < 0.02, fit
    gap = 250.0 * 0.25 * (math.exp(-0.5 / 0.25) - math.exp(-1.15 / 0.25)) / 0.65  # mean gap over 0.5-1.15 m
    assert fit.window_mean == pytest.approx(350.0 - gap, abs=3.0)  # 3 N: 14 bins of 40 runs' 12 N bin noise, x3
    assert fit.n_worlds == 40 and fit.levels_off
    with pytest.raises(analysis.InputError, match="n >= 2 runs"):
        analysis.plateau_fit(x[:, :1], truth[:, :1])
    with pytest.raises(analysis.InputError, match="at least four"):
        analysis.plateau_fit(x[:100], truth[:100])


def test_plateau_fit_says_when_the_draught_does_not_level_off():
    # Reference: a draught that rises along a straight line, D(x) = 300 + 40 x N, over the 1.2 m of the test above
    # (same runs, samples and noise) has no plateau to find: the exponential's length is not identified (the fit
    # either runs it past the fitted travel or cannot pin it to better than half itself), and the straight line
    # through the bins must recover the slope within 3 of its own standard error, that error being of the size the
    # bins' noise implies (about 1.9 N per bin over 0.8 m: 1-4 N/m).
    rng = np.random.default_rng(5)
    x = np.tile(np.arange(0.0, 1.2, 0.002)[:, None], (1, 40))
    fit = analysis.plateau_fit(x, 300.0 + 40.0 * x + rng.normal(0.0, 60.0, x.shape))
    assert not fit.levels_off, fit
    assert abs(fit.slope - 40.0) < 3 * fit.slope_se and 1.0 < fit.slope_se < 4.0, fit
