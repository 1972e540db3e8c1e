"""The names this module used to hold, kept for callers outside the engine: the contact laws now live in
:mod:`warpdem.laws` (the cohesive-frictional law in ``warpdem/laws/cohfrict.py``), the sphere-triangle closest point
in :mod:`warpdem.geometry`."""

from __future__ import annotations

from .geometry import closest_point_triangle
from .laws import (
    ACTIVE,
    COHESIVE,
    FRAGILE,
    MAT_COHESIVE,
    MAT_FRAGILE,
    MAT_MOMENT,
    Hist,
    LawOut,
    Materials,
    Phys,
    empty_hist,
    new_hist,
    rotate_hist,
    set_cohesion,
)
from .laws.cohfrict import elastic_energy, hmean, make_phys
from .laws.cohfrict import law as cohfrict_law

__all__ = [
    "ACTIVE",
    "COHESIVE",
    "FRAGILE",
    "MAT_COHESIVE",
    "MAT_FRAGILE",
    "MAT_MOMENT",
    "Hist",
    "LawOut",
    "Materials",
    "Phys",
    "closest_point_triangle",
    "cohfrict_law",
    "elastic_energy",
    "empty_hist",
    "hmean",
    "make_phys",
    "new_hist",
    "rotate_hist",
    "set_cohesion",
]
