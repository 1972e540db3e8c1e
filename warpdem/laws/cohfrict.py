"""Yade's cohesive-frictional contact law (CohFrictMat, Ip2_CohFrictMat_CohFrictMat_CohFrictPhys,
Law2_ScGeom6D_CohFrictPhys_CohesionMoment): the material, the pair parameters, the force law, the elastic energy and
the stiffness for the time step.

Reference: ``shared/docs/yade-physics.md`` sections 1-3 (Yade ``pkg/dem/CohesiveFrictionalContactLaw.cpp``).
The history of a contact (shear force, bending and twisting moments, plastic normal displacement, adhesions, the
previous normal and its flags) is a :class:`~warpdem.laws.base.Hist`; :func:`law` advances it by one step.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import warp as wp

from ..errors import check_finite, check_nonnegative, check_positive, check_range, degrees_to_radians
from .base import (
    COHESIVE,
    COHFRICT,
    FRAGILE,
    MAT_COHESIVE,
    MAT_FRAGILE,
    MAT_MOMENT,
    CohFrictMaterials,
    Hist,
    LawOut,
    Phys,
    deleted,
    law_out,
    rotate_hist,
    transport,
)

wp.set_module_options({"enable_backward": False})


@dataclass(frozen=True)
class Material:
    """Yade's CohFrictMat, in SI units (angles in degrees at this API).

    Attributes:
        young: Young's modulus E [Pa]; the contact normal stiffness is kn = E*R for equal spheres.
        poisson: the stiffness RATIO ks/kn [-] in [0, 1] (Yade's "poisson"; not an elastic Poisson effect).
        density: density rho [kg/m^3].
        friction_angle: interparticle friction angle phi [deg], 0 <= phi < 90.
        normal_cohesion: normal cohesion Cn [Pa]; the bond strength is an = Cn * min(R1, R2)^2 [N].
        shear_cohesion: shear cohesion Cs [Pa]; as = Cs * min(R1, R2)^2 [N].
        eta_roll: rolling plastic coefficient [-]; the rolling moment is capped at eta_roll*R*|Fn|.
            Negative means no cap (purely elastic), as in Yade.
        eta_twist: twisting plastic coefficient [-], likewise.
        alpha_kr: rolling stiffness factor [-]: kr = R1*R2*ks*alpha_kr (harmonic mean of the two materials).
        alpha_ktw: twisting stiffness factor [-]: ktw = R1*R2*ks*alpha_ktw.
        moment_law: apply rolling and twisting moments (Yade's momentRotationLaw; both materials need it).
        fragile: a cohesive bond breaks for good at its strength (True) or yields plastically (False).
        cohesive: whether contacts of this material may receive cohesion (Yade's isCohesive).
    """

    LAW: ClassVar[int] = int(COHFRICT)
    """the contact law of this material (``laws.COHFRICT``)."""
    FIELDS: ClassVar[tuple[str, ...]] = (
        "young",
        "poisson",
        "density",
        "friction_angle",
        "normal_cohesion",
        "shear_cohesion",
        "eta_roll",
        "eta_twist",
        "alpha_kr",
        "alpha_ktw",
    )
    """the per-world overridable fields (``material:<name>:<field>``), in the order of the Model's tables."""

    young: float
    poisson: float
    density: float
    friction_angle: float
    normal_cohesion: float = 0.0
    shear_cohesion: float = 0.0
    eta_roll: float = -1.0
    eta_twist: float = -1.0
    alpha_kr: float = 2.0
    alpha_ktw: float = 2.0
    moment_law: bool = False
    fragile: bool = True
    cohesive: bool = True

    def __post_init__(self) -> None:
        check_positive("young", self.young)
        check_range("poisson", self.poisson, 0.0, 1.0)
        check_positive("density", self.density)
        degrees_to_radians("friction_angle", self.friction_angle)
        check_nonnegative("normal_cohesion", self.normal_cohesion)
        check_nonnegative("shear_cohesion", self.shear_cohesion)
        check_finite("eta_roll", self.eta_roll)
        check_finite("eta_twist", self.eta_twist)
        check_nonnegative("alpha_kr", self.alpha_kr)
        check_nonnegative("alpha_ktw", self.alpha_ktw)

    def replace(self, **changes: float | bool) -> Material:
        """Return a copy with some fields changed (validated like a new material)."""
        return dataclasses.replace(self, **changes)

    @property
    def flags(self) -> int:
        """Bit set: 1 = moment law, 2 = fragile, 4 = cohesive (the device encoding)."""
        return int(self.moment_law) | (int(self.fragile) << 1) | (int(self.cohesive) << 2)


@wp.func
def hmean(a: float, b: float) -> float:
    if a > 0.0 and b > 0.0:
        return 2.0 * a * b / (a + b)
    return 0.0


@wp.func
def make_phys(mats: CohFrictMaterials, mi: int, mj: int, pair: int, r1: float, r2: float) -> Phys:
    """Contact parameters for materials mi (radius r1 [m]) and mj (radius r2 [m]), indices into the per-world
    tables; pair: the pair's index into ``mats.pair_tan`` (its friction tangent)."""
    p = Phys()
    a1 = mats.young[mi] * r1
    a2 = mats.young[mj] * r2
    p.kn = 2.0 * a1 * a2 / (a1 + a2)
    b1 = a1 * mats.poisson[mi]
    b2 = a2 * mats.poisson[mj]
    p.ks = 0.0
    if b1 + b2 > 0.0:
        p.ks = 2.0 * b1 * b2 / (b1 + b2)
    p.kr = r1 * r2 * p.ks * hmean(mats.alpha_kr[mi], mats.alpha_kr[mj])
    p.ktw = r1 * r2 * p.ks * hmean(mats.alpha_ktw[mi], mats.alpha_ktw[mj])
    p.tan_phi = mats.pair_tan[pair]  # the pair's own angle, or tan(min(phi_i, phi_j))
    p.max_roll = wp.min(mats.eta_roll[mi] * r1, mats.eta_roll[mj] * r2)
    p.max_twist = wp.min(mats.eta_twist[mi] * r1, mats.eta_twist[mj] * r2)
    fi = mats.flags[mi]
    fj = mats.flags[mj]
    p.moment_law = int((fi & MAT_MOMENT) != 0 and (fj & MAT_MOMENT) != 0)
    p.cohesive = int((fi & MAT_COHESIVE) != 0 and (fj & MAT_COHESIVE) != 0)
    p.fragile = int((fi & MAT_FRAGILE) != 0 or (fj & MAT_FRAGILE) != 0)
    rmin = wp.min(r1, r2)
    p.an = wp.min(mats.normal_coh[mi], mats.normal_coh[mj]) * rmin * rmin
    p.as_ = wp.min(mats.shear_coh[mi], mats.shear_coh[mj]) * rmin * rmin
    adhesion = mats.pair_adh[pair]
    if adhesion >= 0.0:  # the pair's own adhesion: its bonds' strength, given to every new contact
        p.adhesive = 1
        p.cohesive = 1
        p.an = adhesion * rmin * rmin
        p.as_ = p.an
    return p


@wp.func(inline=True)  # inlined: the same code as before the split
def normal_force(h: Hist, p: Phys, un: float, fragile: bool, unp_max: float):
    """The normal force fn [N] (positive in compression) of a contact of overlap un [m], with its plastic normal
    displacement unp [m] (h.unp, or the new one where a non-fragile bond yields in tension); returns (alive, fn,
    unp), alive 0 where the bond breaks (a fragile one beyond its strength h.an [N], a non-fragile one whose
    plastic tensile displacement -unp exceeds unp_max [m] where unp_max >= 0)."""
    fn = p.kn * (un - h.unp)
    unp = h.unp
    if -fn > h.an:
        if fragile:
            return 0, fn, unp
        # non-fragile: normal plasticity in tension
        fn = -h.an
        unp = un + h.an / p.kn
        if unp_max >= 0.0 and -unp > unp_max:
            return 0, fn, unp
    return 1, fn, unp


@wp.func(inline=True)  # inlined: the same code as before the split
def shear_force(out: LawOut, h: Hist, p: Phys, fn: float, fragile: bool, is_new: int, n: wp.vec3f, v12: wp.vec3f,
                orth: wp.vec3f, twist: wp.vec3f, dt: float):
    """The shear force: h.fs [N] transported to the current tangent plane (by orth and twist, see
    :func:`~warpdem.laws.base.rotate_hist`; zero for a new contact), plus -ks times the shear increment of v12
    [m/s] over dt [s], held to the Coulomb limit with shear adhesion (a fragile cohesive bond loses its cohesion
    when the limit is exceeded). Sets out.hist.fs, out.hist's cohesion where it breaks and out.dissip_slide [J];
    returns (out, fn_out), fn_out the normal force [N] the contact transmits (0 for a sliding one in tension)."""
    fn_out = fn
    fs = rotate_hist(h.fs, orth, twist)
    if is_new != 0:
        fs = wp.vec3f(0.0)
    dus = (v12 - wp.dot(n, v12) * n) * dt
    fs = fs - p.ks * dus

    # Coulomb limit with shear adhesion; fragile bonds break when exceeded
    fs_norm = wp.length(fs)
    max_fs = wp.max(0.0, out.hist.as_ + fn * p.tan_phi)
    if fs_norm > max_fs:
        if fragile and (out.hist.flags & COHESIVE) != 0:
            out.hist.flags = out.hist.flags & ~COHESIVE
            out.hist.an = 0.0
            out.hist.as_ = 0.0
            max_fs = wp.max(0.0, fn * p.tan_phi)
        trial = fs
        fs = fs * (max_fs / fs_norm)
        if p.ks > 0.0:
            d = wp.dot(trial - fs, fs) / p.ks
            if d > 0.0:
                out.dissip_slide = d
        if fn < 0.0:
            fn_out = 0.0
    out.hist.fs = fs
    return out, fn_out


@wp.func(inline=True)  # inlined: the same code as before the split
def cap_moment(m: wp.vec3f, m_max: float, k: float):
    """A rolling or twisting moment m [N m] held to its plastic cap m_max [N m] (m_max >= 0); returns (the capped
    moment, the energy dissipated [J] by the cap at rotational stiffness k [N m/rad], 0 where k is 0 or m is within
    the cap)."""
    dissip = 0.0
    mn = wp.length(m)
    if mn > m_max:
        if k > 0.0:
            dissip = (mn - m_max) * m_max / k
        if mn > 0.0:
            m = m * (m_max / mn)
    return m, dissip


@wp.func(inline=True)  # inlined: the same code as before the split
def moments(out: LawOut, h: Hist, p: Phys, fn_out: float, n: wp.vec3f, rel_angvel: wp.vec3f, orth: wp.vec3f,
            twist: wp.vec3f, dt: float, always_moment: int) -> LawOut:
    """The rolling and twisting moments, incremental form with plastic caps (eta * R * |fn_out| [N m]): h.mb and
    h.mtw [N m] transported (orth, twist) and advanced by -kr dt and -ktw dt times the bending and twisting parts
    of rel_angvel [rad/s], on a contact whose materials both take the moment law and that is cohesive (or any, with
    always_moment). Sets out.moment, out.hist.mb, out.hist.mtw, out.hist.normal = n and adds the caps' work [J] to
    out.dissip_roll."""
    mb = h.mb
    mtw = h.mtw
    if p.moment_law != 0 and ((out.hist.flags & COHESIVE) != 0 or always_moment != 0):
        rel_twist = wp.dot(n, rel_angvel) * n
        rel_bend = rel_angvel - rel_twist
        mb = rotate_hist(h.mb, orth, twist) - p.kr * dt * rel_bend
        mtw = rotate_hist(h.mtw, orth, twist) - p.ktw * dt * rel_twist
        fabs = wp.abs(fn_out)
        if p.max_roll >= 0.0:
            mb, d_roll = cap_moment(mb, p.max_roll * fabs, p.kr)
            out.dissip_roll += d_roll
        if p.max_twist >= 0.0:
            mtw, d_twist = cap_moment(mtw, p.max_twist * fabs, p.ktw)
            out.dissip_roll += d_twist
        out.moment = mb + mtw
    out.hist.mb = mb
    out.hist.mtw = mtw
    out.hist.normal = n
    return out


@wp.func
def law(
    h: Hist,
    p: Phys,
    is_new: int,
    n: wp.vec3f,
    un: float,
    v12: wp.vec3f,
    ang_sum: wp.vec3f,
    rel_angvel: wp.vec3f,
    dt: float,
    always_moment: int,
    unp_max: float,
) -> LawOut:
    """One step of Law2_ScGeom6D_CohFrictPhys_CohesionMoment (incremental moments).

    Args:
        h: history (for a new contact, from :func:`new_hist`).
        p: contact parameters.
        is_new: 1 if the contact was created this step (no rotation of the history).
        n: current unit normal (1 -> 2). un: overlap [m].
        v12: velocity of 2 relative to 1 at the contact point [m/s] (Yade's getIncidentVel).
        ang_sum: omega1 + omega2 [rad/s] (for the twist part of the transport).
        rel_angvel: omega2 - omega1 [rad/s].
        dt: time step [s]. always_moment: apply moments on non-cohesive contacts too.
        unp_max: a non-fragile contact is deleted when its plastic tensile displacement -unp exceeds this [m]
            (Yade's unpMax: 0 by default, so it breaks at its first tensile yield; < 0 means never).
    """
    out = law_out(h)
    fragile = (h.flags & FRAGILE) != 0
    alive, fn, unp = normal_force(h, p, un, fragile, unp_max)
    if alive == 0:
        return deleted(out)
    out.hist.unp = unp
    orth, twist = transport(h, n, ang_sum, dt, is_new)  # to the current tangent plane
    out, fn_out = shear_force(out, h, p, fn, fragile, is_new, n, v12, orth, twist, dt)
    out.force = -fn_out * n - out.hist.fs
    return moments(out, h, p, fn_out, n, rel_angvel, orth, twist, dt, always_moment)


@wp.func
def elastic_energy(h: Hist, p: Phys, un: float) -> float:
    """Elastic energy stored in a contact [J]: (Fn^2/kn + Fs^2/ks + Mb^2/kr + Mtw^2/ktw)/2."""
    fn = p.kn * (un - h.unp)
    e = 0.5 * fn * fn / p.kn
    if p.ks > 0.0:
        e += 0.5 * wp.dot(h.fs, h.fs) / p.ks
    if p.kr > 0.0:
        e += 0.5 * wp.dot(h.mb, h.mb) / p.kr
    if p.ktw > 0.0:
        e += 0.5 * wp.dot(h.mtw, h.mtw) / p.ktw
    return e


@wp.func
def stiffness(h: Hist, p: Phys, un: float) -> wp.vec4f:
    """The contact's stiffnesses for the time step (Yade's GlobalStiffnessTimeStepper reads them): (kn [N/m],
    ks [N/m], kr [N m/rad], ktw [N m/rad]); constant over the contact's life."""
    return wp.vec4f(p.kn, p.ks, p.kr, p.ktw)
