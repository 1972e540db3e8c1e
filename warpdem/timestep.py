"""Time step estimates: the P-wave critical step and a contact-stiffness estimate (Yade's timesteppers)."""

from __future__ import annotations

import math

import numpy as np

from .errors import InputError
from .model import ALL_DOFS, FLAG_PIVOT, Model

MAX_STEPS = 5e7
"""steps of one simulation beyond which a run is refused before it starts: at ~1e4 steps/s (a small rig on a CPU)
more than a day, at paper scale on a GPU weeks. Every run of the paper's study needs fewer than 1e6; more means an
input (a Young's modulus, a spring stiffness, a particle size) collapsed the time step."""


def pwave_timestep(model: Model) -> float:
    """Yade's PWaveTimeStep: min over spheres (and worlds) of r / sqrt(E / rho) [s]; inf without spheres."""
    if model.n_spheres == 0:
        return math.inf
    mat = model.host["sphere_material"] + model.host["sphere_world"] * model.n_materials
    e = model.host["material_young"][mat]
    rho = model.host["material_density"][mat]
    return float(np.min(model.host["sphere_radius"] / np.sqrt(e / rho)))


def spring_timestep(model: Model) -> float:
    """Stability limit of the spring connectors [s]: 2/omega (sqrt(1 + zeta^2) - zeta) per spring (the central
    difference limit of a damped oscillator), omega^2 = k / m_red, zeta = c / (2 sqrt(k m_red)), with m_red the reduced
    mass of the two ends. A hinged body's end counts with its effective mass I_p / r^2 at the attachment point (r
    from the pivot, I_p the smallest moment about the pivot); other bodies count with their mass (translation only:
    a stiff spring on a light lever arm can be stiffer than this suggests). A spring with a stop counts with k plus
    the stop's stiffness (the stiffer side)."""
    if model.n_springs == 0:
        return math.inf
    a = model.spring_body_a.numpy()
    b = model.spring_body_b.numpy()
    k = model.spring_stiffness.numpy().astype(np.float64)
    k = k + np.where(model.spring_preload.numpy() != 0, model.spring_stop_stiffness.numpy().astype(np.float64), 0.0)
    c = model.spring_damping.numpy().astype(np.float64)
    mass = model.host["body_mass"]
    free = (model.host["body_flags"] & ALL_DOFS) != ALL_DOFS
    inv = np.where(free, 1.0 / np.where(mass > 0, mass, 1.0), 0.0)
    inv_a, inv_b = inv[a].copy(), inv[b].copy()
    hinged = (model.host["body_flags"] & FLAG_PIVOT) != 0
    if np.any(hinged):
        inertia = model.host["body_inertia"]
        pivot = model.host["body_pivot"]
        sides = ((a, model.spring_point_a.numpy(), inv_a), (b, model.spring_point_b.numpy(), inv_b))
        for ends, points, inv_end in sides:
            for s in np.nonzero(hinged[ends])[0]:
                body = ends[s]
                d = pivot[body]  # centre of mass -> pivot, body frame
                i_p = inertia[body].min() + mass[body] * float(d @ d)  # a lower bound of the moments about the pivot
                r2 = float(np.sum((points[s] - d) ** 2))
                inv_end[s] = r2 / i_p
    inv_red = inv_a + inv_b
    ok = (k > 0) & (inv_red > 0)
    if not np.any(ok):
        return math.inf
    omega = np.sqrt(k[ok] * inv_red[ok])
    zeta = c[ok] / (2.0 * np.sqrt(k[ok] / inv_red[ok]))
    return float(np.min(2.0 / omega * (np.sqrt(1.0 + zeta**2) - zeta)))


def critical_timestep(model: Model) -> float:
    """The step a simulation may not exceed without ``force_dt``: min of the P-wave and spring limits [s]."""
    return min(pwave_timestep(model), spring_timestep(model))


def stiffness_timestep(sim: object, safety: float = 0.8) -> float:
    """Yade's GlobalStiffnessTimeStepper estimate from the current contacts [s], with each contact's stiffnesses as
    its law gives them (``laws.stiffness``, read through ``observers.contact_table``).

    Per body: K_i = sum (kn - ks) n_i^2 + ks (translation), K_R,i = sum ks R^2 (1 - n_i^2) + kr (1 - n_i^2) + ktw n_i^2
    (rotation); dt = 1.41044 * safety * min sqrt(m / K_i), sqrt(I / K_R,i).
    """
    from .observers import contact_table

    model = sim.model
    ct = contact_table(sim)
    if len(ct["kn"]) == 0:
        return pwave_timestep(model)
    nb = model.n_bodies
    kt = np.zeros((nb, 3))
    kr = np.zeros((nb, 3))
    n2 = ct["normal"] ** 2
    for side in ("body1", "body2"):
        body = ct[side]
        r = ct["radius1" if side == "body1" else "radius2"]
        np.add.at(kt, body, (ct["kn"] - ct["ks"])[:, None] * n2 + ct["ks"][:, None])
        np.add.at(kr, body, (ct["ks"] * r**2 + ct["kr"])[:, None] * (1 - n2) + ct["ktw"][:, None] * n2)
    mass = model.host["body_mass"]
    inertia = model.host["body_inertia"]
    free = (model.host["body_flags"] & ALL_DOFS) != ALL_DOFS
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = np.where(kt > 0, mass[:, None] / kt, np.inf)
        t2 = np.where(kr > 0, inertia / kr, np.inf)
    dt2 = np.minimum(t1, t2)[free]
    if dt2.size == 0 or not np.isfinite(dt2).any():
        return pwave_timestep(model)
    return float(1.41044 * safety * np.sqrt(np.min(dt2)))


def check_step_count(what: str, duration: float, dt: float, cause: str, limit: float = MAX_STEPS) -> int:
    """Refuse a run of ``duration`` [s] at step ``dt`` [s] that would take more than ``limit`` steps.

    Args:
        what: the run, for the message ("soil-bin run", "deposition", ...).
        duration: simulated time [s]. dt: the time step [s] the run would use.
        cause: what sets ``dt`` (the inputs to change), for the message.

    Returns the number of steps. Raises InputError naming the step, the count and the cause.
    """
    if not (math.isfinite(dt) and dt > 0.0):
        raise InputError(f"{what}: the time step must be finite and > 0 s, got {dt!r} (set by {cause})")
    steps = duration / dt
    if not math.isfinite(steps) or steps > limit:
        raise InputError(f"{what}: dt = {dt:.3g} s for {duration:.3g} s of simulated time is {steps:.3g} steps, more "
                         f"than {limit:.0e}; the step is set by {cause}")
    return int(math.ceil(steps))
