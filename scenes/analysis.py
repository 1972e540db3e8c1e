"""Signal analysis of the reference study: ringing tests, calibration errors, spectra, steady state, shear strength.

- Ringing test (paper section 2.1.1): damped frequency f_d = 1/T_d (eq. 3), logarithmic decrement
  Lambda = (1/n) ln(A_1/A_{n+1}) (eq. 4) and damping ratio zeta = Lambda / sqrt(4 pi^2 + Lambda^2) (eq. 5) from
  automatically picked peaks: :func:`ringdown`.
- GA calibration (sections 2.2.1-2.2.2): relative errors (eqs. 8, 9, 11) and fitness functions (eqs. 7, 10).
- FFT analysis (section 2.4): zero-phase Butterworth low-pass at 100 Hz, single-sided amplitude spectrum and the
  dominant tones with their integer-multiple (harmonic) relations.
- Steady state after 0.5 m of tool travel (section 2.2.2) and the Mohr-Coulomb fit of direct shear box peaks (2.3).

Pure functions of numpy arrays (numpy and scipy only), SI units throughout. Bad inputs raise
:class:`warpdem.errors.InputError`, a ``ValueError`` that names the offending parameter and its value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import optimize, signal

from warpdem.errors import InputError

__all__ = [
    "MohrCoulomb",
    "RingDown",
    "SteadyState",
    "Tone",
    "damping_ratio_from_log_decrement",
    "dominant_frequencies",
    "draught_fitness",
    "log_decrement_from_damping_ratio",
    "lowpass",
    "mohr_coulomb",
    "noise_std",
    "relative_error",
    "ringdown",
    "ringing_fitness",
    "sampling_rate",
    "spectrum",
    "steady_state",
]

# ---------------------------------------------------------------------------------------------------------------------
# Tuning constants (each with its reason)
# ---------------------------------------------------------------------------------------------------------------------

#: a local extremum counts as a vibration peak when its prominence exceeds this many noise standard deviations: the
#: prominence of a pure-noise extremum is at most the noise's range, about 8.8 std over 1e5 Gaussian samples (the
#: rare larger ones fall outside the steadily spaced run or within 5 std of the offset, see below)
_PROMINENCE_NOISE = 10.0
#: ... and this fraction of the signal's range, which keeps round-off ripple of noise-free signals out
_PROMINENCE_RANGE = 1e-3
#: successive half-periods of a free damped vibration are equal; a run of extrema ends where an interval differs from
#: the previous one by more than this fraction (a hammer hit or a noise extremum breaks the rhythm by far more)
_SPACING_RTOL = 0.25
#: extrema closer to the offset than this many noise std are dropped: their timing and height are mostly noise
_AMPLITUDE_NOISE = 5.0
#: half-width of the parabola fitted around each extremum, as a fraction of the period: +-1/8 period keeps the
#: parabola within 0.2 % of the cosine cap while averaging tens of samples of noise
_PEAK_WINDOW_PERIODS = 1.0 / 8.0
#: Gaussian std from the median absolute deviation
_MAD_TO_STD = 1.4826
#: time steps that differ by less than this fraction of the median step count as uniform sampling: a 0.1 % jitter
#: moves a sample by 1e-3 dt, a phase error far below the FFT's own resolution
_UNIFORM_RTOL = 1e-3
#: peaks of a Hann-windowed spectrum closer than this many bins belong to one main lobe (half-width 2 bins)
_HANN_MAIN_LOBE_BINS = 3


# ---------------------------------------------------------------------------------------------------------------------
# Results
# ---------------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RingDown:
    """Ringing test result (paper eqs. 3-5).

    Attributes:
        frequency_hz: damped frequency f_d = 1/T_d [Hz] (eq. 3).
        damping_ratio: zeta [-] from the logarithmic decrement (eq. 5).
        log_decrement: Lambda [-] per cycle (eq. 4).
        period_s: damped period T_d [s].
        n_cycles_used: cycles n spanned by the peaks used.
        peak_times: times of the picked maxima [s], shape (k,).
        peak_amplitudes: heights of those maxima above the offset [units of the signal], shape (k,).
        offset: equilibrium value the signal oscillates about [units of the signal] (given or estimated).
    """

    frequency_hz: float
    damping_ratio: float
    log_decrement: float
    period_s: float
    n_cycles_used: int
    peak_times: np.ndarray
    peak_amplitudes: np.ndarray
    offset: float


@dataclass(frozen=True)
class Tone:
    """One dominant spectral peak.

    Attributes:
        frequency_hz: interpolated peak frequency [Hz].
        amplitude: amplitude of the sinusoid it represents [units of the signal] (A for A sin(2 pi f t)).
        harmonic_of: index, in the list returned by :func:`dominant_frequencies`, of the stronger primary tone this
            one is an integer multiple of; None for a primary tone.
        multiple: that integer multiple m >= 2 (1 for a primary tone).
    """

    frequency_hz: float
    amplitude: float
    harmonic_of: int | None = None
    multiple: int = 1


@dataclass(frozen=True)
class SteadyState:
    """Statistics of a signal over its steady-state part.

    Attributes:
        mean: mean [units of the signal].
        std: standard deviation [units of the signal] (numpy's, ddof as requested).
        n: number of samples used.
        t_start: time of the first sample used [s].
        sem: standard error of the mean [units of the signal]: std / sqrt(n_eff), with n_eff the effective number
            of independent samples of the correlated signal (:func:`effective_samples`).
        trend: least-squares slope of the signal against time [units of the signal per s] (a drift, or a run that
            has not settled).
        trend_sem: its standard error: residual std / (std of the times x sqrt(n_eff of the residual)).
        t_mean: mean time of the samples used [s].
    """

    mean: float
    std: float
    n: int
    t_start: float
    sem: float = math.nan
    trend: float = math.nan
    trend_sem: float = math.nan
    t_mean: float = math.nan


@dataclass(frozen=True)
class MohrCoulomb:
    """Mohr-Coulomb failure line tau = c + sigma tan(phi) fitted to direct shear box peaks.

    Attributes:
        cohesion: c [Pa].
        friction_angle_deg: internal friction angle phi [deg].
        r2: coefficient of determination [-] (1 by construction for two points).
        n_points: number of (sigma, tau) points fitted.
    """

    cohesion: float
    friction_angle_deg: float
    r2: float
    n_points: int


# ---------------------------------------------------------------------------------------------------------------------
# Input checks
# ---------------------------------------------------------------------------------------------------------------------


def _describe(arr: np.ndarray) -> str:
    return repr(arr.tolist()) if arr.size <= 6 else f"array of shape {arr.shape}"


def _finite_1d(name: str, value: object, min_size: int = 1) -> np.ndarray:
    """value as a finite float64 array of shape (n,), n >= min_size, else InputError naming it."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim != 1:
        raise InputError(f"{name} must be one-dimensional, got shape {arr.shape}")
    if arr.size < min_size:
        raise InputError(f"{name} needs at least {min_size} samples, got {arr.size}: {_describe(arr)}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise InputError(f"{name} has {bad.size} non-finite value(s), first at index {bad[0]}: {arr[bad[0]]}")
    return arr


def _time_axis(name: str, value: object, min_size: int = 2) -> np.ndarray:
    """A finite, strictly increasing time axis [s] of shape (n,)."""
    t = _finite_1d(name, value, min_size)
    steps = np.diff(t)
    bad = np.flatnonzero(steps <= 0.0)
    if bad.size:
        i = bad[0]
        raise InputError(
            f"{name} must be strictly increasing, but {name}[{i}]={t[i]!r} >= {name}[{i + 1}]={t[i + 1]!r}"
        )
    return t


def _same_shape(**arrays: np.ndarray) -> None:
    shapes = {name: arr.shape for name, arr in arrays.items()}
    if len(set(shapes.values())) > 1:
        raise InputError("shapes must match, got " + ", ".join(f"{k} {v}" for k, v in shapes.items()))


def _scalar_or_array(value: np.ndarray) -> float | np.ndarray:
    return float(value) if np.ndim(value) == 0 else value


def sampling_rate(t: object) -> float:
    """Sampling rate [Hz] of a uniformly sampled time axis t [s], shape (n,), n >= 2.

    Raises InputError when t is not strictly increasing or its steps differ from their median by more than 0.1 %.
    """
    t = _time_axis("t", t)
    steps = np.diff(t)
    dt = float(np.median(steps))
    worst = int(np.argmax(np.abs(steps - dt)))
    if abs(steps[worst] - dt) > _UNIFORM_RTOL * dt:
        raise InputError(
            f"t must be uniformly sampled (steps within {_UNIFORM_RTOL:.0e} of the median step {dt!r} s), but "
            f"t[{worst + 1}] - t[{worst}] = {steps[worst]!r} s; resample first (e.g. numpy.interp)"
        )
    return 1.0 / dt


# ---------------------------------------------------------------------------------------------------------------------
# Ringing test: eqs. (3)-(5)
# ---------------------------------------------------------------------------------------------------------------------


def damping_ratio_from_log_decrement(lam: float | np.ndarray) -> float | np.ndarray:
    """Damping ratio zeta = Lambda / sqrt(4 pi^2 + Lambda^2) [-] (eq. 5) of the logarithmic decrement Lambda [-].

    Scalar or array (any shape) in, same out.
    """
    lam = np.asarray(lam, dtype=np.float64)
    if not np.all(np.isfinite(lam)):
        raise InputError(f"lam must be finite, got {_describe(lam)}")
    return _scalar_or_array(lam / np.sqrt(4.0 * math.pi**2 + lam**2))


def log_decrement_from_damping_ratio(zeta: float | np.ndarray) -> float | np.ndarray:
    """Logarithmic decrement Lambda = 2 pi zeta / sqrt(1 - zeta^2) [-], the inverse of eq. (5), for an
    underdamped damping ratio |zeta| < 1. Scalar or array (any shape) in, same out."""
    zeta = np.asarray(zeta, dtype=np.float64)
    if not np.all(np.abs(zeta) < 1.0):
        raise InputError(f"zeta must be finite with |zeta| < 1 (underdamped), got {_describe(zeta)}")
    return _scalar_or_array(2.0 * math.pi * zeta / np.sqrt(1.0 - zeta**2))


def noise_std(x: object) -> float:
    """Robust standard deviation [units of x] of white noise on a smooth, oversampled signal x, shape (n,), n >= 4.

    Uses the third difference, which cancels a smooth signal to O((2 pi f dt)^3) while white noise of std s gives
    std sqrt(20) s; its median absolute deviation, scaled to a Gaussian std, ignores isolated spikes (a hammer hit).
    """
    x = _finite_1d("x", x, min_size=4)
    d3 = np.diff(x, 3)
    return float(_MAD_TO_STD * np.median(np.abs(d3 - np.median(d3))) / math.sqrt(20.0))


def _alternating_extrema(x: np.ndarray, prominence: float) -> tuple[np.ndarray, np.ndarray]:
    """Sample indices (k,) of prominent maxima and minima in time order, and their signs (+1 max, -1 min),
    made to alternate by keeping the more extreme of two neighbours of the same kind."""
    maxima, _ = signal.find_peaks(x, prominence=prominence)
    minima, _ = signal.find_peaks(-x, prominence=prominence)
    index = np.concatenate([maxima, minima])
    sign = np.concatenate([np.ones(maxima.size), -np.ones(minima.size)])
    order = np.argsort(index)
    kept: list[tuple[int, float]] = []
    for i, s in zip(index[order], sign[order], strict=True):
        if kept and kept[-1][1] == s:
            if s * x[i] > s * x[kept[-1][0]]:
                kept[-1] = (int(i), s)
        else:
            kept.append((int(i), s))
    return np.array([k[0] for k in kept], dtype=int), np.array([k[1] for k in kept])


def _regular_runs(times: np.ndarray) -> list[slice]:
    """Maximal runs of consecutive extrema with steady spacing: each interval within _SPACING_RTOL of the previous one
    (successive runs share the extremum where the rhythm breaks)."""
    gaps = np.diff(times)
    runs, start = [], 0
    for i in range(1, gaps.size + 1):
        if i == gaps.size or abs(gaps[i] / gaps[i - 1] - 1.0) > _SPACING_RTOL:
            runs.append(slice(start, i + 1))
            start = i
    return runs


def _free_vibration_run(times: np.ndarray, values: np.ndarray) -> slice | None:
    """The free vibration among the extrema: the steadily spaced run of at least 3 extrema (two intervals, so that
    its rhythm is confirmed at least once) with the largest total swing sum |v_{k+1} - v_k|. A hammer hit, noise
    extrema in a long quiet tail and a short high-frequency transient break the rhythm or swing far less."""
    runs = [run for run in _regular_runs(times) if run.stop - run.start >= 3]
    if not runs:
        return None
    return max(runs, key=lambda run: float(np.sum(np.abs(np.diff(values[run])))))


def _refine_extremum(t: np.ndarray, x: np.ndarray, i: int, half: int, sign: float) -> tuple[float, float]:
    """Time [s] and value of the vertex of a parabola least-squares fitted to x over samples i-half..i+half,
    re-centred once on the vertex; falls back to the sample itself when the fit has no vertex of the expected kind
    (sign +1: maximum, -1: minimum) within its window."""
    t_peak, x_peak = float(t[i]), float(x[i])
    for _ in range(2):
        lo, hi = max(i - half, 0), min(i + half + 1, t.size)
        dt = (t[hi - 1] - t[lo]) / max(hi - lo - 1, 1)
        u = (t[lo:hi] - t[i]) / dt  # in samples, for a well-conditioned fit
        a2, a1, a0 = np.polyfit(u, x[lo:hi], 2)
        if sign * a2 >= 0.0:  # flat, or curving the wrong way for this kind of extremum
            break
        u_vertex = -a1 / (2.0 * a2)
        if not u[0] <= u_vertex <= u[-1]:
            break
        t_peak, x_peak = float(t[i] + u_vertex * dt), float(a0 - a1**2 / (4.0 * a2))
        j = int(np.clip(np.searchsorted(t, t_peak), 0, t.size - 1))
        if j == i:
            break
        i = j
    return t_peak, x_peak


def _three_point_offset(e0: float, e1: float, e2: float) -> float:
    """Equilibrium of three successive extrema e0, e1, e2 of a damped sinusoid, whose distances from it form a
    geometric sequence: (e0 - c)(e2 - c) = (e1 - c)^2 gives c = (e0 e2 - e1^2) / (e0 + e2 - 2 e1)."""
    denominator = e0 + e2 - 2.0 * e1
    return 0.5 * (e0 + e1) if denominator == 0.0 else (e0 * e2 - e1**2) / denominator


def _fit_damped_sine(
    tau: np.ndarray, x: np.ndarray, omega0: float, decay0: float, offset: float | None
) -> tuple[float, float, float]:
    """Least-squares fit of x(tau) = c + exp(-decay tau) (a cos(omega tau) + b sin(omega tau)) over all samples.

    The model is linear in (a, b, c) for given (omega, decay), so those are solved exactly inside the residual
    (variable projection) and only omega [rad/s] and decay [1/s] are iterated from their peak-picking estimates.
    c is held at offset when one is given. Returns (omega, decay, c).
    """
    target = x if offset is None else x - offset

    def basis(p: np.ndarray) -> np.ndarray:
        envelope = np.exp(-p[1] * tau)
        columns = [envelope * np.cos(p[0] * tau), envelope * np.sin(p[0] * tau)]
        if offset is None:
            columns.append(np.ones_like(tau))
        return np.column_stack(columns)

    def residual(p: np.ndarray) -> np.ndarray:
        b = basis(p)
        return b @ np.linalg.lstsq(b, target, rcond=None)[0] - target

    # omega stays within a factor 2 of the peak spacing's estimate; decay >= 0 (a free vibration does not grow)
    bounds = ([0.5 * omega0, 0.0], [2.0 * omega0, np.inf])
    solution = optimize.least_squares(residual, [omega0, max(decay0, 0.0)], bounds=bounds, x_scale="jac")
    omega, decay = solution.x
    if offset is None:
        c = float(np.linalg.lstsq(basis(solution.x), target, rcond=None)[0][2])
    else:
        c = float(offset)
    return float(omega), float(decay), c


def ringdown(t: object, x: object, *, n_cycles: int | None = None, offset: float | None = None) -> RingDown:
    """Damped frequency, logarithmic decrement and damping ratio of a free vibration (paper eqs. 3-5).

    Args:
        t: sample times [s], shape (n,), strictly increasing (uniform sampling not required).
        x: signal, shape (n,): displacement [m] or force [N] of a free damped vibration about an unknown constant
            offset, with noise, possibly preceded by a rest period and a transient (a hammer hit).
        n_cycles: None (default): T_d and Lambda from a least-squares fit of a damped sinusoid to every sample of
            the ringdown, whose successive peaks satisfy eq. (4) exactly for every n; this uses all cycles and is
            the most noise-robust. An integer n >= 1: the paper's formulas on the picked peaks, T_d = (t_{n+1} -
            t_1)/n and Lambda = (1/n) ln(A_1/A_{n+1}) (eq. 4), A measured from the offset.
        offset: the equilibrium value [units of x] when known; otherwise it is estimated with the fit.

    Algorithm: prominent maxima and minima (scipy.signal.find_peaks, prominence above 10 noise std, noise from
    :func:`noise_std`), each refined by a parabola over +-1/8 period; the free vibration is the run of them with
    steady half-period spacing and the largest swing (a hammer hit or a noise extremum breaks the rhythm); extrema
    within 5 noise std of the offset (first estimated from three successive extrema) are dropped; the peak spacing
    and the decay over one cycle seed the fit.

    Returns:
        RingDown; peak_times and peak_amplitudes hold the maxima of the run used, shape (k,), k >= 2.

    Raises:
        InputError (a ValueError): bad inputs (shapes, NaN, non-increasing t, n_cycles < 1 or beyond the peaks
        found) or fewer than 2 peaks of a free vibration found.
    """
    t = _time_axis("t", t, min_size=8)
    x = _finite_1d("x", x, min_size=8)
    _same_shape(t=t, x=x)
    if n_cycles is not None and (int(n_cycles) != n_cycles or n_cycles < 1):
        raise InputError(f"n_cycles must be None or an integer >= 1, got {n_cycles!r}")
    if offset is not None and not math.isfinite(offset):
        raise InputError(f"offset must be None or finite, got {offset!r}")

    sigma_noise = noise_std(x)
    times, values, signs = _ringdown_extrema(t, x, sigma_noise)
    c0 = float(offset) if offset is not None else _three_point_offset(*values[:3])
    above_noise = signs * (values - c0) > _AMPLITUDE_NOISE * sigma_noise
    n_kept = int(np.argmin(above_noise)) if not above_noise.all() else above_noise.size
    times, values, signs = times[:n_kept], values[:n_kept], signs[:n_kept]
    _require_two_peaks(signs, f"above {_AMPLITUDE_NOISE:g} noise std ({sigma_noise:.3g}) from the offset {c0:.6g}")

    # seeds: period from the mean half-period spacing, decay from one cycle of extrema of the same kind
    period0 = 2.0 * float(np.mean(np.diff(times)))
    heights = np.abs(values - c0)
    decay0 = max(math.log(heights[0] / heights[2]) / period0, 0.0) if heights[2] > 0 < heights[0] else 0.0
    window = (t >= times[0]) & (t <= times[-1] + period0)  # the free vibration, not what may follow it
    omega, decay, c = _fit_damped_sine(t[window] - times[0], x[window], 2.0 * math.pi / period0, decay0, offset)

    peak_times = times[signs > 0]
    peak_amplitudes = values[signs > 0] - c
    if n_cycles is None:
        period = 2.0 * math.pi / omega
        lam = decay * period
        n_used = peak_times.size - 1
    else:
        n_used = int(n_cycles)
        if n_used + 1 > peak_times.size:
            raise InputError(
                f"n_cycles={n_cycles} needs {n_used + 1} peaks, but only {peak_times.size} were found above the noise"
            )
        if peak_amplitudes[n_used] <= 0.0 or peak_amplitudes[0] <= 0.0:
            raise InputError(f"n_cycles={n_cycles}: peak amplitudes {peak_amplitudes} are not all above the offset")
        period = float(peak_times[n_used] - peak_times[0]) / n_used
        lam = math.log(peak_amplitudes[0] / peak_amplitudes[n_used]) / n_used
    return RingDown(
        frequency_hz=1.0 / period,
        damping_ratio=float(damping_ratio_from_log_decrement(lam)),
        log_decrement=float(lam),
        period_s=float(period),
        n_cycles_used=n_used,
        peak_times=peak_times,
        peak_amplitudes=peak_amplitudes,
        offset=c,
    )


def _ringdown_extrema(t: np.ndarray, x: np.ndarray, sigma_noise: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Refined times (k,), values (k,) and signs (k,) of the alternating extrema of the free vibration in x."""
    prominence = max(_PROMINENCE_NOISE * sigma_noise, _PROMINENCE_RANGE * float(np.ptp(x)))
    index, signs = _alternating_extrema(x, prominence)
    _require_two_peaks(signs, f"with prominence >= {prominence:.3g}")
    half_widths = _window_half_widths(t, index)
    refined = np.array(
        [_refine_extremum(t, x, int(i), int(h), s) for i, h, s in zip(index, half_widths, signs, strict=True)]
    )
    times, values = refined[:, 0], refined[:, 1]
    run = _free_vibration_run(times, values)
    if run is None:
        _require_two_peaks(signs[:0], "in a run of at least 3 steadily spaced extrema")
    _require_two_peaks(signs[run], "in the run of steadily spaced extrema with the largest swing")
    return times[run], values[run], signs[run]


def _window_half_widths(t: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Half-width in samples (k,) of the parabola fitted around each extremum: 1/8 of the local period, the period
    being twice the mean gap to the neighbouring extrema; at least 2 samples (a parabola needs 3)."""
    gaps = np.diff(t[index])
    before = np.concatenate([gaps[:1], gaps])
    after = np.concatenate([gaps, gaps[-1:]])
    local_period = before + after  # twice the mean of the two half-periods around each extremum
    dt = (t[-1] - t[0]) / (t.size - 1)
    return np.maximum(2, np.round(_PEAK_WINDOW_PERIODS * local_period / dt)).astype(int)


def _require_two_peaks(signs: np.ndarray, where: str) -> None:
    n_peaks = int(np.count_nonzero(signs > 0))
    if n_peaks < 2 or signs.size < 3:
        raise InputError(
            f"ringdown needs at least 2 peaks (maxima) of a free vibration, found {n_peaks} {where}; "
            "pass a longer record or one with less noise"
        )


# ---------------------------------------------------------------------------------------------------------------------
# GA calibration: eqs. (7)-(11)
# ---------------------------------------------------------------------------------------------------------------------


def relative_error(
    sim: float | np.ndarray, target: float | np.ndarray, *, relative_to: Literal["target", "sim"] = "target"
) -> float | np.ndarray:
    """Relative error |sim - target| / |ref| as a fraction (not %), eqs. (8)-(9) and (11) in magnitude.

    relative_to="target" is the paper's equations; relative_to="sim" divides by the simulated value, which is what
    Table 2's RE columns hold (16 springs: |0.19256 - 0.20270| / 0.19256 = 0.05264). Scalars or broadcastable
    arrays of any one quantity (units cancel); returns a float for scalar inputs.
    """
    sim_a = np.asarray(sim, dtype=np.float64)
    target_a = np.asarray(target, dtype=np.float64)
    if relative_to not in ("target", "sim"):
        raise InputError(f'relative_to must be "target" or "sim", got {relative_to!r}')
    ref = target_a if relative_to == "target" else sim_a
    if not (np.all(np.isfinite(sim_a)) and np.all(np.isfinite(target_a))):
        raise InputError(f"sim and target must be finite, got sim={_describe(sim_a)}, target={_describe(target_a)}")
    if np.any(ref == 0.0):
        raise InputError(f"relative_error relative to {relative_to} is undefined: {relative_to} contains 0")
    return _scalar_or_array(np.abs(sim_a - target_a) / np.abs(ref))


def ringing_fitness(re_freq: float, re_damp: float) -> float:
    """Ringing-test fitness 1 / (RE_freq RE_damp) (eq. 7) of two relative errors given as fractions (not %);
    infinite for a perfect match."""
    for name, value in (("re_freq", re_freq), ("re_damp", re_damp)):
        if not (math.isfinite(value) and value >= 0.0):
            raise InputError(f"{name} must be a finite relative error >= 0, got {value!r}")
    product = re_freq * re_damp
    return math.inf if product == 0.0 else 1.0 / product


def draught_fitness(re: float) -> float:
    """Draught fitness 1 / |RE_draught| (eq. 10) of the relative error of eq. (11) as a fraction; eq. (11) is
    printed signed, its magnitude is used so that under- and over-predictions score alike. Infinite when re = 0."""
    if not math.isfinite(re):
        raise InputError(f"re must be finite, got {re!r}")
    return math.inf if re == 0.0 else 1.0 / abs(re)


# ---------------------------------------------------------------------------------------------------------------------
# FFT analysis (section 2.4)
# ---------------------------------------------------------------------------------------------------------------------


def lowpass(x: object, fs: float, cutoff_hz: float = 100.0, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth low-pass of x along its last axis (section 2.4).

    Args:
        x: signal, shape (..., n), any units; filtered along the last axis.
        fs: sampling rate [Hz].
        cutoff_hz: -3 dB frequency of the single pass [Hz], 0 < cutoff_hz < fs/2. Run forward and backward
            (scipy.signal.sosfiltfilt) the gain is squared: -6 dB at the cutoff, 80 dB/decade above it for order 4.
        order: order of the single-pass Butterworth filter (scipy.signal.butter, second-order sections).

    Returns:
        The filtered signal, same shape as x, with no phase shift.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 0:
        raise InputError("x must have at least one axis of samples, got a scalar")
    if not np.all(np.isfinite(x)):
        raise InputError(f"x must be finite, got {np.count_nonzero(~np.isfinite(x))} non-finite value(s)")
    if not (math.isfinite(fs) and fs > 0.0):
        raise InputError(f"fs must be a positive sampling rate [Hz], got {fs!r}")
    if not 0.0 < cutoff_hz < 0.5 * fs:
        raise InputError(f"cutoff_hz must lie in (0, fs/2) = (0, {0.5 * fs!r}) Hz (Nyquist), got {cutoff_hz!r}")
    if int(order) != order or order < 1:
        raise InputError(f"order must be an integer >= 1, got {order!r}")
    sos = signal.butter(int(order), cutoff_hz, btype="low", output="sos", fs=fs)
    padlen = 3 * (2 * len(sos) + 1)  # sosfiltfilt's default edge padding
    if x.shape[-1] <= padlen:
        raise InputError(f"x needs more than {padlen} samples along its last axis for order={order}, got {x.shape[-1]}")
    return signal.sosfiltfilt(sos, x, axis=-1)


def spectrum(
    t: object, x: object, *, cutoff_hz: float | None = 100.0, detrend: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """Single-sided amplitude spectrum of a uniformly sampled signal (section 2.4).

    The signal is low-passed with :func:`lowpass` at cutoff_hz (skipped for None), its least-squares straight line
    removed (detrend=True: mean and drift), multiplied by a periodic Hann window and transformed (numpy.fft.rfft).
    Amplitudes are 2 |X_k| / sum(w) (1 |X_k| / sum(w) at 0 Hz and Nyquist), which corrects the window's coherent
    gain: a tone A sin(2 pi f t) on a bin reads A. Between bins the Hann main lobe reads up to 15 % low
    (scalloping); :func:`dominant_frequencies` interpolates that away.

    Args:
        t: sample times [s], shape (n,), uniformly sampled (checked by :func:`sampling_rate`).
        x: signal, shape (n,), any units.

    Returns:
        (freqs [Hz], amplitude [units of x]), both of shape (n // 2 + 1,), from 0 Hz to Nyquist.
    """
    fs = sampling_rate(t)
    y = _finite_1d("x", x)
    _same_shape(t=np.asarray(t), x=y)
    if cutoff_hz is not None:
        y = lowpass(y, fs, cutoff_hz)
    if detrend:
        y = signal.detrend(y, type="linear")
    window = signal.windows.hann(y.size, sym=False)
    amplitude = 2.0 * np.abs(np.fft.rfft(y * window)) / window.sum()
    amplitude[0] *= 0.5
    if y.size % 2 == 0:
        amplitude[-1] *= 0.5
    return np.fft.rfftfreq(y.size, 1.0 / fs), amplitude


def _hann_interpolate(amplitude: np.ndarray, k: int) -> tuple[float, float]:
    """Bin offset delta in [-0.5, 0.5] and true amplitude of a tone whose Hann-windowed peak is bin k.

    For a periodic Hann window the main lobe is |W(d)| = sinc(d) / (1 - d^2) (d in bins, normalised to 1 at 0),
    so the larger neighbour's ratio r = |X_{k+-1}| / |X_k| = (1 + delta) / (2 - delta) gives delta = (2r - 1)/(r + 1)
    exactly for an isolated tone, and the amplitude is |X_k| / |W(delta)|. A ratio below 1/2, which no isolated tone
    gives (a noise peak can), is read as delta = 0.
    """
    left, right = amplitude[k - 1], amplitude[k + 1]
    side = 1.0 if right >= left else -1.0
    ratio = max(left, right) / amplitude[k]
    delta = max((2.0 * ratio - 1.0) / (ratio + 1.0), 0.0)
    gain = np.sinc(delta) / (1.0 - delta**2)
    return side * delta, float(amplitude[k] / gain)


def dominant_frequencies(
    t: object,
    x: object,
    *,
    n: int = 5,
    cutoff_hz: float | None = 100.0,
    min_hz: float = 0.5,
    harmonic_rtol: float = 0.02,
) -> list[Tone]:
    """The n largest spectral peaks of x between min_hz and cutoff_hz (section 2.4), strongest first.

    Peaks are local maxima of :func:`spectrum` (at least 3 bins apart: one Hann main lobe); each frequency and
    amplitude is interpolated from the peak bin and its larger neighbour (exact for an isolated tone, see
    :func:`_hann_interpolate`), so tones between bins are found to a small fraction of a bin. As the paper
    "considered integer multiples of the primary frequencies", each tone is checked against the stronger primary
    tones before it: if |f - m f_primary| <= harmonic_rtol * f_primary for an integer m >= 2, it is marked
    harmonic_of that tone (a tolerance scaled by f_primary, so that high multiples are not matched by chance).

    Args:
        t: sample times [s], shape (n_samples,), uniformly sampled.
        x: signal, shape (n_samples,), any units.
        n: number of tones to return (fewer when the band has fewer peaks).
        cutoff_hz: low-pass cutoff [Hz] applied first and upper end of the search band (None: Nyquist, no filter).
        min_hz: lower end of the search band [Hz], above the detrending residue near 0 Hz.
        harmonic_rtol: tolerance of the integer-multiple test as a fraction of the primary frequency [-].

    Returns:
        list of Tone, at most n, by decreasing amplitude.
    """
    if int(n) != n or n < 1:
        raise InputError(f"n must be an integer >= 1, got {n!r}")
    freqs, amplitude = spectrum(t, x, cutoff_hz=cutoff_hz)
    top = freqs[-1] if cutoff_hz is None else cutoff_hz
    if not 0.0 <= min_hz < top:
        raise InputError(f"min_hz must lie in [0, {top!r}) Hz, got {min_hz!r}")
    bins, _ = signal.find_peaks(amplitude, distance=_HANN_MAIN_LOBE_BINS)
    bins = bins[(freqs[bins] >= min_hz) & (freqs[bins] <= top)]
    bins = bins[np.argsort(amplitude[bins])[::-1][: int(n)]]
    df = freqs[1] - freqs[0]
    tones: list[Tone] = []
    for k in bins:
        delta, amp = _hann_interpolate(amplitude, int(k))
        tones.append(Tone(frequency_hz=float((k + delta) * df), amplitude=amp))
    tones.sort(key=lambda tone: -tone.amplitude)
    return _mark_harmonics(tones, harmonic_rtol)


def _mark_harmonics(tones: list[Tone], rtol: float) -> list[Tone]:
    """Mark each tone that is an integer multiple m >= 2 of an earlier (stronger) primary tone."""
    marked: list[Tone] = []
    for tone in tones:
        for i, primary in enumerate(marked):
            if primary.harmonic_of is not None:
                continue
            m = round(tone.frequency_hz / primary.frequency_hz)
            if m >= 2 and abs(tone.frequency_hz - m * primary.frequency_hz) <= rtol * primary.frequency_hz:
                tone = Tone(tone.frequency_hz, tone.amplitude, harmonic_of=i, multiple=m)
                break
        marked.append(tone)
    return marked


# ---------------------------------------------------------------------------------------------------------------------
# Steady state and shear strength
# ---------------------------------------------------------------------------------------------------------------------


def steady_state(t: object, x: object, travel: object, *, start_travel: float = 0.5, ddof: int = 0) -> SteadyState:
    """Mean and standard deviation of x over the samples where the tool has travelled >= start_travel
    (section 2.2.2: the steady-state region after 0.5 m).

    Args:
        t: sample times [s], shape (n,), strictly increasing.
        x: signal, shape (n,): draught force [N], displacement [m], ...
        travel: tool travel [m] at each sample, shape (n,).
        start_travel: travel [m] from which the signal counts as steady.
        ddof: delta degrees of freedom of the std (0: numpy's default, population std).

    Raises InputError when shapes differ, values are not finite, or no sample has travel >= start_travel.
    """
    t = _time_axis("t", t, min_size=1)
    x = _finite_1d("x", x)
    travel = _finite_1d("travel", travel)
    _same_shape(t=t, x=x, travel=travel)
    steady = travel >= start_travel
    n = int(np.count_nonzero(steady))
    if n <= ddof:
        raise InputError(
            f"steady_state needs more than ddof={ddof} samples with travel >= start_travel={start_travel!r} m, "
            f"found {n} (largest travel {float(travel.max())!r} m)"
        )
    values = x[steady]
    std = float(values.std(ddof=ddof))
    tc = t[steady] - t[steady].mean()
    trend = trend_sem = math.nan
    if n > 2 and tc.std() > 0:
        trend = float(np.dot(tc, values - values.mean()) / np.dot(tc, tc))
        resid = values - values.mean() - trend * tc
        trend_sem = float(resid.std() / (tc.std() * math.sqrt(effective_samples(resid))))
    return SteadyState(mean=float(values.mean()), std=std, n=n, t_start=float(t[np.argmax(steady)]),
                       sem=std / math.sqrt(effective_samples(values)) if n > 1 else math.nan, trend=trend,
                       trend_sem=trend_sem, t_mean=float(t[steady].mean()))


@dataclass(frozen=True)
class Plateau:
    """A draught approaching its plateau along the travel: D(x) = plateau - amplitude exp(-x / length).

    Attributes:
        plateau: the draught the run tends to [N]; plateau_se its standard error [N].
        amplitude: how far below the plateau it starts [N].
        length: the travel over which the gap falls by e [m]; length_se its standard error [m].
        window_mean: the mean of the binned draught from ``start_travel`` on [N] (a steady-state window's mean).
        n_worlds: the runs averaged.
        slope, slope_se: a straight line's slope through the same bins and its standard error [N/m].
        levels_off: the approach is identified: its length is shorter than the fitted travel and known to better
            than half itself. When False the plateau and length are extrapolations the records do not support (a
            draught still rising, nearly linearly, over the travel): read the slope.
        fit_span: the travel from the first to the last fitted bin's centre [m].
    """

    plateau: float
    plateau_se: float
    amplitude: float
    length: float
    length_se: float
    window_mean: float
    n_worlds: int
    slope: float
    slope_se: float
    levels_off: bool
    fit_span: float


def plateau_fit(travel: object, draught: object, *, fit_from: float = 0.3, start_travel: float = 0.5,
                bin_width: float = 0.05) -> Plateau:
    """Where several runs' draught is heading: each run's draught is averaged in travel bins of ``bin_width`` [m],
    the bins averaged over the runs (their scatter over the runs is each bin's standard error), and D(x) = plateau -
    amplitude exp(-x / length) is fitted by weighted least squares to the bins from ``fit_from`` [m] on (standard
    errors from the bins' errors, scaled up by the reduced chi-square where the curve misses by more). A steady
    window that starts before the approach has ended (a few lengths) averages below the plateau. A straight line is
    fitted to the same bins; where the approach is not identified (``Plateau.levels_off`` False: a draught still
    rising over the whole travel) its slope is what the records say.

    Args:
        travel: tool travel [m] (k, n): k samples of n runs (worlds), each rising.
        draught: the draught [N] (k, n) at those samples.
        fit_from: travel [m] from which the bins are fitted (past the tool's entry into the soil).
        start_travel: travel [m] from which ``window_mean`` averages.
        bin_width: [m].

    Raises InputError when the shapes differ, values are not finite, fewer than two runs are given, fewer than four
    bins lie past ``fit_from`` in every run, a bin holds no sample or the fit does not converge.
    """
    x = np.asarray(travel, dtype=np.float64)
    y = np.asarray(draught, dtype=np.float64)
    if x.ndim != 2 or x.shape != y.shape or x.shape[1] < 2:
        raise InputError(f"plateau_fit needs travel and draught of one shape (k samples, n >= 2 runs), got "
                         f"{x.shape} and {y.shape}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise InputError("plateau_fit: travel and draught must be finite")
    edges = np.arange(fit_from, float(x.max(axis=0).min()) + 1e-12, bin_width)
    if len(edges) < 5:
        raise InputError(f"plateau_fit needs at least four {bin_width:g} m bins past fit_from={fit_from:g} m in "
                         f"every run; the shortest run ends at {float(x.max(axis=0).min()):g} m")
    bins = np.array([[y[(x[:, w] >= a) & (x[:, w] < b), w].mean() for a, b in zip(edges[:-1], edges[1:], strict=True)]
                     for w in range(x.shape[1])])
    centre, mean = 0.5 * (edges[:-1] + edges[1:]), bins.mean(axis=0)
    if not np.all(np.isfinite(bins)):
        raise InputError(f"plateau_fit: a {bin_width:g} m bin holds no sample of some run (samples too sparse)")
    se = np.maximum(bins.std(axis=0, ddof=1) / math.sqrt(x.shape[1]), 1e-12 * float(np.abs(mean).max()))
    span = float(centre[-1] - centre[0])

    def model(s: np.ndarray, d: float, a: float, ell: float) -> np.ndarray:
        return d - a * np.exp(-s / ell)

    try:
        (d_inf, amp, length), cov = optimize.curve_fit(
            model, centre, mean, sigma=se, absolute_sigma=True,
            p0=(float(mean[-1]), float(mean[-1] - mean[0]) * math.e, span / 2), maxfev=20000)
    except RuntimeError as e:
        raise InputError(f"plateau_fit: the approach to a plateau did not converge ({e})") from None
    chi2 = float(np.sum(((mean - model(centre, d_inf, amp, length)) / se) ** 2)) / max(1, len(centre) - 3)
    err = np.sqrt(np.diag(cov) * max(1.0, chi2))  # the bins' own scatter, or the misfit where it is larger
    (slope, intercept), cov_line = np.polyfit(centre, mean, 1, w=1.0 / se, cov="unscaled")
    chi2_line = float(np.sum(((mean - np.polyval((slope, intercept), centre)) / se) ** 2)) / max(1, len(centre) - 2)
    levels_off = bool(0.0 < length < span and err[2] < 0.5 * length)
    return Plateau(plateau=float(d_inf), plateau_se=float(err[0]), amplitude=float(amp), length=float(length),
                   length_se=float(err[2]), window_mean=float(mean[centre >= start_travel].mean()),
                   n_worlds=int(x.shape[1]), slope=float(slope),
                   slope_se=float(math.sqrt(cov_line[0, 0] * max(1.0, chi2_line))), levels_off=levels_off,
                   fit_span=span)


def effective_samples(x: object) -> float:
    """Effective number of independent samples of a correlated series (n,): n / (1 + 2 sum_k rho_k), the
    autocorrelations rho_k summed up to the first non-positive one (Geyer's initial positive sequence, simplified).
    For an AR(1) series with coefficient phi it tends to n (1 - phi) / (1 + phi); for white noise to n."""
    x = _finite_1d("x", x, min_size=2)
    x = x - x.mean()
    n = len(x)
    var = float(x @ x)
    if var == 0.0:
        return float(n)
    spec = np.fft.rfft(x, 2 * n)  # autocorrelation by FFT: O(n log n) for long records
    rho = np.fft.irfft(spec * np.conj(spec))[:n] / var
    nonpos = np.flatnonzero(rho[1:] <= 0)
    stop = int(nonpos[0]) + 1 if len(nonpos) else n
    return float(min(n, n / (1.0 + 2.0 * rho[1:stop].sum())))


def mohr_coulomb(normal_stress: object, shear_stress: object) -> MohrCoulomb:
    """Least-squares Mohr-Coulomb line tau = c + sigma tan(phi) through direct shear box peaks (section 2.3).

    Args:
        normal_stress: normal stresses sigma [Pa], shape (k,), k >= 2 with at least two distinct values.
        shear_stress: peak shear stresses tau [Pa], shape (k,).

    Returns:
        MohrCoulomb with cohesion c [Pa], friction angle phi [deg] and R^2 (meaningful from k = 3; 1 for k = 2).
    """
    sigma = _finite_1d("normal_stress", normal_stress, min_size=2)
    tau = _finite_1d("shear_stress", shear_stress, min_size=2)
    _same_shape(normal_stress=sigma, shear_stress=tau)
    if np.ptp(sigma) == 0.0:
        raise InputError(f"normal_stress needs at least two distinct values to fit a line, got {_describe(sigma)}")
    design = np.column_stack([np.ones_like(sigma), sigma])
    (cohesion, slope), *_ = np.linalg.lstsq(design, tau, rcond=None)
    ss_res = float(np.sum((tau - design @ np.array([cohesion, slope])) ** 2))
    ss_tot = float(np.sum((tau - tau.mean()) ** 2))
    r2 = 1.0 if ss_tot == 0.0 else 1.0 - ss_res / ss_tot
    return MohrCoulomb(
        cohesion=float(cohesion), friction_angle_deg=math.degrees(math.atan(slope)), r2=r2, n_points=sigma.size
    )
