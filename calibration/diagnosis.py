"""Model criticism: show what the rig gets wrong, name the cause, extend the rig, measure the gain on held-out data.

``diagnose(rig_model)`` does four things:

1. **Fit the baseline**: the rig as described, with its first-order unknowns (``rig.genes``: e.g. a dashpot, a
   factor on the inertia, a factor on the spring rates) fitted by weighted least squares on the residuals
   r = (sim - measured) / sigma (sigma: the rig model's 1-sigma uncertainty of each measured value), generalized
   least squares where the rig model states how its residuals correlate (``rig.residual_correlation()``, e.g. the
   soil bin's reductions that share one rigid reference run; every loss below is then r^T C^-1 r, see
   ``Whitening``), in the genes'
   unit coordinates (log-scaled genes in decades): a grid over the whole ranges, then Levenberg-Marquardt rounds
   with forward differences. Every point is one DEM run of every configuration; all candidates' points of a round
   are the worlds of one batched simulation. The simulations serve every fold: a fold's fit is the best simulated
   point for its training configurations (the steps of each fold are simulated, so a fit is never extrapolated).
   A simulated record whose extraction fails is scored by what the failure says (``residuals``), not as a fixed
   large error.
2. **Compare on held-out data**: the baseline plus each applicable mechanism of ``calibration.mechanisms`` (started
   from the baseline's fit, its own genes gridded; the grid is repeated from points along the baseline's least
   determined direction, ``DiagnosisSettings.ridge_starts``), leave-one-configuration-out. For configuration j the
   candidate is fitted without j and predicts j; its held-out loss is l_j = sum_k r_jk^2. A candidate beats the
   baseline when its held-out loss falls by at least ``min_gain`` (reported with the standard error of the
   per-configuration gains), its likelihood-ratio test against the baseline (in-sample chi^2 fall ~ chi^2(added
   genes), the uncertainties being stated) is significant after Holm's correction over all candidates (alpha), and
   its AICc (in-sample chi^2 + 2p + 2p(p+1)/(n-p-1)) is lower by more than 2.
3. **Name the causes, stepwise**, unless the baseline already explains the data: its held-out residuals consistent
   with the stated uncertainties (chi^2 with one dof per data point, p >= ``noise_p``) and its fitted factors within
   their physical ranges (a baseline that fits only by leaving them has absorbed a mechanism: step 1 goes on). Then
   the verdict is "no significant discrepancy", whatever a candidate gains (the candidates are still fitted and
   ranked for the report). Otherwise the significant candidate of least held-out loss is named, compared after the
   same refinement (more Levenberg-Marquardt rounds: the leader gets them, and so does any runner-up whose loss is
   then lower), with any other significant one whose held-out loss is within sqrt(2 n) of it, the spread of a chi^2
   with n data points, as indistinguishable; it becomes the baseline and the remaining mechanisms are tried on top of
   it, until none is significant or the residual is consistent with noise. So a mechanism that helps only on top of
   another one is found. Without any significant candidate: "no significant discrepancy" if the baseline's residuals
   are consistent with the stated uncertainties, else "unexplained residual" with its pattern (rank correlations with
   the covariates); a named cause that leaves a residual larger than noise is reported so
   (``Diagnosis.residual_left``).
4. **Extend and measure**: the named extension is applied to the DEM rig and every configuration re-simulated,
   with the fold parameters, for the held-out errors before and after (and with the all-data fit, for plots).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from scipy import stats

from warpdem.errors import InputError

from . import mechanisms as mech
from .genes import Gene
from .rig_models import Case


@dataclass(frozen=True)
class Candidate:
    """The baseline rig, or the baseline with one or more mechanisms: all of its genes are fitted together."""

    name: str
    mechanisms: tuple[mech.Mechanism, ...]
    genes: tuple[Gene, ...]

    def values(self, z: np.ndarray) -> dict[str, float]:
        """Unit coordinates (n_genes,) in [0, 1] -> every gene's value (SI)."""
        return {g.name: float(g.from_ga(g.ga_range[0] + zi * (g.ga_range[1] - g.ga_range[0])))
                for g, zi in zip(self.genes, z, strict=True)}

    def params(self, z: np.ndarray) -> dict[str, float]:
        """Unit coordinates -> baseline gene values and mechanism knobs (SI)."""
        values = self.values(z)
        mech_genes = {g.name for m in self.mechanisms for g in m.genes}
        out = {k: v for k, v in values.items() if k not in mech_genes}
        for m in self.mechanisms:
            out.update(m.knobs({g.name: values[g.name] for g in m.genes}))
        return out


@dataclass
class DiagnosisSettings:
    """How candidates are fitted and judged. Grid points per dimension by the number of fitted genes."""

    rounds: int = 6
    """one grid round, then Levenberg-Marquardt rounds."""
    first_grid: dict[int, int] = field(default_factory=lambda: {0: 1, 1: 9, 2: 6, 3: 6, 4: 3})
    """grid points per gene in the first round, by the number of genes."""
    fd_step: float = 0.003
    """forward-difference step in unit coordinates (0.3 % of a linear range; 1 % in value per 1.5 decades)."""
    lm_damping: tuple[float, ...] = (1e-3, 1e-1)
    """Levenberg-Marquardt damping factors tried per step (relative to the mean of diag J^T J)."""
    alpha: float = 0.05
    """significance level of the held-out comparison (family-wise, Holm)."""
    min_gain: float = 0.3
    """least relative fall of the held-out loss for a cause to be named."""
    noise_p: float = 0.01
    """a residual whose chi^2 p-value falls below this is 'larger than noise'."""
    mechanisms: tuple[str, ...] | None = None
    """the candidate mechanisms (default: every registered one the rig supports)."""
    batch_worlds: int = 0
    """at most this many worlds per batched simulation (0: each round's new points in one); with a checkpoint, the
    simulated points are saved after every batch."""
    converge_rounds: int = 6
    """convergence check: at most this many more Levenberg-Marquardt rounds for the baseline and for a fit a step is
    about to name, until its loss stops falling (0: none; a fit that still falls is named "not converged")."""
    converge_tol: float = 0.5
    """a round in which neither the in-sample chi^2 nor the held-out loss falls by this much has converged (chi^2
    units: a tenth of the 3.84 a one-gene likelihood-ratio test needs at 5 %)."""
    ridge_starts: tuple[float, ...] = (0.25,)
    """a model extended by a mechanism also starts its first round's grid from points moved along the least
    determined direction of the model it extends (the eigenvector of J^T J's smallest eigenvalue, J the simulated
    forward differences of its residuals; e.g. the inertia-stiffness ridge of ringing records), at these fractions of
    the way to the unit box's edge on either side: a mechanism whose best fit lies elsewhere along that ridge is found
    whatever tiny differences (another device's rounding, 1e-6 of the data) choose the path of the local steps.
    () starts from the extended fit alone. Not part of a checkpoint's key (it only adds points)."""

    def __post_init__(self) -> None:
        if self.rounds < 1:
            raise ValueError(f"rounds must be >= 1, got {self.rounds!r}")
        if self.converge_rounds < 0:
            raise ValueError(f"converge_rounds must be >= 0, got {self.converge_rounds!r}")
        if not (math.isfinite(self.converge_tol) and self.converge_tol > 0):
            raise ValueError(f"converge_tol must be a positive number, got {self.converge_tol!r}")
        if self.batch_worlds < 0:
            raise ValueError(f"batch_worlds must be >= 0, got {self.batch_worlds!r}")
        if not 0 < self.alpha < 1:
            raise ValueError(f"alpha must be in (0, 1), got {self.alpha!r}")
        if not 0 <= self.min_gain < 1:
            raise ValueError(f"min_gain must be in [0, 1), got {self.min_gain!r}")
        if not all(isinstance(f, int | float) and 0 < f <= 1 for f in self.ridge_starts):
            raise ValueError(f"ridge_starts must be fractions in (0, 1], got {self.ridge_starts!r}")


