"""Shear-box screening (section 2.3): the draught calibration accepts several parameter sets; each is run in the
direct shear box and ranked by its distance to the laboratory's cohesion and internal friction angle.

Distance: ``(dc / c_lab)^2 + (dphi / phi_lab)^2`` against the laboratory test at 3.96 % moisture (6.4 kPa, 32.3
deg; the soil bin's moisture), the metric :func:`scenes.shear_box.closest_ga_set` uses on the paper's Tables 4-6.
All sets run as the worlds of one batched shear-box simulation (one world per set and normal stress). Cohesion is
set on the contacts present at the start of shear and not on new ones, the rule of both soil rigs
(``scenes.paper.COHESION_ON_NEW_CONTACTS``).
"""

from __future__ import annotations

from collections.abc import Sequence

from scenes.assemblies import Bed
from scenes.shear_box import BATCH_CONSOLIDATION, lab_distance, lab_strength, preset, run_shear_boxes

from .genes import soil_fields


def distance(cohesion_kpa: float, friction_deg: float, lab: tuple[float, float] | None = None) -> float:
    """(dc / c_lab)^2 + (dphi / phi_lab)^2 [-] (:func:`scenes.shear_box.lab_distance`)."""
    return float(lab_distance(cohesion_kpa, friction_deg, lab))


def screen(sets: Sequence[dict[str, float]], assembly: str = "C", scale: str = "ci", *, device: str | None = None,
           bed: Bed | None = None, progress: object | None = None, **changes: object) -> list[dict[str, float]]:
    """Run every parameter set in the shear box (one batched simulation) and rank them.

    Args:
        sets: genes of each set: ``friction_angle`` [deg], ``normal_cohesion`` [Pa] (shear cohesion = half),
            ``eta_roll`` (= eta_twist) [-].
        assembly, scale: the shear box preset (:func:`scenes.shear_box.preset`).
        changes: further ShearBoxConfig fields (e.g. ``normal_stresses``); ``consolidation_time`` defaults to
            ``BATCH_CONSOLIDATION`` fixed, so that a set's result does not depend on the others.
    Returns:
        One row per set, best (smallest distance) first: the genes, ``cohesion_kpa``, ``friction_angle_deg``,
        ``r2``, ``distance`` and ``rank`` (1 = closest to the laboratory).
    """
    if not sets:
        raise ValueError("no parameter sets to screen")
    changes = {"consolidation_time": (BATCH_CONSOLIDATION, BATCH_CONSOLIDATION), **changes}
    configs = [preset(scale, assembly, **{f: float(v) for f, v in soil_fields(s).items()}, label=f"set {k + 1}",
                      **changes) for k, s in enumerate(sets)]
    results = run_shear_boxes(configs, device, bed=bed, progress=progress)
    lab = lab_strength()
    rows = []
    for k, (s, res) in enumerate(zip(sets, results, strict=True)):
        c, phi = res.fit.cohesion / 1e3, res.fit.friction_angle_deg
        rows.append({"set": k + 1, **{g: float(v) for g, v in s.items()}, "cohesion_kpa": float(c),
                     "friction_angle_deg": float(phi), "r2": float(res.fit.r2), "distance": distance(c, phi, lab)})
    rows.sort(key=lambda r: r["distance"])
    for rank, r in enumerate(rows, 1):
        r["rank"] = rank
    return rows
