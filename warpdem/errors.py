"""Errors raised by warpdem and the input checks that raise them.

Every check names the offending parameter and its value, so that a bad scene fails at build time with a message
an engineer can act on, not deep inside a kernel.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

import numpy as np


class InputError(ValueError):
    """A parameter given to warpdem is out of its physical or logical range."""


class SimulationError(RuntimeError):
    """A running simulation became unstable or overflowed a capacity; the message says where and why.

    Attributes:
        step: the step at which the problem was detected.
        body: the index of the offending body (-1 when not body-specific).
        cause: a short machine-readable cause ("nan", "speed", "escaped", "energy", "capacity").
        world: the world of that body (-1 when not body-specific).
    """

    def __init__(self, message: str, step: int = -1, body: int = -1, cause: str = "", world: int = -1) -> None:
        super().__init__(message)
        self.step = step
        self.body = body
        self.cause = cause
        self.world = world


class BudgetExhausted(RuntimeError):
    """A long run stopped at its wall-time budget after saving what it had: run it again to continue."""


def _describe(value: object) -> str:
    arr = np.asarray(value)
    if arr.size > 6:
        return f"array of shape {arr.shape}"
    return repr(value)


def check_finite(name: str, value: object) -> None:
    """Raise InputError if ``value`` (scalar or array) holds NaN or inf."""
    arr = np.asarray(value, dtype=np.float64)
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))
        where = f" at index {tuple(bad[0])}" if arr.ndim else ""
        raise InputError(f"{name} must be finite, got {_describe(value)} (non-finite{where})")


def check_positive(name: str, value: object) -> None:
    """Raise InputError unless every element of ``value`` is finite and > 0."""
    check_finite(name, value)
    arr = np.asarray(value, dtype=np.float64)
    if np.any(arr <= 0.0):
        bad = float(arr.reshape(-1)[np.argmax(arr.reshape(-1) <= 0.0)])
        where = "" if arr.size == 1 else f" (in {_describe(value)})"
        raise InputError(f"{name} must be > 0, got {bad!r}{where}")


def check_nonnegative(name: str, value: object) -> None:
    """Raise InputError unless every element of ``value`` is finite and >= 0."""
    check_finite(name, value)
    arr = np.asarray(value, dtype=np.float64)
    if np.any(arr < 0.0):
        bad = float(arr.reshape(-1)[np.argmax(arr.reshape(-1) < 0.0)])
        raise InputError(f"{name} must be >= 0, got {bad!r}")


def check_range(name: str, value: float, low: float, high: float, *, high_open: bool = False) -> None:
    """Raise InputError unless ``low <= value <= high`` (``< high`` when ``high_open``)."""
    check_finite(name, value)
    ok = low <= value < high if high_open else low <= value <= high
    if not ok:
        bracket = ")" if high_open else "]"
        raise InputError(f"{name} must be in [{low}, {high}{bracket}, got {value!r}")


def check_vec3(name: str, value: object) -> np.ndarray:
    """Return ``value`` as a float64 array of shape (3,), raising InputError otherwise."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (3,):
        raise InputError(f"{name} must be a 3-vector, got shape {arr.shape}")
    check_finite(name, arr)
    return arr


def check_points(name: str, value: object) -> np.ndarray:
    """Return ``value`` as a float64 array of shape (n, 3) with n >= 1, raising InputError otherwise."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] == 0:
        raise InputError(f"{name} must have shape (n, 3) with n >= 1, got shape {arr.shape}")
    check_finite(name, arr)
    return arr


def check_choice(name: str, value: object, choices: Iterable[object]) -> None:
    """Raise InputError unless ``value`` is one of ``choices``."""
    choices = list(choices)
    if value not in choices:
        raise InputError(f"{name} must be one of {choices}, got {value!r}")


def check_int(name: str, value: object, low: int = 0) -> int:
    """Return ``value`` as an int >= ``low``, raising InputError otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise InputError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


def check_keys(what: str, data: Mapping[str, object], known: Iterable[str],
               error: type[InputError] = InputError) -> None:
    """Raise ``error`` naming the keys of a description table ``what`` (e.g. "tool description x.toml") that are
    not ``known``, and the known ones."""
    known = sorted(known)
    unknown = sorted(set(data) - set(known))
    if unknown:
        raise error(f"{what}: unknown keys {unknown}; known {known}")


def count_table(name: str, value: object, what: str = "a number",
                error: type[InputError] = InputError) -> dict[int, float]:
    """A description's table of spring count = number (``what`` says which, e.g. "a rate [N/m]") as {int: float};
    ``error`` names ``name`` and the bad entry otherwise."""
    if not isinstance(value, Mapping):
        raise error(f"{name} must be a table of spring count = {what}, got {value!r}")
    table = {}
    for n, x in value.items():
        try:
            table[int(n)] = float(x)
        except (TypeError, ValueError):
            raise error(f"{name} entry {n!r} = {x!r}: a spring count and {what} are needed") from None
    return table


def degrees_to_radians(name: str, angle_deg: float) -> float:
    """Check a friction angle in degrees (0 <= angle < 90) and return it in radians."""
    check_range(name, angle_deg, 0.0, 90.0, high_open=True)
    return math.radians(angle_deg)
