"""The study's rigs, each named once: the name the command line, the measured data, the rig models and the
mechanisms use for it, what it is, and the scenes module that builds and runs it.

- ``ringing``: the hinged sweep on its spring stack, hit and left to ring (section 2.1.1, Table 2);
  :mod:`scenes.ringing` (and :mod:`scenes.ringing_twin`, the paper's build of it).
- ``soil-bin``: the sweep drawn through the soil bin, rigid or on its springs (sections 2.2, 2.4, Table 3);
  :mod:`scenes.soil_bin`.
- ``shear-box``: the direct shear box of a soil sample (section 2.3); :mod:`scenes.shear_box`.

Their calibration and diagnosis models stand beside them in :mod:`calibration` (``calibration.rig_models``: a model
per rig that has measured configurations to criticise; ``calibration.problems``: the GA problems over them).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from types import ModuleType

from warpdem.errors import InputError


@dataclass(frozen=True)
class Rig:
    """A rig of the study: ``name`` (its one spelling everywhere), ``title`` (for reports), ``module`` (the scenes
    module that builds and runs it)."""

    name: str
    title: str
    module: str

    def scene(self) -> ModuleType:
        """The scenes module of this rig (imported on first use)."""
        return importlib.import_module(self.module)


RINGING = Rig("ringing", "ringing test of the hinged tool on its springs (Table 2)", "scenes.ringing")
SOIL_BIN = Rig("soil-bin", "soil bin, rigid or passive tool (Table 3)", "scenes.soil_bin")
SHEAR_BOX = Rig("shear-box", "direct shear box (section 2.3)", "scenes.shear_box")
RIGS: dict[str, Rig] = {r.name: r for r in (RINGING, SOIL_BIN, SHEAR_BOX)}
"""every rig by name."""


def get(name: str, among: tuple[str, ...] | None = None) -> Rig:
    """The rig called ``name`` (one of ``among``, default every rig); InputError naming the known ones otherwise."""
    known = among if among is not None else tuple(RIGS)
    if name not in known:
        raise InputError(f"rig must be one of {', '.join(repr(k) for k in known)}, got {name!r}")
    return RIGS[name]
