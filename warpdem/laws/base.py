"""What every contact law shares: the law ids, the per-contact history, the pair parameters, what one law
evaluation gives, and the per-world material tables the kernels read.

Conventions (``shared/docs/yade-physics.md`` sections 1-3): body 1 is the first body of a contact (for a
sphere-facet contact, the facet), the unit normal n points from 1 to 2, the overlap un > 0 when penetrating,
Fn > 0 compresses.
"""

from __future__ import annotations

import warp as wp

wp.set_module_options({"enable_backward": False})

#: Contact law ids (Model.contact_law, laws.MATERIAL_TABLES): which law a model's materials follow.
COHFRICT = wp.constant(0)  # Yade's Law2_ScGeom6D_CohFrictPhys_CohesionMoment (laws/cohfrict.py)
HERTZ_MINDLIN = wp.constant(1)  # Yade's Law2_ScGeom_MindlinPhys_Mindlin (laws/hertz_mindlin.py)

#: Hist.flags bits
ACTIVE = wp.constant(1)  # the contact exists (Yade: the interaction is real)
COHESIVE = wp.constant(2)  # cohesion is set and not broken
FRAGILE = wp.constant(4)  # the bond breaks (vs yields) at its strength

#: Material flag bits (Material.flags)
MAT_MOMENT = wp.constant(1)
MAT_FRAGILE = wp.constant(2)
MAT_COHESIVE = wp.constant(4)


@wp.struct
class Hist:
    """Per-contact history, float32 [N], [N m], [m] (a law uses the fields it needs and leaves the others 0)."""

    fs: wp.vec3f  # shear force acting on body 2 [N]
    mb: wp.vec3f  # bending (rolling) moment acting on body 2 [N m]
    mtw: wp.vec3f  # twisting moment acting on body 2 [N m]
    normal: wp.vec3f  # contact normal of the previous step
    unp: float  # plastic normal displacement [m]
    an: float  # normal adhesion [N]
    as_: float  # shear adhesion [N]
    flags: int  # ACTIVE | COHESIVE | FRAGILE


@wp.struct
class Phys:
    """A contact's parameters from its two materials and contact radii (Yade's Ip2 functor), computed each step by
    :func:`warpdem.laws.pair_phys`; a law reads the fields it needs, the others are 0."""

    kn: float
    """CohFrict: normal stiffness [N/m]; Hertz-Mindlin: kno, with Fn = kno un^1.5 [N/m^1.5]; float32."""
    ks: float
    """CohFrict: shear stiffness [N/m]; Hertz-Mindlin: kso, with ks = kso un^0.5 [N/m^1.5]; float32."""
    kr: float
    """rolling stiffness [N m/rad], float32 (CohFrict)."""
    ktw: float
    """twisting stiffness [N m/rad], float32 (CohFrict)."""
    tan_phi: float
    """tangent of the contact's friction angle [-], float32."""
    max_roll: float
    """maxRollPl [m], float32; < 0: no cap (CohFrict)."""
    max_twist: float
    """maxTwistPl [m], float32; < 0: no cap (CohFrict)."""
    moment_law: int
    """1: both materials have the moment law, int32 (CohFrict)."""
    cohesive: int
    """1: both materials may be cohesive, int32 (CohFrict)."""
    fragile: int
    """1: either material is fragile (Yade: fragile = fragile1 || fragile2), int32 (CohFrict)."""
    an: float
    """normal adhesion this contact would get [N], float32 (CohFrict)."""
    as_: float
    """shear adhesion this contact would get [N], float32 (CohFrict)."""
    adhesive: int
    """1: the pair of materials has an adhesion of its own, so a new contact is bonded (CohFrict), int32."""
    law: int
    """the contact law (COHFRICT, HERTZ_MINDLIN), int32."""


@wp.struct
class LawOut:
    """What one law evaluation produces."""

    hist: Hist
    force: wp.vec3f  # force on body 1 (body 2 gets -force), applied at the contact point [N]
    moment: wp.vec3f  # moment on body 2 (body 1 gets -moment) [N m]
    alive: int  # 0 if the law deleted the contact this step
    dissip_slide: float  # energy dissipated by sliding this step [J]
    dissip_roll: float  # energy dissipated by rolling/twisting plasticity this step [J]


