"""warpdem's bond protocols on the bed of bond_protocols_twin.py, beside Yade's (bond_protocols_yade.npz).

    python benchmarks/yade/bond_protocols_compare.py [--device cpu]   # -> bond_protocols_report.md
    python benchmarks/yade/bond_protocols_compare.py --bed A_dense    # -> bond_protocols_report_A_dense.md

The scene is the Yade script's, built from the same spec (soil_bin_twin_spec_A.npz: assembly A's ci bed of 681
spheres, GA set 11's float32 material values, the bin's 10 facets, warpdem's dt, no tool) with warpdem's public API;
each protocol as the Yade script runs it (its docstring), the settling with Cundall damping on the soil group (the
NewtonIntegrator's damping in Yade) and ``Simulation(bond_detection_factor=...)`` for distance bonding.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def paths(bed: str = "A") -> tuple[Path, Path, Path]:
    """The spec, Yade's output and the report of a bed ("A": assembly A's ci bed; "A_dense": deposited without
    friction)."""
    tail = "" if bed == "A" else "_" + bed
    return (HERE / f"soil_bin_twin_spec_{bed}.npz", HERE / f"bond_protocols_yade{tail}.npz",
            HERE / f"bond_protocols_report{tail}.md")


SPEC, YADE, REPORT = paths()


def load(path: Path) -> dict[str, np.ndarray]:
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


def materials(spec: dict[str, np.ndarray]) -> tuple[object, object]:
    """The soil (GA set 11) and wall materials as the spec holds them (float32 values, friction in degrees)."""
    import warpdem as wd

    def f(prefix: str, key: str) -> float:
        return float(spec[f"{prefix}_{key}_f32"])

    soil = wd.Material(young=f("soil", "young"), poisson=f("soil", "poisson"), density=float(spec["soil_density"]),
                       friction_angle=float(np.degrees(f("soil", "friction_angle_rad"))),
                       normal_cohesion=f("soil", "normal_cohesion"), shear_cohesion=f("soil", "shear_cohesion"),
                       eta_roll=f("soil", "eta_roll"), eta_twist=f("soil", "eta_twist"), moment_law=True)
    wall = wd.Material(young=f("tool", "young"), poisson=f("tool", "poisson"), density=float(spec["tool_density"]),
                       friction_angle=float(np.degrees(f("tool", "friction_angle_rad"))))
    return soil, wall


def run(protocol: str, spec: dict[str, np.ndarray], yade: dict[str, np.ndarray], device: str = "cpu",
        perturb: float = 0.0, seed: int = 0) -> dict[str, np.ndarray]:
    """One protocol of the Yade script in warpdem: records after the bonding step and every ``record`` steps
    (step, c_ss, coh_ss, ke [J]) and the gaps [m] of the bonds whose spheres do not touch after the bonding step.
    ``perturb`` [m]: every sphere displaced by a uniform random vector in [-perturb, perturb]^3 (another
    realization of the same bed)."""
    import warpdem as wd

    soil, wall = materials(spec)
    if protocol == "ductile":
        soil = replace(soil, fragile=False)
    pos = spec["sphere_pos"].copy()
    if perturb > 0:
        pos += np.random.default_rng(seed).uniform(-perturb, perturb, pos.shape)
    b = wd.ModelBuilder(gravity=tuple(float(g) for g in spec["gravity"]))
    b.add_material("soil", soil)
    b.add_material("wall", wall)
    tri = spec["bin_tri"]
    b.add_mesh("bin", tri.reshape(-1, 3), np.arange(3 * len(tri)).reshape(-1, 3), "wall")
    b.add_spheres(pos, spec["sphere_radius"], "soil", group="soil")
    settled = protocol.startswith("settled")
    detection = float(yade["detection"]) if protocol.endswith("distance") else 1.0
    model, state = b.finalize(device)
    sim = wd.Simulation(model, state, dt=float(spec["dt"]), always_use_moment_law=True,
                        cohesion_on_new_contacts=protocol == "new", bond_detection_factor=detection)
    contacts, bonds = wd.observers.coordination_number("soil"), wd.observers.cohesive_bonds("soil")
    n = len(pos)

    def record() -> tuple[float, float, float, float]:
        c = float(contacts(sim)[0]) * n / 2.0
        ke = float(wd.observers.kinetic_energy(sim)[0])  # the bin's facets have no mass: the soil's, as Yade's
        return float(sim.state.step), round(c), float(bonds(sim)[0]), ke

    if settled:
        sim.set_local_damping("soil", float(yade["settle_damping"]))
        sim.advance(int(yade["settle_steps"]))
        sim.set_local_damping("soil", 0.0)
    sim.set_cohesion_now()
    sim.advance(1)
    gaps = _bond_gaps(sim)
    rec = [record()]
    every = int(yade["record"])
    for _ in range(int(yade["run_steps"]) // every):
        sim.advance(every)
        rec.append(record())
    r = np.array(rec)
    return {"step": r[:, 0], "c_ss": r[:, 1], "coh_ss": r[:, 2], "ke": r[:, 3], "bond_gaps": gaps}


def _bond_gaps(sim: object) -> np.ndarray:
    """Gaps [m] of the bonded sphere-sphere contacts whose spheres do not touch."""
    from warpdem.laws import ACTIVE, COHESIVE

    ss = sim.contacts.ss
    start, count = ss.start.numpy(), ss.count.numpy()
    k = np.concatenate([np.arange(a, a + c) for a, c in zip(start, count, strict=True)]) if count.sum() else np.zeros(0, int)
    owner = np.repeat(np.arange(len(start)), count)
    flags = ss.hist.numpy()["flags"][k]
    bonded = ((flags & int(ACTIVE)) != 0) & ((flags & int(COHESIVE)) != 0)
    i, j = owner[bonded], ss.key_a.numpy()[k][bonded]
    pos = sim.data.sphere_pos.numpy()
    rad = sim.model.host["sphere_radius"]
    gap = np.linalg.norm(pos[j] - pos[i], axis=1) - rad[i] - rad[j]
    return gap[gap > 0]


def run_all(protocol: str, spec: dict[str, np.ndarray], yade: dict[str, np.ndarray], device: str = "cpu",
            ) -> dict[str, np.ndarray]:
    """``run`` on the Yade script's realizations (the same perturbed beds: numpy's default_rng(seed) on the same
    array): c_ss, coh_ss, ke as (realization, record); bond_gaps of realization 0."""
    runs = [run(protocol, spec, yade, device, float(yade["perturb"]) if s else 0.0, s)
            for s in range(int(yade["realizations"]))]
    out = {k: np.stack([r[k] for r in runs]) for k in ("c_ss", "coh_ss", "ke")}
    out["bond_gaps"] = runs[0]["bond_gaps"]
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cpu")
    p.add_argument("--bed", default="A", help="A (default) or A_dense")
    args = p.parse_args(argv)
    spec_path, yade_path, report = paths(args.bed)
    spec, yade = load(spec_path), load(yade_path)
    nr = int(yade["realizations"])
    lines = ["# Bond protocols: warpdem against Yade 2023.02a on the same bed", "",
             f"Assembly A's ci bed{' deposited without friction' if 'dense' in args.bed else ''} "
             f"({int(yade['n_spheres'])} spheres), GA set 11, the bin's facets, no tool, no "
             f"local damping after bonding; {int(yade['run_steps'])} steps "
             f"({int(yade['run_steps']) * float(spec['dt']):.3f} s) after the bonding step; settling: "
             f"{int(yade['settle_steps'])} steps with damping {float(yade['settle_damping'])}; distance bonding: "
             f"detection factor {float(yade['detection'])}. {nr} realizations per engine (the bed as exported, and "
             f"{nr - 1} displaced by at most {float(yade['perturb']):.0e} m per sphere, the same in both engines); "
             "counts at the end: mean and standard deviation over them. Written by "
             f"`python benchmarks/yade/bond_protocols_compare.py --device {args.device} --bed {args.bed}` from "
             f"`{yade_path.name}` (`yade -n -x benchmarks/yade/bond_protocols_twin.py`).", "",
             "| protocol | engine | bonds after the bonding step | of them with a gap | largest gap [um] | "
             "bonds at the end | surviving [%] | contacts at the end | kinetic energy at the end [J] |",
             "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for proto in (str(s) for s in yade["protocols"]):
        w = run_all(proto, spec, yade, args.device)
        y = {k: yade[f"{proto}_{k}"] for k in ("c_ss", "coh_ss", "ke", "bond_gaps")}
        for name, r in (("Yade", y), ("warpdem", w)):
            g, coh, c, ke = r["bond_gaps"], r["coh_ss"], r["c_ss"], r["ke"]
            surv = 100 * coh[:, -1] / coh[:, 0]
            lines.append(f"| {proto} | {name} | {int(coh[0, 0])} | {len(g)} | {1e6 * (g.max() if len(g) else 0):.1f} "
                         f"| {coh[:, -1].mean():.0f} +- {coh[:, -1].std(ddof=1):.0f} | {surv.mean():.1f} +- "
                         f"{surv.std(ddof=1):.1f} | {c[:, -1].mean():.0f} +- {c[:, -1].std(ddof=1):.0f} | "
                         f"{ke[:, -1].mean():.3g} |")
        print(lines[-2], lines[-1], sep="\n", flush=True)
    report.write_text("\n".join(lines) + "\n")
    print("wrote", report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
