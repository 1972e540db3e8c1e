"""Yade's Hertz-Mindlin contact law without cohesion (FrictMat, Ip2_FrictMat_FrictMat_MindlinPhys,
Law2_ScGeom_MindlinPhys_Mindlin with its defaults): the material, the pair parameters, the force law, the elastic
energy and the stiffness for the time step.

Reference: Yade's ``pkg/dem/HertzMindlin.cpp`` (2023.02a). With materials a, b (Young's moduli Ea, Eb [Pa],
Poisson's ratios va, vb [-], friction angles phi_a, phi_b) and contact radii R1, R2 (a facet counts with twice the
sphere's radius, as in Yade's Ig2_Facet_Sphere_ScGeom):

- E* = Ea Eb / ((1 - va^2) Eb + (1 - vb^2) Ea), G = (Ea / (2 (1 + va)) + Eb / (2 (1 + vb))) / 2,
  v = (va + vb) / 2, R* = R1 R2 / (R1 + R2);
- kno = 4/3 E* sqrt(R*) [N/m^1.5], kso = 2 sqrt(4 R*) G / (2 - v) [N/m^1.5], tan(min(phi_a, phi_b));
- per step, with overlap un [m]: the contact is deleted when un < 0; Fn = kno un^1.5 [N];
  tangent stiffnesses kn = 3/2 kno un^0.5 and ks = kso un^0.5 [N/m] (the time step's);
  the shear force Fs (history) is transported to the current tangent plane, then Fs <- Fs - ks dus with dus the
  tangential relative displacement of the step (Yade's incident velocity with its anti-ratcheting factor, as the
  cohesive-frictional law); Coulomb slip |Fs| <= Fn tan(phi) (scaled back);
- force on body 1: -Fn n - Fs, at the contact point.

Not implemented (Yade's defaults leave them off): viscous damping (Ip2's en, es, betan, betas), adhesion
(includeAdhesion), the moment law (includeMoment, krot, ktwist), neverErase. There is no cohesion: a Simulation of
Hertz-Mindlin materials refuses ``always_use_moment_law=True``, ``cohesion_on_new_contacts=True``,
``bond_detection_factor`` other than 1 and :meth:`~warpdem.simulation.Simulation.set_cohesion_now` with an
InputError naming the parameter and its value.

Energies: the elastic energy of a contact is 2/5 kno un^2.5 (the integral of Fn, as Yade's normElastEnergy) plus
|Fs|^2 / (2 ks) (Yade integrates the shear part along the path instead; the two agree while un does not change);
the sliding dissipation of a step is (Fs_trial - Fs) . Fs / ks, as in the cohesive-frictional law.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import warp as wp

from ..errors import check_positive, check_range, degrees_to_radians
from .base import HERTZ_MINDLIN, HertzMindlinMaterials, Hist, LawOut, Phys, deleted, law_out, rotate_hist, transport

wp.set_module_options({"enable_backward": False})


@dataclass(frozen=True)
class HertzMindlinMaterial:
    """Yade's FrictMat for the Hertz-Mindlin law, in SI units (angles in degrees at this API). A model's materials
    all follow one law: Hertz-Mindlin materials cannot be mixed with cohesive-frictional ones (``Material``).

    Attributes:
        young: Young's modulus E [Pa] (> 0).
        poisson: the elastic Poisson's ratio v [-] in [0, 0.5] (unlike ``Material.poisson``, a stiffness ratio).
        density: density rho [kg/m^3] (> 0).
        friction_angle: interparticle friction angle phi [deg], 0 <= phi < 90.
    """

    LAW: ClassVar[int] = int(HERTZ_MINDLIN)
    """the contact law of this material (``laws.HERTZ_MINDLIN``)."""
    FIELDS: ClassVar[tuple[str, ...]] = ("young", "poisson", "density", "friction_angle")
    """the per-world overridable fields (``material:<name>:<field>``)."""

    young: float
    poisson: float
    density: float
    friction_angle: float

    def __post_init__(self) -> None:
        check_positive("young", self.young)
        check_range("poisson", self.poisson, 0.0, 0.5)
        check_positive("density", self.density)
        degrees_to_radians("friction_angle", self.friction_angle)

    def replace(self, **changes: float) -> HertzMindlinMaterial:
        """Return a copy with some fields changed (validated like a new material)."""
        return dataclasses.replace(self, **changes)

    @property
    def flags(self) -> int:
        """No moment law, no cohesion: 0 (the device encoding of ``Material.flags``)."""
        return 0


@wp.func
def make_phys(mats: HertzMindlinMaterials, mi: int, mj: int, pair: int, r1: float, r2: float) -> Phys:
    """Ip2_FrictMat_FrictMat_MindlinPhys for materials mi (contact radius r1 [m]) and mj (r2 [m]), indices into the
    per-world tables (pair: the pair's index into ``mats.pair_tan``): kno in ``kn`` and kso in ``ks`` [N/m^1.5], the
    friction tangent; no cohesion, no moments."""
    p = Phys()
    ea = mats.young[mi]
    eb = mats.young[mj]
    va = mats.poisson[mi]
    vb = mats.poisson[mj]
    g = 0.5 * (ea / (2.0 * (1.0 + va)) + eb / (2.0 * (1.0 + vb)))
    v = 0.5 * (va + vb)
    e = ea * eb / ((1.0 - va * va) * eb + (1.0 - vb * vb) * ea)
    r = r1 * r2 / (r1 + r2)
    p.kn = 4.0 / 3.0 * e * wp.sqrt(r)
    p.ks = 2.0 * wp.sqrt(4.0 * r) * g / (2.0 - v)
    p.tan_phi = mats.pair_tan[pair]  # the pair's own angle, or tan(min(phi_i, phi_j))
    p.max_roll = -1.0
    p.max_twist = -1.0
    return p


@wp.func
def law(h: Hist, p: Phys, is_new: int, n: wp.vec3f, un: float, v12: wp.vec3f, ang_sum: wp.vec3f, dt: float) -> LawOut:
    """One step of Law2_ScGeom_MindlinPhys_Mindlin (no damping, adhesion or moments).

    Args:
        h: history (for a new contact, from ``new_hist``): the shear force ``fs`` [N] and the previous normal.
        p: contact parameters from :func:`make_phys`.
        is_new: 1 if the contact was created this step (no transport of the history).
        n: current unit normal (1 -> 2). un: overlap [m]; the contact is deleted when un < 0.
        v12: velocity of 2 relative to 1 at the contact point [m/s] (Yade's getIncidentVel).
        ang_sum: omega1 + omega2 [rad/s] (for the twist part of the transport).
        dt: time step [s].
    """
    out = law_out(h)
    if un < 0.0:
        return deleted(out)
    root = wp.sqrt(un)
    fn = p.kn * un * root  # kno un^1.5
    ks = p.ks * root  # tangent shear stiffness [N/m]

    # transport the history to the current tangent plane (nothing to transport for a new contact)
    fs = wp.vec3f(0.0)
    if is_new == 0:
        orth, twist = transport(h, n, ang_sum, dt, is_new)
        fs = rotate_hist(h.fs, orth, twist)
    dus = (v12 - wp.dot(n, v12) * n) * dt
    fs = fs - ks * dus

    # Coulomb slip
    max_fs = fn * p.tan_phi
    if wp.dot(fs, fs) > max_fs * max_fs:
        trial = fs
        fs = fs * (max_fs / wp.length(fs))
        if ks > 0.0:
            d = wp.dot(trial - fs, fs) / ks
            if d > 0.0:
                out.dissip_slide = d
    out.hist.fs = fs
    out.hist.normal = n
    out.force = -fn * n - fs
    return out


@wp.func
def elastic_energy(h: Hist, p: Phys, un: float) -> float:
    """Elastic energy stored in a contact [J]: 2/5 kno un^2.5 + |Fs|^2 / (2 kso un^0.5)."""
    if un <= 0.0:
        return 0.0
    root = wp.sqrt(un)
    return 0.4 * p.kn * un * un * root + 0.5 * wp.dot(h.fs, h.fs) / (p.ks * root)


@wp.func
def stiffness(h: Hist, p: Phys, un: float) -> wp.vec4f:
    """The contact's tangent stiffnesses for the time step, as Yade's law stores them for
    GlobalStiffnessTimeStepper: (kn = 3/2 kno un^0.5 [N/m], ks = kso un^0.5 [N/m], 0, 0)."""
    root = wp.sqrt(wp.max(un, 0.0))
    return wp.vec4f(1.5 * p.kn * root, p.ks * root, 0.0, 0.0)