class MaterialTables:
    """Per-world material tables (Simulation.materials, from the Model's), each of shape (n_worlds * n_materials,)
    but ``pair_tan``. The fields of every law's table struct (:data:`CohFrictMaterials`,
    :data:`HertzMindlinMaterials`): the struct's type is the law, so the kernels are compiled for one law each (a
    kernel taking the tables is generic over them, overloaded once per law) and branch on no law at run time."""

    young: wp.array(dtype=float)
    """Young's modulus [Pa], float32."""
    poisson: wp.array(dtype=float)
    """Poisson's ratio [-], float32 (CohFrict: Yade's shear to normal stiffness ratio; Hertz-Mindlin: the elastic
    Poisson's ratio)."""
    normal_coh: wp.array(dtype=float)
    """normal cohesion [Pa], float32."""
    shear_coh: wp.array(dtype=float)
    """shear cohesion [Pa], float32."""
    eta_roll: wp.array(dtype=float)
    """rolling plasticity coefficient [-], float32."""
    eta_twist: wp.array(dtype=float)
    """twisting plasticity coefficient [-], float32."""
    alpha_kr: wp.array(dtype=float)
    """rolling stiffness factor [-], float32."""
    alpha_ktw: wp.array(dtype=float)
    """twisting stiffness factor [-], float32."""
    flags: wp.array(dtype=int)
    """MAT_MOMENT | MAT_FRAGILE | MAT_COHESIVE, int32."""
    pair_tan: wp.array(dtype=float)
    """tangent of the friction angle of each pair of materials [-], float32, (n_worlds * n_materials *
    n_materials,) in world, first, second material order: the pair's own angle where one is set
    (``ModelBuilder.set_pair_friction``, Yade's MatchMaker on the Ip2's frictAngle), else the smaller of its two
    materials' angles (both laws' rule, Yade's default)."""
    pair_adh: wp.array(dtype=float)
    """adhesion of each pair of materials [Pa], float32, laid out as ``pair_tan``; -1: none
    (``ModelBuilder.set_pair_adhesion``; CohFrict)."""
    n_materials: int
    """materials per world, int32."""


@wp.struct
class CohFrictMaterials:
    """The material tables of a cohesive-frictional model (fields: :class:`MaterialTables`)."""

    __annotations__ = dict(MaterialTables.__annotations__)


@wp.struct
class HertzMindlinMaterials:
    """The material tables of a Hertz-Mindlin model (fields: :class:`MaterialTables`)."""

    __annotations__ = dict(MaterialTables.__annotations__)


@wp.func
def set_cohesion(h: Hist, p: Phys) -> Hist:
    """Yade's setCohesionNow on an existing contact: adhesions reset, cohesion (re)established."""
    out = h
    if p.cohesive != 0:
        out.an = p.an
        out.as_ = p.as_
        out.flags = ACTIVE | COHESIVE
        if p.fragile != 0:
            out.flags = out.flags | FRAGILE
    return out


@wp.func
def empty_hist() -> Hist:
    h = Hist()
    h.fs = wp.vec3f(0.0)
    h.mb = wp.vec3f(0.0)
    h.mtw = wp.vec3f(0.0)
    h.normal = wp.vec3f(0.0)
    h.unp = 0.0
    h.an = 0.0
    h.as_ = 0.0
    h.flags = 0
    return h


@wp.func
def new_hist(p: Phys, n: wp.vec3f, give_cohesion: int) -> Hist:
    """History of a contact created this step; cohesion is given if asked and both materials are cohesive."""
    h = empty_hist()
    h.normal = n
    h.flags = ACTIVE | FRAGILE
    if give_cohesion != 0:
        h = set_cohesion(h, p)
    return h


@wp.func(inline=True)  # inlined: the same code as before the split
def law_out(h: Hist) -> LawOut:
    """A law's output before its step: history h, no force or moment, alive, nothing dissipated."""
    out = LawOut()
    out.hist = h
    out.force = wp.vec3f(0.0)
    out.moment = wp.vec3f(0.0)
    out.alive = 1
    out.dissip_slide = 0.0
    out.dissip_roll = 0.0
    return out


@wp.func(inline=True)  # inlined: the same code as before the split
def deleted(out: LawOut) -> LawOut:
    """out for a contact the law deletes this step: not alive, its history cleared (the rest of out kept)."""
    out.alive = 0
    out.hist = empty_hist()
    return out


@wp.func(inline=True)  # inlined: the same code as before the split
def transport(h: Hist, n: wp.vec3f, ang_sum: wp.vec3f, dt: float, is_new: int):
    """The two small rotations that carry the history's tangential vectors from the previous normal h.normal to n
    (the current unit normal) over dt [s] with ang_sum = omega1 + omega2 [rad/s]: returns (orth, twist) for
    :func:`rotate_hist`, both zero for a new contact (is_new != 0: nothing to transport)."""
    orth = wp.vec3f(0.0)
    twist = wp.vec3f(0.0)
    if is_new == 0:
        orth = wp.cross(h.normal, n)
        twist = (0.5 * dt * wp.dot(h.normal, ang_sum)) * h.normal
    return orth, twist


@wp.func
def rotate_hist(v: wp.vec3f, orth: wp.vec3f, twist: wp.vec3f) -> wp.vec3f:
    """Yade's ScGeom::rotate: transport a tangential vector to the new contact plane (two small rotations)."""
    r = v - wp.cross(v, orth)
    return r - wp.cross(r, twist)
