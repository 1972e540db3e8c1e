"""Yade's cohesive-frictional material (CohFrictMat) and the contact parameters derived from two of them.

Reference: ``shared/docs/yade-physics.md`` section 1 (Yade ``pkg/dem/CohesiveFrictionalContactLaw.cpp``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from .errors import check_finite, check_nonnegative, check_positive, check_range, degrees_to_radians

#: The per-world overridable material fields, as named in override tables (``material:<name>:<field>``).
MATERIAL_FIELDS = (
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
