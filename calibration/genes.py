"""Genes and GA settings: what is calibrated, over which range, and how the GA searches.

The defaults are the paper's (section 2.2): 5 generations, 20 individuals, 7 parents mating and kept, 0.01 % gene
mutation rate. With PyGAD that means ``keep_parents=-1`` (the 7 parents survive) and ``keep_elitism=0``: each
generation then makes 20 - 7 = 13 new individuals, so a calibration evaluates 20 + 5 x 13 = 85 individuals, the
paper's "85 simulations". A rate of 0.01 % of 2 or 3 genes is below one gene; PyGAD then mutates one gene per
offspring.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field

import numpy as np

FITNESS_MODES = ("paper", "max")
"""ringing fitness: "paper" is eq. (7), 1 / (RE_freq RE_damp); "max" is 1 / max(RE_freq, RE_damp). The product of
eq. (7) is unbounded when either error vanishes, whatever the other: it rewards an exact frequency with a poor
damping (Table 2's 16-spring row: 0.8 % and 5.3 %). "max" asks both errors to be small."""
PARENT_SELECTIONS = ("sss", "rws", "sus", "rank", "random", "tournament")
CROSSOVERS = ("single_point", "two_points", "uniform", "scattered")
MUTATIONS = ("random", "swap", "inversion", "scramble")


SHEAR_TO_NORMAL_COHESION = 0.5
"""the paper's soil sets tie the shear cohesion to the normal one (Tables 4-6: shear = normal / 2)."""


def soil_fields(genes: Mapping[str, object]) -> dict[str, object]:
    """The soil contact material's fields of a GA soil set (``scenes.soil_bin``'s ``soil_overrides``, the shear box's
    configuration): ``friction_angle`` [deg], ``normal_cohesion`` [Pa], ``shear_cohesion`` = normal / 2 [Pa],
    ``eta_roll`` = ``eta_twist`` [-], from the genes ``friction_angle``, ``normal_cohesion`` and ``eta_roll``
    (floats, or arrays (n,) of a population: the fields come out alike). The one place of the paper's rule."""
    return {"friction_angle": genes["friction_angle"], "normal_cohesion": genes["normal_cohesion"],
            "shear_cohesion": SHEAR_TO_NORMAL_COHESION * genes["normal_cohesion"], "eta_roll": genes["eta_roll"],
            "eta_twist": genes["eta_roll"]}


def soil_overrides(genes: Mapping[str, float], n: int) -> dict[str, list[float]]:
    """:func:`soil_fields` of one set for ``n`` worlds: field -> (n,) values."""
    return {k: [float(v)] * n for k, v in soil_fields(genes).items()}


@dataclass(frozen=True)
class Gene:
    """One calibrated parameter over [low, high] in its SI unit; ``log``: the GA searches log10(value), which
    samples every decade alike (for ranges spanning decades, e.g. a Young's modulus of 1e6-5e8 Pa)."""

    name: str
    low: float
    high: float
    log: bool = False
    unit: str = ""

    def __post_init__(self) -> None:
        for k in ("low", "high"):
            v = getattr(self, k)
            if not isinstance(v, int | float) or not math.isfinite(v):
                raise ValueError(f"gene {self.name!r}: {k} must be a finite number, got {v!r}")
        if not self.low < self.high:
            raise ValueError(f"gene {self.name!r}: empty range, low {self.low!r} must be below high {self.high!r}")
        if self.log and self.low <= 0:
            raise ValueError(f"gene {self.name!r}: a log-scaled gene needs low > 0, got {self.low!r}")

    def to_ga(self, value: np.ndarray | float) -> np.ndarray:
        """Physical value(s) -> the GA's coordinate."""
        v = np.asarray(value, dtype=np.float64)
        return np.log10(v) if self.log else v

    def from_ga(self, x: np.ndarray | float) -> np.ndarray:
        """The GA's coordinate(s) -> physical value(s), clipped to [low, high]."""
        x = np.asarray(x, dtype=np.float64)
        v = 10.0**x if self.log else x
        return np.clip(v, self.low, self.high)

    @property
    def ga_range(self) -> tuple[float, float]:
        lo, hi = self.to_ga(self.low), self.to_ga(self.high)
        return float(lo), float(hi)


def with_ranges(defaults: tuple[Gene, ...], ranges: dict[str, tuple[float, float]] | None) -> tuple[Gene, ...]:
    """The default genes with some ranges replaced: ``{name: (low, high)}``. Unknown names are errors."""
    ranges = dict(ranges or {})
    known = [g.name for g in defaults]
    for name in ranges:
        if name not in known:
            raise ValueError(f"unknown gene name {name!r}; this calibration's genes are {known}")
    out = []
    for g in defaults:
        if g.name in ranges:
            lo, hi = ranges[g.name]
            g = Gene(g.name, float(lo), float(hi), g.log, g.unit)
        out.append(g)
    return tuple(out)


@dataclass
class GASettings:
    """PyGAD settings (defaults: the paper's) and the optional batched local refinement after the GA."""

    generations: int = 5
    population: int = 20
    parents: int = 7
    """parents mating per generation (PyGAD num_parents_mating)."""
    keep_parents: int = -1
    """parents surviving into the next generation (-1: all of them, PyGAD's default)."""
    keep_elitism: int = 0
    mutation_percent_genes: float = 0.01
    parent_selection: str = "sss"
    crossover: str = "single_point"
    mutation: str = "random"
    seed: int = 0
    refine_iterations: int = 0
    """iterations of batched pattern search after the GA (0: none). Each evaluates the 3^g - 1 neighbours (g <= 3,
    else the 2g axis neighbours) of the best individual as one batch; a step that finds nothing better is halved."""
    refine_step: float = 0.05
    """first pattern-search step as a fraction of each gene's (GA-coordinate) range."""
    extra: dict[str, object] = field(default_factory=dict)
    """further PyGAD keyword arguments, passed through."""

    def __post_init__(self) -> None:
        for name, low in (("generations", 1), ("population", 2), ("parents", 1), ("refine_iterations", 0)):
            v = getattr(self, name)
            if not isinstance(v, int | np.integer) or v < low:
                raise ValueError(f"{name} must be an integer >= {low}, got {v!r}")
        if self.population < self.parents:
            raise ValueError(f"population ({self.population}) is smaller than the number of parents "
                             f"({self.parents})")
        if not (self.keep_parents == -1 or 0 <= self.keep_parents <= self.parents):
            raise ValueError(f"keep_parents must be -1 or in [0, parents={self.parents}], got {self.keep_parents!r}")
        if not 0 <= self.keep_elitism <= self.population:
            raise ValueError(f"keep_elitism must be in [0, population], got {self.keep_elitism!r}")
        if not 0 < self.mutation_percent_genes <= 100:
            raise ValueError(f"mutation_percent_genes must be in (0, 100], got {self.mutation_percent_genes!r}")
        for name, choices in (("parent_selection", PARENT_SELECTIONS), ("crossover", CROSSOVERS),
                              ("mutation", MUTATIONS)):
            if getattr(self, name) not in choices:
                raise ValueError(f"{name} must be one of {choices}, got {getattr(self, name)!r}")
        if not 0 < self.refine_step <= 0.5:
            raise ValueError(f"refine_step must be in (0, 0.5], got {self.refine_step!r}")

    def to_dict(self) -> dict[str, object]:
        return asdict(self)
