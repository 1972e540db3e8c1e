"""The contact laws, and the one place that selects between them.

Adding a contact law: write ``warpdem/laws/<law>.py`` giving
(1) its material: a frozen dataclass with the class attributes ``LAW`` (a new id in ``base.py``) and ``FIELDS``
    (its per-world overridable fields, each a column of the Model's material tables), a ``flags`` property and a
    validating ``replace``. A field no law has yet needs a column: :data:`MATERIAL_FIELDS`, a ``mat_<field>`` array
    of ``Model`` packed by ``builder._MAT_ARRAYS``, a :class:`MaterialTables` field in ``base.py`` set in
    ``simulation._materials_of``;
(2) its material tables' struct in ``base.py`` (fields: :class:`MaterialTables`), the type that names the law;
(3) the pair physics ``make_phys(mats, mi, mj, pair, r1, r2) -> Phys`` taking those tables;
(4) the force law: one step of a contact's history, giving a ``LawOut``;
(5) ``elastic_energy(h, p, un)``, the energy stored in a contact [J];
(6) ``stiffness(h, p, un)``, the (kn, ks, kr, ktw) the time step estimate reads.
Then add one overload for the new tables to each of :func:`pair_phys`, :func:`contact_law`, :func:`elastic_energy`
and :func:`stiffness` below, the tables to :data:`MATERIAL_TABLES`, its material class to :data:`LAWS` and its name
to :data:`LAW_NAMES`, and the settings it cannot take to :func:`check_settings`. The kernels (``contacts.py``) call
only these four functions; a contact's history is the shared :class:`Hist` (a law uses the fields it needs).
``hertz_mindlin.py`` is the example to copy.

Every material of a model follows one law (``Model.contact_law``, checked by :func:`law_of`). The law is the type
of the material tables the kernels get (``Simulation.materials``): every kernel taking them is generic and compiled
once per law (:func:`overload_per_law`), so a contact pays for its own law only, with no branch on the law.

- ``cohfrict``: Yade's Law2_ScGeom6D_CohFrictPhys_CohesionMoment (``Material``): cohesion, rolling and twisting.
- ``hertz_mindlin``: Yade's Law2_ScGeom_MindlinPhys_Mindlin without cohesion (``HertzMindlinMaterial``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import warp as wp

from ..errors import InputError
from . import cohfrict, hertz_mindlin
from .base import (
    ACTIVE,
    COHESIVE,
    COHFRICT,
    FRAGILE,
    HERTZ_MINDLIN,
    MAT_COHESIVE,
    MAT_FRAGILE,
    MAT_MOMENT,
    CohFrictMaterials,
    HertzMindlinMaterials,
    Hist,
    LawOut,
    MaterialTables,
    Phys,
    empty_hist,
    new_hist,
    rotate_hist,
    set_cohesion,
)
from .cohfrict import Material
from .hertz_mindlin import HertzMindlinMaterial

wp.set_module_options({"enable_backward": False})

LAWS: dict[int, type] = {int(COHFRICT): Material, int(HERTZ_MINDLIN): HertzMindlinMaterial}
"""law id -> its material class."""
LAW_NAMES: dict[int, str] = {int(COHFRICT): "cohesive-frictional", int(HERTZ_MINDLIN): "Hertz-Mindlin"}
"""law id -> its name in messages."""
MATERIAL_FIELDS: tuple[str, ...] = Material.FIELDS
"""the columns of the Model's material tables: every law's ``FIELDS`` (a law leaves the others 0)."""


def law_of(materials: Sequence[object]) -> int:
    """The law id of a model's materials (``COHFRICT`` without any); InputError if they mix laws."""
    laws = {int(m.LAW) for m in materials}
    if len(laws) > 1:
        names = ", ".join(f"{type(m).__name__}" for m in materials)
        raise InputError(f"a model's materials must all follow one contact law, got {names}")
    return laws.pop() if laws else int(COHFRICT)


def check_settings(law: int, **settings: object) -> None:
    """Refuse the simulation settings ``law`` cannot take, naming the parameter and its value: Hertz-Mindlin has no
    cohesion and no moment law, so ``always_use_moment_law``, ``cohesion_on_new_contacts`` (True) and
    ``bond_detection_factor`` (other than 1) are refused; the cohesive-frictional law takes them all."""
    if law != HERTZ_MINDLIN:
        return
    refused = {"always_use_moment_law": False, "cohesion_on_new_contacts": False, "bond_detection_factor": 1.0}
    for name, value in settings.items():
        if name in refused and value != refused[name]:
            raise InputError(
                f"{name}={value!r} needs cohesive-frictional materials: the Hertz-Mindlin law has no "
                f"cohesion and no moment law (leave {name} at {refused[name]!r})"
            )


