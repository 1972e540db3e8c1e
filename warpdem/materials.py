"""The materials of the contact laws (each defined beside its law in :mod:`warpdem.laws`): ``Material`` is Yade's
CohFrictMat (``laws/cohfrict.py``), ``HertzMindlinMaterial`` Yade's FrictMat for the Hertz-Mindlin law
(``laws/hertz_mindlin.py``). ``MATERIAL_FIELDS``: the per-world overridable fields, as named in override tables
(``material:<name>:<field>``); a material takes those of its ``FIELDS``.
"""

from __future__ import annotations

from .laws import MATERIAL_FIELDS, HertzMindlinMaterial, Material

__all__ = ["MATERIAL_FIELDS", "HertzMindlinMaterial", "Material"]