@dataclass
class Fit:
    """A fitted candidate: parameters (all data and per fold), losses and held-out statistics."""

    candidate: Candidate
    z_all: np.ndarray
    z_fold: np.ndarray
    """(n_configs, n_genes): the fit without configuration j."""
    pred_all: np.ndarray
    """(n_configs, n_obs) at the all-data fit."""
    pred_heldout: np.ndarray
    """(n_configs, n_obs): configuration j predicted by the fit without it."""
    heldout_loss: np.ndarray
    """(n_configs,) sum_k r_jk^2 of the held-out predictions (with correlated residuals: the whitened ones,
    ``Whitening``)."""
    chi2_in: float
    n_points: int
    aicc: float = math.nan
    gain: float = math.nan
    gain_se: float = math.nan
    p_heldout: float = math.nan
    """one-sided paired t-test p of the held-out gain over configurations (reported; weak with few)."""
    p_value: float = math.nan
    """likelihood-ratio p against the baseline (in-sample chi^2 fall, stated uncertainties)."""
    p_holm: float = math.nan
    significant: bool = False

    @property
    def name(self) -> str:
        return self.candidate.name

    @property
    def n_params(self) -> int:
        return len(self.candidate.genes)

    def params_all(self) -> dict[str, float]:
        return self.candidate.values(self.z_all)

    def at_bound(self, tol: float = 0.005) -> list[dict[str, object]]:
        """The genes whose all-data fit lies within ``tol`` (a fraction of the searched range) of an end of the
        range: the data ask for a value the search did not allow, so the mechanism may stand in for another one
        or the range is too narrow. Each: gene, value (SI), low, high, side ("low" or "high"), and in how many
        leave-one-out folds the fit sits at the same end."""
        out, values = [], self.params_all()
        for i, g in enumerate(self.candidate.genes):
            for side, at in (("low", lambda z: z <= tol), ("high", lambda z: z >= 1.0 - tol)):
                if at(self.z_all[i]):
                    out.append({"gene": g.name, "value": values[g.name], "low": g.low, "high": g.high,
                                "unit": g.unit, "side": side, "folds": int(np.sum(at(self.z_fold[:, i]))),
                                "n_folds": int(self.z_fold.shape[0])})
        return out


@dataclass
class Diagnosis:
    """What ``diagnose`` found. ``verdict`` is "cause", "no significant discrepancy" or "unexplained residual"."""

    rig: str
    observables: tuple[str, ...]
    configs: list[dict]
    measured: np.ndarray
    sigma: np.ndarray
    """1-sigma uncertainty of each measured value, in its unit (n_configs, n_obs)."""
    uncertainty: dict[str, str]
    """the stated uncertainty per observable, in words (e.g. "1 %", "2 (absolute)")."""
    units: dict[str, str]
    covariates: dict[str, np.ndarray]
    fits: dict[str, Fit]
    ranking: list[str]
    verdict: str
    cause: tuple[str, ...] = ()
    indistinguishable: list[str] = field(default_factory=list)
    pattern: list[str] = field(default_factory=list)
    noise_p_baseline: float = math.nan
    noise_p_best: float = math.nan
    verification: dict[str, object] = field(default_factory=dict)
    measured_series: list[tuple[np.ndarray, np.ndarray]] | None = None
    """the measured records per configuration (time [s], signal), when the rig compared records."""
    n_simulations: int = 0
    """simulated worlds the fits and the verification asked for (a point simulated before is reused, not re-run)."""
    wall_s: float = 0.0
    """[s] wall time over every call of a resumed diagnosis that recorded it (see ``wall_untimed``)."""
    wall_untimed: bool = False
    """some earlier call of a resumed diagnosis recorded no wall time: ``wall_s`` leaves it out."""
    steps: list[dict[str, object]] = field(default_factory=list)
    """the stepwise search: per step, the mechanism named, held-out losses before and after, gain, p."""
    residual_left: bool = False
    """the final model's held-out residuals are larger than the stated noise (p < noise_p)."""
    adjustments: list[str] = field(default_factory=list)
    """what the baseline's fitted first-order unknowns say about the rig, in words."""
    failures: list[str] = field(default_factory=list)
    """simulated records whose extraction failed (model, configuration, why)."""
    measured_failures: list[str] = field(default_factory=list)
    """measured records whose extraction failed (configuration, why): those values are left out."""
    absorbed: list[str] = field(default_factory=list)
    """the fitted baseline's first-order factors outside their physical ranges, in words (issue #39, item 2)."""
    priority: list[str] = field(default_factory=list)
    """the mechanisms that would produce what the baseline absorbed: named first where the data cannot tell them
    from the best."""
    at_bound: list[dict[str, object]] = field(default_factory=list)
    """significant candidates not named because a gene of their newest mechanism ended on its physical bound: step,
    mechanism, gene, value, low, high, unit, side, source."""
    bounds: dict[str, dict[str, object]] = field(default_factory=dict)
    """mechanism -> gene -> its physical range (low, high, unit) and the range's source."""
    sizes: list[dict[str, object]] = field(default_factory=list)
    """the named causes' sizes with their uncertainty along the inertia-stiffness ridge (or fixed by a datum)."""
    convergence: dict[str, dict[str, object]] = field(default_factory=dict)
    """per refined fit (the baseline, each named model): converged, extra rounds, last fall of the loss."""
    correlation: np.ndarray | None = None
    """the residuals' correlation the losses were whitened with (n_configs n_obs, n_configs n_obs), configuration-
    major, in units of sigma; None: independent residuals (``Whitening``)."""

    @property
    def baseline(self) -> Fit:
        return self.fits["baseline"]

    @property
    def named(self) -> Fit | None:
        return self.fits["+".join(self.cause)] if self.cause else None


def residuals(pred: np.ndarray, measured: np.ndarray, sigma: np.ndarray, bound: np.ndarray | None = None
              ) -> np.ndarray:
    """Residuals in units of the uncertainty, (..., n_configs, n_obs). A failed extraction from a simulation (NaN)
    is scored by what the failure says: where the rig gives a ``bound`` (n_obs,) for the observable (e.g. a
    simulated record with no free vibration has a damping ratio of at least about 0.5), the residual of that
    one-sided value, (bound - measured) / sigma when the measurement lies below it, else 0; where not, the
    observable is unknown for that simulation (0). A missing measurement counts 0."""
    r = (pred - measured) / sigma
    b = np.full(measured.shape[-1], np.nan) if bound is None else np.asarray(bound, dtype=np.float64)
    fail = np.where(np.isfinite(b), np.maximum(b - measured, 0.0) / sigma, 0.0)
    r = np.where(np.isnan(pred), fail, r)
    return np.where(np.isnan(measured), 0.0, r)


