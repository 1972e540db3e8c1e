"""A wall-time budget for the long commands, and an evaluator that stops a calibration between its batches.

A command given ``--budget`` seconds stops with :class:`warpdem.errors.BudgetExhausted` at the first point where
its next piece would not fit (a GA batch as long per individual as the last one), with everything finished so far
saved; the same command then continues from there.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from warpdem.errors import BudgetExhausted, InputError


class Budget:
    """A wall-time budget [s] (None: unlimited) shared by the pieces of one call."""

    def __init__(self, seconds: float | None) -> None:
        if seconds is not None and not (math.isfinite(seconds) and seconds > 0):
            raise InputError(f"budget must be a positive number of seconds, got {seconds!r}")
        self.deadline = None if seconds is None else time.time() + seconds

    def left(self) -> float:
        return math.inf if self.deadline is None else self.deadline - time.time()

    def require(self, seconds: float, what: str) -> None:
        """Raise BudgetExhausted unless ``seconds`` are left for ``what``."""
        if self.left() < seconds:
            raise BudgetExhausted(f"stopped before {what} (about {seconds:.0f} s needed, {max(self.left(), 0):.0f} "
                                  "s left of the budget); run the same command again to continue")


class BatchGuard:
    """An evaluator that refuses a batch the budget cannot hold: one taking as long per individual as the last
    (``per_individual`` [s]: the estimate before the first batch, e.g. from an earlier call; ``timed`` receives
    each new estimate)."""

    def __init__(self, evaluate: Callable[[np.ndarray], list[dict[str, float]]], budget: Budget, what: str,
                 per_individual: float = 0.0, timed: Callable[[float], None] | None = None) -> None:
        self.evaluate, self.budget, self.what = evaluate, budget, what
        self.per_individual, self.timed = per_individual, timed or (lambda v: None)

    def __call__(self, values: np.ndarray) -> list[dict[str, float]]:
        self.budget.require(self.per_individual * len(values), f"a batch of {len(values)} {self.what}")
        t = time.perf_counter()
        out = self.evaluate(values)
        self.per_individual = (time.perf_counter() - t) / max(len(values), 1)
        self.timed(self.per_individual)
        return out