MATERIAL_TABLES: dict[int, Any] = {int(COHFRICT): CohFrictMaterials, int(HERTZ_MINDLIN): HertzMindlinMaterials}
"""law id -> the struct of its material tables (fields: :class:`MaterialTables`), whose type selects the law."""


def overload_per_law(*kernels: wp.Kernel) -> None:
    """Compile each kernel once per contact law: an overload whose ``mats`` argument is that law's material tables
    (:data:`MATERIAL_TABLES`), so that a launch runs the law of the tables it is given and no kernel branches on the
    law at run time."""
    for kernel in kernels:
        for tables in MATERIAL_TABLES.values():
            wp.overload(kernel, {"mats": tables})


# The four functions the kernels call, one overload per law: the type of ``mats`` selects it at compile time.
@wp.func
def pair_phys(mats: CohFrictMaterials, mi: int, mj: int, pair: int, r1: float, r2: float) -> Phys:
    """The contact parameters of materials mi (contact radius r1 [m]) and mj (r2 [m]), indices into the per-world
    tables, by the materials' law; pair: the pair's index into ``MaterialTables.pair_tan`` (its friction tangent)."""
    return cohfrict.make_phys(mats, mi, mj, pair, r1, r2)


@wp.func
def pair_phys(mats: HertzMindlinMaterials, mi: int, mj: int, pair: int, r1: float, r2: float) -> Phys:  # noqa: F811
    return hertz_mindlin.make_phys(mats, mi, mj, pair, r1, r2)


@wp.func
def contact_law(mats: CohFrictMaterials, h: Hist, p: Phys, is_new: int, n: wp.vec3f, un: float, v12: wp.vec3f,
                ang_sum: wp.vec3f, rel_angvel: wp.vec3f, dt: float, always_moment: int, unp_max: float) -> LawOut:
    """One step of the contact's law (the law of ``mats``): see ``cohfrict.law`` for the arguments (Hertz-Mindlin
    ignores ``rel_angvel``, ``always_moment`` and ``unp_max``)."""
    return cohfrict.law(h, p, is_new, n, un, v12, ang_sum, rel_angvel, dt, always_moment, unp_max)


@wp.func
def contact_law(mats: HertzMindlinMaterials, h: Hist, p: Phys, is_new: int, n: wp.vec3f, un: float,  # noqa: F811
                v12: wp.vec3f, ang_sum: wp.vec3f, rel_angvel: wp.vec3f, dt: float, always_moment: int,
                unp_max: float) -> LawOut:
    return hertz_mindlin.law(h, p, is_new, n, un, v12, ang_sum, dt)


@wp.func
def elastic_energy(mats: CohFrictMaterials, h: Hist, p: Phys, un: float) -> float:
    """Elastic energy stored in a contact of overlap un [m] [J], by the law of ``mats``."""
    return cohfrict.elastic_energy(h, p, un)


@wp.func
def elastic_energy(mats: HertzMindlinMaterials, h: Hist, p: Phys, un: float) -> float:  # noqa: F811
    return hertz_mindlin.elastic_energy(h, p, un)


@wp.func
def stiffness(mats: CohFrictMaterials, h: Hist, p: Phys, un: float) -> wp.vec4f:
    """The contact's (kn [N/m], ks [N/m], kr [N m/rad], ktw [N m/rad]) for the time step, by the law of ``mats``."""
    return cohfrict.stiffness(h, p, un)


@wp.func
def stiffness(mats: HertzMindlinMaterials, h: Hist, p: Phys, un: float) -> wp.vec4f:  # noqa: F811
    return hertz_mindlin.stiffness(h, p, un)


__all__ = [
    "ACTIVE",
    "COHESIVE",
    "COHFRICT",
    "FRAGILE",
    "HERTZ_MINDLIN",
    "LAWS",
    "LAW_NAMES",
    "MATERIAL_FIELDS",
    "MAT_COHESIVE",
    "MAT_FRAGILE",
    "MAT_MOMENT",
    "HertzMindlinMaterial",
    "Hist",
    "LawOut",
    "MATERIAL_TABLES",
    "CohFrictMaterials",
    "HertzMindlinMaterials",
    "Material",
    "MaterialTables",
    "Phys",
    "check_settings",
    "contact_law",
    "elastic_energy",
    "empty_hist",
    "law_of",
    "new_hist",
    "overload_per_law",
    "pair_phys",
    "rotate_hist",
    "set_cohesion",
    "stiffness",
]