class Whitening:
    """Generalized least squares: the residuals' correlation and the one transform that every loss goes through.

    ``corr``: the correlation of the residuals r = (sim - measured) / sigma (the rig model's
    ``residual_correlation()``), (n_configs n_obs, n_configs n_obs) over the flattened residuals, configuration-major
    (entry j n_obs + k is configuration j's observable k), in units of sigma (unit diagonal); None: independent. A
    set of residuals (``keep``: the configurations of a fold, the finite entries of a Jacobian; always only the
    measured values) is whitened with its own marginal correlation C (C's rows and columns of the kept entries):
    w = C^(-1/2) r with the symmetric inverse square root (zero-phase, "ZCA", whitening), so that sum w^2 =
    r^T C^-1 r, the generalized least-squares loss, and w ~ N(0, I) when r ~ N(0, C).

    Held-out residuals: configuration j's held-out residuals come from the fit without j, yet they share the errors
    that C describes (e.g. one rigid reference) with the other configurations'. The held-out residuals of all
    configurations (each predicted by its own fold) are whitened together, as one vector, with the full C; each
    configuration's held-out loss is its share, sum_k w_jk^2. Their sum is r_held^T C^-1 r_held, chi^2 with one dof
    per datum under the stated errors (the noise gate); the shares are independent N(0, 1) sums, so the paired
    comparisons over configurations keep their meaning; the symmetric square root, unlike a Cholesky factor, does
    not depend on the order of the configurations and keeps each share the closest to that configuration's own
    residuals among all whitening transforms (Kessy, Lewin and Strimmer 2018, Am. Stat. 72(4)). A shared error
    thus counts once, by its own variance, not once per configuration; a fold's training loss is its own
    configurations' r^T C^-1 r (C marginalized over them), which is what a fit without j sees. Failed simulated
    extractions keep their score (``residuals``) inside the whitened vector; a Jacobian drops them (``keep``).

    Without correlations every method reduces to the independent residuals' sums of squares (the same arithmetic,
    the same bits).
    """

    def __init__(self, corr: np.ndarray | None, measured: np.ndarray) -> None:
        self.shape = np.shape(measured)
        self.measured = ~np.isnan(np.asarray(measured, dtype=np.float64))
        self.corr = None if corr is None else np.asarray(corr, dtype=np.float64)
        self._w: dict[bytes, np.ndarray] = {}
        if self.corr is None:
            return
        n = self.measured.size
        if self.corr.shape != (n, n):
            raise ValueError(f"residual correlation: shape {self.corr.shape}, expected ({n}, {n}) (configurations x "
                             f"observables, {self.shape})")
        if not np.allclose(self.corr, self.corr.T, rtol=0.0, atol=1e-12):
            raise ValueError("residual correlation: not symmetric")
        if np.linalg.eigvalsh(self.corr)[0] <= 1e-10:
            raise ValueError("residual correlation: not positive definite (a shared error as large as a stated "
                             "uncertainty?)")

    @property
    def correlated(self) -> bool:
        return self.corr is not None

    def _matrix(self, mask: np.ndarray) -> np.ndarray:
        """C_mm^(-1/2) (symmetric) of the entries ``mask`` (flattened), cached."""
        key = mask.tobytes()
        if key not in self._w:
            idx = np.flatnonzero(mask)
            lam, vec = np.linalg.eigh(self.corr[np.ix_(idx, idx)])
            self._w[key] = (vec / np.sqrt(lam)) @ vec.T
        return self._w[key]

    def __call__(self, r: np.ndarray, keep: np.ndarray | None = None) -> np.ndarray:
        """Whitened residuals (..., n_configs, n_obs) of r (..., n_configs, n_obs), over the entries ``keep``
        ((n_configs, n_obs) or (n_configs, 1) bool; default all) that are measured; zero elsewhere. Without
        correlations: r (with zeros outside ``keep``)."""
        if self.corr is None:
            return r if keep is None else np.where(keep, r, 0.0)
        mask = self.measured if keep is None else self.measured & np.broadcast_to(keep, self.shape)
        flat = mask.reshape(-1)
        lead = r.shape[:-2]
        x = r.reshape(*lead, -1)[..., flat]
        out = np.zeros(lead + (flat.size,))
        out[..., flat] = x @ self._matrix(flat)
        return out.reshape(r.shape)

    def losses(self, r: np.ndarray) -> np.ndarray:
        """Each configuration's share of the loss, sum_k w_jk^2 (..., n_configs), all configurations whitened
        together; their sum is r^T C^-1 r."""
        return np.sum(self(r) ** 2, axis=-1)

    def chi2(self, r: np.ndarray) -> float:
        """r^T C^-1 r of one set of residuals (n_configs, n_obs)."""
        return float(np.sum(self(r) ** 2))

    def train_losses(self, r: np.ndarray) -> np.ndarray:
        """Fold j's training loss (..., n_configs): r^T C^-1 r over every configuration but j, C marginalized over
        them."""
        if self.corr is None:
            loss = self.losses(r)
            return loss.sum(axis=-1)[..., None] - loss
        n = self.shape[0]
        return np.stack([np.sum(self(r, (np.arange(n) != j)[:, None]) ** 2, axis=(-2, -1)) for j in range(n)],
                        axis=-1)

    def heldout_losses(self, r: np.ndarray, i_fold: np.ndarray) -> np.ndarray:
        """Held-out losses (n_configs,): configuration j's residuals taken at point i_fold[j] of r
        (m, n_configs, n_obs), the assembled vector whitened together (class docstring)."""
        return self.losses(r[i_fold, np.arange(self.shape[0])])


def _grid(box: np.ndarray, n: int) -> np.ndarray:
    """Points of a regular grid with n per dimension over box (2, d) -> (n^d, d)."""
    d = box.shape[1]
    if d == 0:
        return np.zeros((1, 0))
    axes = [np.linspace(box[0, i], box[1, i], n) if box[1, i] > box[0, i] else np.array([box[0, i]])
            for i in range(d)]
    return np.array(list(itertools.product(*axes)))


def _checkpoint_key(rig: object, settings: DiagnosisSettings, rounds: int | None = None) -> str:
    """What a checkpoint must match to be resumed: the rig, its settings, the data and the fit settings except the
    number of rounds. Round r's points follow from the points of rounds 1..r-1 alone, so a diagnosis with fewer or
    more rounds requests a prefix or an extension of another's points, and its checkpoint serves both. ``rounds``:
    the key as it was written before the rounds left it (the same text with ``fit.rounds`` at that value)."""
    fit = asdict(settings)
    del fit["ridge_starts"]
    if rounds is None:
        del fit["rounds"]
    else:
        fit["rounds"] = rounds
    text = json.dumps({"rig": rig.rig, "settings": getattr(rig, "settings", dict)(), "configs": rig.configs,
                       "observables": list(rig.observables), "measured": np.asarray(rig.measured).tolist(),
                       "uncertainty": getattr(rig, "uncertainty", None), "fit": fit},
                      sort_keys=True, default=str)
    return hashlib.sha1(text.encode()).hexdigest()


LEGACY_ROUNDS = range(1, 13)
"""the rounds a checkpoint written with the rounds in its key may name (it is read under the present key)."""


class _Fitter:
    """Grid and Levenberg-Marquardt fits of many candidates against one rig model, sharing batched simulations.
    Every simulated point is kept (``cache``) and, with a checkpoint file, saved after every batch: a killed
    diagnosis run again with the same checkpoint simulates only what it had not, and one run again with another
    number of rounds refits from the points it shares with the earlier run (fewer rounds: none is simulated)."""

    def __init__(self, rig: object, settings: DiagnosisSettings, log: Callable[[str], None],
                 checkpoint: str | Path | None = None) -> None:
        self.rig, self.settings, self.log = rig, settings, log
        self.cache: dict[tuple[str, tuple[float, ...]], np.ndarray] = {}
        self.seen: dict[str, list[tuple[str, tuple[float, ...]]]] = {}
        self.n_sims = 0
        self.t0 = time.perf_counter()
        self.wall_before = 0.0  # [s] the earlier calls' wall time, as their checkpoint recorded it
        self.wall_untimed = False  # a resumed checkpoint that recorded no wall time (written before it did)
        self.checkpoint = Path(checkpoint) if checkpoint else None
        self.key = _checkpoint_key(rig, settings)
        if self.checkpoint is not None and self.checkpoint.exists():
            data = json.loads(self.checkpoint.read_text())
            if data.get("key") != self.key and data.get("key") not in {
                    _checkpoint_key(rig, settings, r) for r in LEGACY_ROUNDS}:
                raise ValueError(f"checkpoint {str(self.checkpoint)!r} belongs to another diagnosis (other data, rig "
                                 f"or settings): remove it or write elsewhere")
            if hasattr(rig, "restore"):
                rig.restore(data["rig_state"])
            for name, z, values in data["cache"]:
                self.cache[(name, tuple(z))] = np.array(values, dtype=np.float64).reshape(rig.n_configs, -1)
            self.n_sims = int(data["n_sims"])
            self.wall_before = float(data.get("wall_s", 0.0))
            self.wall_untimed = bool(data.get("wall_untimed", "wall_s" not in data))
            log(f"  resumed from {self.checkpoint}: {len(self.cache)} simulated parameter sets")
        self.sigma = rig.sigma  # fixed before any fit (a rig may simulate its own noise level here)
        self.bound = rig.failure_bound() if hasattr(rig, "failure_bound") else None
        self.white = Whitening(rig.residual_correlation() if hasattr(rig, "residual_correlation") else None,
                               rig.measured)

    def save(self) -> None:
        if self.checkpoint is None:
            return
        from .archive import write_json_atomic

        write_json_atomic(self.checkpoint, {
            "key": self.key, "n_sims": self.n_sims, "wall_s": self.wall_s(), "wall_untimed": self.wall_untimed,
            "rig_state": getattr(self.rig, "state", dict)(),
            "cache": [[k[0], list(k[1]), np.where(np.isfinite(v), v, None).tolist()] for k, v in self.cache.items()]})

    def wall_s(self) -> float:
        """Wall time [s] of the fit over every call that wrote its checkpoint (this one included)."""
        return self.wall_before + time.perf_counter() - self.t0

    def _key(self, cand: Candidate, z: np.ndarray) -> tuple[str, tuple[float, ...]]:
        return cand.name, tuple(np.round(z, 10).tolist())

    def evaluate(self, requests: list[tuple[Candidate, np.ndarray]], what: str, record: bool = True) -> None:
        """Simulate the requested points not yet in the cache; ``record``: they count as the candidates' points
        (False: only cached, e.g. the differences that find a fitted model's least determined direction)."""
        for cand, z in requests if record else ():
            self.seen.setdefault(cand.name, []).append(self._key(cand, z))
        todo, seen = [], set()
        for cand, z in requests:
            key = self._key(cand, z)
            if key not in self.cache and key not in seen:
                seen.add(key)
                todo.append((cand, z))
        if not todo:
            return
        n_cfg = self.rig.n_configs
        per = max(1, self.settings.batch_worlds // n_cfg) if self.settings.batch_worlds else len(todo)
        n_batches = -(-len(todo) // per)
        t_stage = time.perf_counter()
        for start in range(0, len(todo), per):
            batch = todo[start:start + per]
            cases = [Case(j, cand.params(z)) for cand, z in batch for j in range(n_cfg)]
            t0 = time.perf_counter()
            out = self.rig.simulate(cases)
            self.n_sims += len(cases)
            k = start // per + 1
            spent = time.perf_counter() - t_stage
            part = (f" (batch {k}/{n_batches}, {spent:.0f} s so far, about {spent / k * (n_batches - k):.0f} s "
                    "left)") if n_batches > 1 else ""
            self.log(f"  {what}{part}: {len(batch)} parameter sets x {n_cfg} configurations = {len(cases)} worlds, "
                     f"{time.perf_counter() - t0:.1f} s")
            for i, (cand, z) in enumerate(batch):
                self.cache[self._key(cand, z)] = out.values[i * n_cfg:(i + 1) * n_cfg]
            self.save()

    def points(self, cand: Candidate) -> tuple[np.ndarray, np.ndarray]:
        """The candidate's points requested so far (m, d), in the order of their requests, and their predictions
        (m, n_cfg, n_obs). Only requested points count, never what a checkpoint holds beyond them: a resumed fit
        sees, at every stage, exactly what the uninterrupted one saw."""
        keys = list(dict.fromkeys(self.seen.get(cand.name, [])))
        return np.array([k[1] for k in keys]).reshape(len(keys), -1), np.array([self.cache[k] for k in keys])

    def residuals(self, pred: np.ndarray) -> np.ndarray:
        """Residuals (..., n_cfg, n_obs) of predictions (..., n_cfg, n_obs) in units of the rig's sigma."""
        return residuals(pred, self.rig.measured, self.sigma, self.bound)

    def best(self, cand: Candidate) -> tuple[np.ndarray, np.ndarray]:
        """Index of the best point for all data and for each fold: (all,), (n_cfg,)."""
        pts, pred = self.points(cand)
        r = self.residuals(pred)  # (m, n_cfg, n_obs)
        i_all = int(np.argmin(self.white.losses(r).sum(axis=1)))
        i_fold = np.argmin(self.white.train_losses(r), axis=0)
        return np.array([i_all]), i_fold

    def sloppy_direction(self, cand: Candidate, z: np.ndarray, label: str) -> np.ndarray:
        """The direction (n_genes,), unit length in unit coordinates, in which the candidate's fit at z is least
        determined: the eigenvector of J^T J's smallest eigenvalue over every configuration's finite residuals, J
        their simulated forward differences about z (simulated here where not cached; not counted as its points)."""
        self.evaluate([(cand, z)] + [(cand, p) for p in self._stencil(z)],
                      f"{label} (the fit's least determined direction)", record=False)
        _, jac, valid = self._jacobian(cand, z)
        a = self._whitened_jacobian(jac, valid)[valid]
        if len(a) == 0:
            return np.zeros(len(z))
        _, vecs = np.linalg.eigh(a.T @ a)
        return vecs[:, 0]

    def _starts(self, z0: np.ndarray, ridge: np.ndarray | None) -> list[np.ndarray]:
        """z0 and the points along ``ridge`` (over z0's seeded genes) at the settings' fractions of the way to the
        unit box's edge on either side (those that move a gene by at least 0.02)."""
        out = [z0]
        if ridge is None or not np.any(ridge):
            return out
        seeded = ~np.isnan(z0)
        v = np.where(seeded, ridge, 0.0)
        for sign in (1.0, -1.0):
            d = sign * v
            with np.errstate(divide="ignore", invalid="ignore"):
                room = np.where(d > 0, (1.0 - z0) / d, np.where(d < 0, -z0 / d, np.inf))
            t_edge = float(np.min(room[seeded])) if seeded.any() else 0.0
            for f in self.settings.ridge_starts:
                z = np.where(seeded, np.clip(z0 + f * t_edge * d, 0.0, 1.0), np.nan)
                if np.nanmax(np.abs(z - z0)) >= 0.02:
                    out.append(z)
        return out

    def fit(self, cands: list[Candidate], label: str, seeds: dict[str, np.ndarray] | None = None,
            ridges: dict[str, np.ndarray] | None = None) -> dict[str, Fit]:
        """A grid over the genes' whole ranges, then Levenberg-Marquardt rounds: after each round, the forward
        differences about every candidate's all-data best point are simulated and the damped Gauss-Newton steps of
        every fold (and of all data) from that point are the next round's points. ``seeds``: per candidate, unit
        coordinates (n_genes,) with NaN for the genes to grid; the others start at their seed (a model extended
        by one mechanism starts from the fitted model it extends). ``ridges``: per seeded candidate, a direction
        over its genes (:meth:`sloppy_direction` of the model it extends); the grid is repeated from points moved
        along it (``DiagnosisSettings.ridge_starts``)."""
        s = self.settings
        seeds, ridges = seeds or {}, ridges or {}
        proposals: dict[str, list[np.ndarray]] = {c.name: [] for c in cands}
        for r in range(s.rounds):
            if r == 0:
                requests = []
                for c in cands:
                    z0 = seeds.get(c.name, np.full(len(c.genes), np.nan))
                    free = np.isnan(z0)
                    for zs in self._starts(z0, ridges.get(c.name)):
                        box = np.array([np.where(free, 0.0, zs), np.where(free, 1.0, zs)])
                        requests += [(c, z) for z in _grid(box, s.first_grid.get(int(free.sum()), 3))]
            else:
                requests = [(c, z) for c in cands for z in proposals[c.name]]
            self.evaluate(requests, f"{label}, round {r + 1}/{s.rounds}")
            if r == s.rounds - 1:
                break
            # forward differences about each candidate's new best point, then the next steps
            stencils, centres = [], {}
            for c in cands:
                if c.genes:
                    pts, _ = self.points(c)
                    centres[c.name] = pts[self.best(c)[0][0]]
                    stencils += [(c, z) for z in self._stencil(centres[c.name])]
            self.evaluate(stencils, f"{label}, round {r + 1}/{s.rounds} (differences)")
            for c in cands:
                if c.genes:
                    proposals[c.name] = self._lm_steps(c, centres[c.name])
        return {c.name: self._result(c) for c in cands}

    def _fit_losses(self, cand: Candidate) -> tuple[float, float]:
        """The best in-sample chi^2 over the candidate's points and the sum of its folds' held-out losses."""
        _, pred = self.points(cand)
        r = self.residuals(pred)
        i_fold = np.argmin(self.white.train_losses(r), axis=0)
        return float(self.white.losses(r).sum(axis=1).min()), float(self.white.heldout_losses(r, i_fold).sum())

    def refine(self, cand: Candidate, label: str) -> dict[str, object]:
        """The convergence check: more Levenberg-Marquardt rounds about the candidate's best point until neither its
        in-sample chi^2 nor its held-out loss falls by ``converge_tol`` in a round (at most ``converge_rounds``).
        Returns converged, the extra rounds and the last round's fall."""
        s = self.settings
        if not cand.genes or s.converge_rounds == 0:
            return {"converged": not cand.genes, "rounds": 0, "fall": math.nan}
        prev, fall = self._fit_losses(cand), math.inf
        for r in range(s.converge_rounds):
            pts, _ = self.points(cand)
            centre = pts[self.best(cand)[0][0]]
            self.evaluate([(cand, z) for z in self._stencil(centre)],
                          f"{label}, convergence round {r + 1} (differences)")
            self.evaluate([(cand, z) for z in self._lm_steps(cand, centre)], f"{label}, convergence round {r + 1}")
            now = self._fit_losses(cand)
            fall, prev = max(prev[0] - now[0], prev[1] - now[1]), now
            if fall < s.converge_tol:
                return {"converged": True, "rounds": r + 1, "fall": fall}
        return {"converged": False, "rounds": s.converge_rounds, "fall": fall}

    def _stencil(self, x0: np.ndarray) -> list[np.ndarray]:
        """Forward-difference points about x0 (one per gene, stepping inwards at the upper bound)."""
        h = self.settings.fd_step
        out = []
        for i in range(x0.size):
            z = x0.copy()
            z[i] = z[i] + h if z[i] + h <= 1.0 else z[i] - h
            out.append(z)
        return out

    def _jacobian(self, cand: Candidate, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The residuals at x0 (n_cfg, n_obs), their forward differences about it from the cached stencil
        (n_cfg, n_obs, n_genes), and where both are finite (n_cfg, n_obs)."""
        keys = [self._key(cand, z) for z in self._stencil(x0)]
        p0 = self.cache[self._key(cand, x0)]
        r0 = residuals(p0, self.rig.measured, self.sigma, self.bound)
        cols = []
        for i, k in enumerate(keys):
            dz = np.array(k[1])[i] - x0[i]  # the step the cached point took (its key is rounded)
            cols.append((residuals(self.cache[k], self.rig.measured, self.sigma, self.bound) - r0) / dz)
        jac = np.stack(cols, axis=-1)
        valid = np.isfinite(p0) & np.all(np.isfinite(np.stack([self.cache[k] for k in keys])), axis=0)
        return r0, jac, valid & np.all(np.isfinite(jac), axis=-1)

    def _whitened_jacobian(self, jac: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """The forward differences (n_cfg, n_obs, n_genes) whitened over the entries ``rows`` (n_cfg, n_obs)."""
        return np.moveaxis(self.white(np.moveaxis(jac, -1, 0), rows), 0, -1)

    def _lm_steps(self, cand: Candidate, x0: np.ndarray) -> list[np.ndarray]:
        """Damped Gauss-Newton steps of every fold and of all data from x0, by the simulated forward differences
        about it."""
        r0, jac, valid = self._jacobian(cand, x0)
        n_cfg = self.rig.n_configs
        out = []
        masks = [np.ones(n_cfg, bool)] + [np.arange(n_cfg) != j for j in range(n_cfg)]
        for mask in masks:
            rows = valid & mask[:, None]
            a, b = self._whitened_jacobian(jac, rows)[rows], self.white(r0, rows)[rows]
            if a.size == 0:
                continue
            jtj, jtr = a.T @ a, a.T @ b
            scale = np.trace(jtj) / max(len(jtj), 1) or 1.0
            for lam in self.settings.lm_damping:
                step = -np.linalg.solve(jtj + lam * scale * np.eye(len(jtj)), jtr)
                out.append(np.clip(x0 + step, 0.0, 1.0))
        return out

    def _result(self, cand: Candidate) -> Fit:
        pts, pred = self.points(cand)
        i_all, i_fold = self.best(cand)
        n_cfg = self.rig.n_configs
        pred_all = pred[i_all[0]]
        held = np.array([pred[i_fold[j], j] for j in range(n_cfg)])
        n_points = int(np.sum(~np.isnan(self.rig.measured)))
        fit = Fit(cand, pts[i_all[0]], pts[i_fold], pred_all, held, self.white.losses(self.residuals(held)),
                  self.white.chi2(self.residuals(pred_all)), n_points)
        p = fit.n_params
        corr = 2 * p * (p + 1) / (n_points - p - 1) if n_points - p - 1 > 0 else math.inf
        fit.aicc = fit.chi2_in + 2 * p + corr
        return fit


def _lr_p(fit: Fit, reference: Fit) -> float:
    """Likelihood-ratio p-value of ``fit`` against the nested ``reference``: with the stated uncertainties the
    fall of the in-sample chi^2 is chi^2-distributed with one degree of freedom per added gene (at least one: a
    mechanism without genes, a discrete alternative, counts its choice as one)."""
    drop = reference.chi2_in - fit.chi2_in
    return float(stats.chi2.sf(drop, max(fit.n_params - reference.n_params, 1))) if drop > 0 else 1.0


def _compare(fits: list[Fit], reference: Fit, settings: DiagnosisSettings) -> None:
    """Each fit against ``reference``: held-out gain with its standard error (paired over configurations, and the
    one-sided t-test p of it, reported), likelihood-ratio p Holm-corrected over the fits, AICc."""
    total = reference.heldout_loss.sum()
    for f in fits:
        d = reference.heldout_loss - f.heldout_loss
        f.gain = float(1.0 - f.heldout_loss.sum() / total) if total > 0 else 0.0
        sd = float(np.std(d, ddof=1)) if d.size > 1 else math.inf
        f.gain_se = sd * math.sqrt(d.size) / total if total > 0 else math.inf
        f.p_heldout = _paired_p(f, reference)
        f.p_value = _lr_p(f, reference)
    order = sorted(fits, key=lambda f: f.p_value)
    running = 0.0
    for i, f in enumerate(order):
        running = max(running, min(1.0, (len(order) - i) * f.p_value))
        f.p_holm = running
        f.significant = bool(f.p_holm < settings.alpha and f.gain >= settings.min_gain
                             and f.aicc < reference.aicc - 2.0)


def _paired_p(a: Fit, b: Fit) -> float:
    """One-sided p that a's held-out loss is below b's (paired t-test over configurations)."""
    d = b.heldout_loss - a.heldout_loss
    sd = float(np.std(d, ddof=1)) if d.size > 1 else math.inf
    if sd == 0.0:
        return 0.0 if d.mean() > 0 else 1.0
    return float(stats.t.sf(d.mean() / (sd / math.sqrt(d.size)), d.size - 1))


def _noise_p(fit: Fit) -> float:
    """p-value of the held-out residuals under the stated uncertainties (chi^2 with one dof per data point; with
    correlated residuals their whitened loss, r^T C^-1 r)."""
    return float(stats.chi2.sf(fit.heldout_loss.sum(), fit.n_points))


def _pattern(cov: dict[str, np.ndarray], rig: object, fit: Fit, bound: np.ndarray | None = None) -> list[str]:
    """The residual pattern: per observable, its mean and its strongest rank correlation with a covariate."""
    r = residuals(fit.pred_heldout, rig.measured, rig.sigma, bound)
    r = np.where(np.isnan(rig.measured), np.nan, r)
    out = []
    for k, name in enumerate(rig.observables):
        rk = r[:, k]
        ok = np.isfinite(rk)
        if ok.sum() < 3:
            continue
        best = ("", 0.0, 1.0)
        for cname, cval in cov.items():
            if np.ptp(cval[ok]) == 0 or np.ptp(rk[ok]) == 0:  # a constant has no rank correlation (scipy warns)
                continue
            rho, p = stats.spearmanr(cval[ok], rk[ok])
            if np.isfinite(rho) and abs(rho) > abs(best[1]):
                best = (cname, float(rho), float(p))
        line = f"{name}: mean residual {np.nanmean(rk):+.2g} sigma, RMS {np.sqrt(np.nanmean(rk**2)):.2g} sigma"
        if best[0]:
            line += f"; rank correlation with {best[0]} {best[1]:+.2f} (p = {best[2]:.2g})"
        out.append(line)
    return out


def mechanisms_for(rig: object, settings: DiagnosisSettings) -> list[mech.Mechanism]:
    """The registered mechanisms (or ``settings.mechanisms``) that apply to the rig: it has their knobs (and their
    series, where they need them), and the data vary in the covariates that tell their effect
    (``Mechanism.varies``; not checked for mechanisms named in ``settings.mechanisms``), and a discrete alternative
    changes it (``Mechanism.applies`` on the rig's facts: yielding bonds only where the soil's break)."""
    names = settings.mechanisms or tuple(mech.REGISTRY)
    cov = rig.covariates() if hasattr(rig, "covariates") else {}
    facts = rig.facts() if hasattr(rig, "facts") else None
    out = []
    for n in names:
        m = mech.get(n)
        if rig.rig not in m.rigs and not settings.mechanisms:
            continue
        if not m.knob_names() <= rig.knobs:
            if settings.mechanisms:
                raise ValueError(f"mechanism {n!r} needs knobs {sorted(m.knob_names() - rig.knobs)} that the "
                                 f"{rig.rig} rig does not have (or that its fitted baseline already covers)")
            continue
        if m.needs_series and not getattr(rig, "has_series", False):
            continue
        if m.applies is not None and facts is not None and not m.applies(facts):
            if settings.mechanisms:
                raise ValueError(f"mechanism {n!r} changes nothing in this {rig.rig} rig (it is that way already)")
            continue
        if not settings.mechanisms and any(k in cov and np.ptp(np.asarray(cov[k], dtype=float)) == 0.0
                                           for k in m.varies):
            continue
        out.append(m)
    return out


def candidates_for(rig: object, settings: DiagnosisSettings) -> list[Candidate]:
    """The baseline and one candidate per applicable mechanism (genes cut to their physical bounds)."""
    base = Candidate("baseline", (), tuple(rig.genes))
    facts = rig.facts() if hasattr(rig, "facts") else None
    return [base] + [extend(base, m, facts) for m in mechanisms_for(rig, settings)]


def extend(cand: Candidate, m: mech.Mechanism, facts: mech.RigFacts | None = None) -> Candidate:
    """A candidate with one more mechanism (its genes appended, their ranges cut to the physical bounds that
    ``facts`` give, :meth:`calibration.mechanisms.Mechanism.bounded_genes`)."""
    ms = cand.mechanisms + (m,)
    return Candidate("+".join(x.name for x in ms), ms, cand.genes + m.bounded_genes(facts))


def _step(fitter: _Fitter, current: Fit, remaining: list[mech.Mechanism], s: DiagnosisSettings, label: str,
          facts: mech.RigFacts | None = None) -> list[Fit]:
    """Every remaining mechanism added to ``current`` (each started from current's fit), compared with it."""
    cands = [extend(current.candidate, m, facts) for m in remaining]
    seeds = {c.name: np.r_[current.z_all, np.full(len(c.genes) - len(current.z_all), np.nan)] for c in cands}
    ridges = {}
    if s.ridge_starts and current.candidate.genes:
        v = fitter.sloppy_direction(current.candidate, current.z_all, label)
        ridges = {c.name: np.r_[v, np.zeros(len(c.genes) - len(v))] for c in cands}
    fits = fitter.fit(cands, label, seeds, ridges)
    out = [fits[c.name] for c in cands]
    _compare(out, current, s)
    return out


def absorbed_parameters(rig: object, base: Fit) -> tuple[list[str], set[str]]:
    """The fitted baseline's first-order factors outside their physical ranges (``rig.baseline_bounds()``), in
    words, and the deviations they show ("stiffness_high", "inertia_low", ...). With the inertia and the rates both
    fitted, ringing records fix only their ratio: it is outside when the ridge s / f_J = const misses the box of
    both ranges; with one of them fixed (a datum), each is judged alone."""
    if not hasattr(rig, "baseline_bounds"):
        return [], set()
    bb, p = rig.baseline_bounds(), dict(base.params_all())
    if getattr(rig, "datum_scale", None) is not None:
        p.setdefault("stiffness_scale", rig.datum_scale)
    lines, dev = [], set()
    if "stiffness_scale" in p and "inertia_factor" in p and "stiffness_scale" not in getattr(rig, "fixed", {}) \
            and any(g.name == "stiffness_scale" for g in base.candidate.genes) \
            and any(g.name == "inertia_factor" for g in base.candidate.genes):
        ks, ki = bb["stiffness_scale"], bb["inertia_factor"]
        r, lo, hi = p["stiffness_scale"] / p["inertia_factor"], ks.low / ki.high, ks.high / ki.low
        if not lo <= r <= hi:
            side = "high" if r > hi else "low"
            dev |= {f"stiffness_{side}", f"inertia_{'low' if side == 'high' else 'high'}"}
            lines.append(f"the rates relative to the inertia are {r:.3g}x the stated ratio, outside the "
                         f"{lo:.3g}-{hi:.3g} that the rates' range ({ks.source}) and the inertia's ({ki.source}) "
                         f"allow: the baseline has absorbed something that makes the rig ring "
                         f"{'faster' if side == 'high' else 'slower'} than described")
        return lines, dev
    for name, b in bb.items():
        if name not in p:
            continue
        v = p[name]
        side = "low" if v < b.low * (1 - 1e-9) else "high" if v > b.high * (1 + 1e-9) else ""
        if side:
            dev.add(f"{name.split('_')[0]}_{side}")
            lines.append(f"the baseline's {name} = {v:.3g} is outside its physical range {b.low:.3g}-{b.high:.3g} "
                         f"({b.source}): it has likely absorbed a mechanism the baseline lacks")
    return lines, dev


def cause_sizes(rig: object, fit: Fit) -> list[dict[str, object]]:
    """Each named gene's size with its uncertainty along the inertia-stiffness ridge: with both factors fitted,
    ringing records fix the rates relative to the inertia (s / f_J) and a gene of ridge power p
    (``Mechanism.ridge``) scales as f_J^p along it; the interval is the ridge's stretch where the rates stay within
    their physical range (``rig.baseline_bounds()``). With the rates fixed by a datum (``rig.datum_scale``) the size
    is fixed too (interval: the fitted value)."""
    p = fit.params_all()
    out = []
    both = "inertia_factor" in p and "stiffness_scale" in p and hasattr(rig, "baseline_bounds")
    for m in fit.candidate.mechanisms:
        for g in m.genes:
            power = m.ridge.get(g.name, 0.0)
            v = p[g.name]
            entry = {"mechanism": m.name, "gene": g.name, "value": v, "unit": g.unit, "low": v, "high": v,
                     "why": "no inertia-stiffness ridge (the fit fixes it)"}
            if power and both:
                ks = rig.baseline_bounds()["stiffness_scale"]
                f = p["inertia_factor"]
                r = p["stiffness_scale"] / f
                lo, hi = sorted((v * (ks.low / r / f) ** power, v * (ks.high / r / f) ** power))
                entry.update(low=lo, high=hi, why=f"along the inertia-stiffness ridge (rates {r:.3g}x the inertia's "
                             f"ratio), the rates within {ks.low:.3g}-{ks.high:.3g}x the stated ones: inertia factor "
                             f"{ks.low / r:.3g}-{ks.high / r:.3g}")
            elif power and getattr(rig, "datum_scale", None) is not None:
                entry["why"] = "fixed: the static deflection datum fixes the rates, the frequencies the inertia"
            out.append(entry)
    return out


def refine_equally(pool: list[Fit], refine: Callable[[Fit], tuple[Fit, dict[str, object]]]
                   ) -> tuple[dict[str, Fit], dict[str, dict[str, object]], Fit]:
    """Refine the leader of ``pool`` (ordered by held-out loss), then any candidate whose held-out loss is below the
    best refined one's, until none is: refinement (more rounds about a best point) fits a candidate's training
    folds better and can raise its held-out loss above a runner-up's that had fewer rounds, so the one named is
    the best of the candidates fitted alike.

    ``refine(fit)`` returns (the refined fit, its convergence record). Returns (refined fits by name, their
    convergence records by name, the best refined fit).
    """
    refined: dict[str, Fit] = {}
    records: dict[str, dict[str, object]] = {}
    nxt: Fit | None = pool[0]
    while nxt is not None:
        refined[nxt.name], records[nxt.name] = refine(nxt)
        lead = min(refined.values(), key=lambda f: f.heldout_loss.sum())
        nxt = next((f for f in pool if f.name not in refined and f.heldout_loss.sum() < lead.heldout_loss.sum()),
                   None)
    return refined, records, lead


def diagnose(rig: object, settings: DiagnosisSettings | None = None,
             log: Callable[[str], None] = lambda s: None, checkpoint: str | Path | None = None) -> Diagnosis:
    """Fit, compare, name and verify (module docstring) for a rig model (``calibration.rig_models``).

    Stepwise: the baseline (with the first-order unknowns of the rig, e.g. an inertia factor, fitted) is compared
    with itself plus each mechanism; the one named becomes the new baseline and the remaining mechanisms are tried
    on top of it, until none is significant or what is left is consistent with noise.

    ``checkpoint``: a JSON file that keeps every simulated point (written after every batched simulation, see
    ``DiagnosisSettings.batch_worlds``); a diagnosis started again with the same file, rig, data and settings
    resumes where it stopped and comes to the same result; with another ``settings.rounds`` it fits again from the
    points that both request (the first round's grid is the same), simulating only the points it adds."""
    s = settings or DiagnosisSettings()
    if rig.n_configs < 2:
        raise InputError(f"the diagnosis holds each configuration out in turn and fits the rest: it needs at least "
                         f"2 configurations, the data have {rig.n_configs}")
    fitter = _Fitter(rig, s, log, checkpoint)
    remaining = mechanisms_for(rig, s)
    facts = rig.facts() if hasattr(rig, "facts") else None
    log(f"diagnosis of the {rig.rig} rig: {rig.n_configs} configurations, observables {', '.join(rig.observables)}; "
        f"baseline genes: {', '.join(g.name for g in rig.genes) or 'none'}; mechanisms: "
        f"{', '.join(m.name for m in remaining)}")
    base_cand = Candidate("baseline", (), tuple(rig.genes))
    fitter.fit([base_cand], "baseline")
    convergence = {"baseline": fitter.refine(base_cand, "baseline")}
    base = fitter._result(base_cand)
    fits = {"baseline": base}
    absorbed, deviations = absorbed_parameters(rig, base)
    priority = [m.name for m in remaining if set(m.produces) & deviations]
    for line in absorbed:
        log(f"  absorbed: {line}")
    current, steps, indist, singles, at_bound = base, [], [], [], []
    noise_base = _noise_p(base)
    while remaining:
        label = f"step {len(steps) + 1}"
        tried = _step(fitter, current, remaining, s, label, facts)
        fits.update({f.name: f for f in tried})
        if not steps:
            singles = sorted(tried, key=lambda f: f.heldout_loss.sum())
            if noise_base >= s.noise_p and not absorbed:
                break  # the baseline fits within the stated uncertainties, in range: nothing to name (ranked only)
        sig = sorted([f for f in tried if f.significant], key=lambda f: f.heldout_loss.sum())
        eligible = []
        for f in sig:
            newest = f.candidate.mechanisms[-1]
            ends = [b for b in f.at_bound() if b["gene"] in {g.name for g in newest.genes}]
            if not ends:
                eligible.append(f)
                continue
            phys = newest.physical(facts)
            for b in ends:
                at_bound.append({"step": len(steps) + 1, "mechanism": newest.name, **b,
                                 "source": phys[b["gene"]].source,
                                 "heldout_loss": float(f.heldout_loss.sum())})
            log(f"  {label}: {newest.name} significant but at its bound ({', '.join(b['gene'] for b in ends)}): "
                "the cause is likely outside this mechanism")
        if not eligible:
            break
        top = eligible[0]
        margin = math.sqrt(2.0 * top.n_points)  # the spread of a chi^2 with n data points
        preferred = [f for f in eligible if f.candidate.mechanisms[-1].name in priority
                     and f.heldout_loss.sum() - top.heldout_loss.sum() < margin]
        pool = preferred or eligible

        def refine_one(f: Fit, label: str = label) -> tuple[Fit, dict[str, object]]:
            record = fitter.refine(f.candidate, label)
            return fitter._result(f.candidate), record

        refined, refinements, lead = refine_equally(pool, refine_one)
        tried = [refined.get(f.name, f) for f in tried]
        _compare(tried, current, s)
        fits.update(refined)
        convergence.update(refinements)
        top = fits[lead.name]
        if not steps:
            loss = {f.name: f.heldout_loss.sum() for f in tried}
            indist = [f.candidate.mechanisms[-1].name for f in eligible if f.name != top.name
                      and abs(loss[f.name] - loss[top.name]) < margin]
        conv = convergence[top.name]
        steps.append({"step": len(steps) + 1, "named": top.candidate.mechanisms[-1].name, "model": top.name,
                      "heldout_loss_before": float(current.heldout_loss.sum()),
                      "heldout_loss_after": float(top.heldout_loss.sum()), "gain": top.gain, "gain_se": top.gain_se,
                      "p_lr_holm": top.p_holm, "noise_p_after": _noise_p(top), "converged": bool(conv["converged"]),
                      "convergence_rounds": int(conv["rounds"]), "last_fall": float(conv["fall"]),
                      "preferred_as_absorbed": bool(preferred)})
        log(f"  step {len(steps)}: {top.candidate.mechanisms[-1].name} (held-out loss "
            f"{current.heldout_loss.sum():.3g} -> {top.heldout_loss.sum():.3g}"
            f"{'' if conv['converged'] else '; the fit did not converge'})")
        remaining = [m for m in remaining if m.name != top.candidate.mechanisms[-1].name]
        current = top
        if _noise_p(top) >= s.noise_p:
            break
    ranking = sorted([n for n in fits if n != "baseline"], key=lambda n: fits[n].heldout_loss.sum())
    cause = tuple(m.name for m in current.candidate.mechanisms)
    noise_final = _noise_p(current)
    if cause:
        verdict = "cause"
    else:
        verdict = "no significant discrepancy" if noise_base >= s.noise_p else "unexplained residual"
    noise_best = _noise_p(singles[0]) if singles else noise_base
    diag = Diagnosis(rig.rig, tuple(rig.observables), list(rig.configs), rig.measured, rig.sigma,
                     rig.describe_uncertainty(), dict(rig.units), rig.covariates(), fits, ranking, verdict, cause,
                     indist, [], noise_base, noise_final if cause else noise_best)
    diag.absorbed, diag.priority, diag.at_bound, diag.convergence = absorbed, priority, at_bound, convergence
    diag.bounds = {m.name: {g: {"low": b.low, "high": b.high, "unit": next(x.unit for x in m.genes if x.name == g),
                                "source": b.source} for g, b in m.physical(facts).items()}
                   for m in mechanisms_for(rig, s)}
    diag.sizes = cause_sizes(rig, current)
    diag.steps = steps
    diag.correlation = fitter.white.corr
    diag.residual_left = bool(noise_final < s.noise_p)
    if hasattr(rig, "describe_fit"):
        diag.adjustments = rig.describe_fit(base.params_all())
    diag.measured_failures = list(getattr(rig, "measured_failures", []))
    diag.measured_series = getattr(rig, "measured_series", None)
    diag.verification = verify(rig, diag, log)
    simulated = diag.verification["baseline"]["static_deflection"]
    if np.all(np.isfinite(simulated)):  # the covariate as the fitted baseline simulates it, not the nominal one
        diag.covariates["static_deflection"] = np.asarray(simulated, dtype=np.float64)
    if diag.residual_left:
        diag.pattern = _pattern(diag.covariates, rig, current, fitter.bound)
    for name in ["baseline"] + (["+".join(cause)] if cause else []):
        for j, why in enumerate(diag.verification[name].get("failed", [])):
            if why:
                diag.failures.append(f"{name}, {_describe(rig, j)}: {why}")
    diag.n_simulations = fitter.n_sims + int(diag.verification.get("n_simulations", 0))
    diag.wall_s = fitter.wall_s()
    diag.wall_untimed = fitter.wall_untimed
    log(f"verdict: {verdict}{': ' + ' + '.join(cause) if cause else ''}"
        f"{' (a residual larger than noise remains)' if cause and diag.residual_left else ''} "
        f"({diag.n_simulations} simulated worlds, {diag.wall_s:.0f} s)")
    return diag


def _missing(observables: tuple[str, ...], values: np.ndarray) -> str:
    """Why a simulation gave no value for some observables ("" when it gave all)."""
    gone = [o for o, v in zip(observables, values, strict=True) if np.isnan(v)]
    return f"the simulation gave no value for {', '.join(gone)}" if gone else ""


def _describe(rig: object, j: int) -> str:
    return rig.describe_config(j) if hasattr(rig, "describe_config") else f"configuration {j}"


def _nanmean(x: np.ndarray) -> np.ndarray:
    """Mean over configurations (axis 0) of the finite values; NaN, without a warning, where there is none."""
    ok = np.isfinite(x)
    n = ok.sum(axis=0)
    return np.where(n > 0, np.where(ok, x, 0.0).sum(axis=0) / np.maximum(n, 1), np.nan)


def verify(rig: object, diag: Diagnosis, log: Callable[[str], None] = lambda s: None) -> dict[str, object]:
    """Re-simulate the baseline and the named extension: configuration j with the fit that did not see j (held-out
    errors before and after) and every configuration with the all-data fit (kept as series for plots)."""
    names = ["baseline"] + (["+".join(diag.cause)] if diag.cause else [])
    n_cfg = len(diag.configs)
    cases, index = [], []
    for name in names:
        f = diag.fits[name]
        for j in range(n_cfg):
            cases.append(Case(j, f.candidate.params(f.z_fold[j])))
            index.append((name, "heldout", j))
        for j in range(n_cfg):
            cases.append(Case(j, f.candidate.params(f.z_all)))
            index.append((name, "all", j))
    white = Whitening(diag.correlation, diag.measured)
    t0 = time.perf_counter()
    out = rig.simulate(cases, keep_series=True)
    log(f"  re-simulation of {', '.join(names)}: {len(cases)} worlds, {time.perf_counter() - t0:.1f} s")
    res: dict[str, object] = {"n_simulations": len(cases)}
    for name in names:
        sel = [i for i, k in enumerate(index) if k[0] == name and k[1] == "heldout"]
        sel_all = [i for i, k in enumerate(index) if k[0] == name and k[1] == "all"]
        held = out.values[sel]
        r = residuals(held, diag.measured, diag.sigma, rig.failure_bound() if hasattr(rig, "failure_bound") else None)
        err = held - diag.measured
        rel = err / np.abs(diag.measured)
        res[name] = {
            "heldout_pred": held, "all_pred": out.values[sel_all],
            "heldout_loss": white.losses(r),
            "heldout_rms_rel": np.sqrt(_nanmean(rel**2)),
            "heldout_rms": np.sqrt(_nanmean(err**2)),
            "heldout_mae": _nanmean(np.abs(err)),
            "series": [out.series[i] for i in sel_all] if out.series else None,
            "static_deflection": out.covariates.get("static_deflection", np.full(len(cases), np.nan))[sel_all],
            "failed": [out.failed[i] for i in sel] if out.failed else [_missing(diag.observables, out.values[i])
                                                                        for i in sel],
        }
    if diag.cause:
        b, e = res["baseline"], res[names[1]]
        res["gain_abs"] = float(b["heldout_loss"].sum() - e["heldout_loss"].sum())
        res["gain_rel"] = float(1.0 - e["heldout_loss"].sum() / b["heldout_loss"].sum())
    return res
