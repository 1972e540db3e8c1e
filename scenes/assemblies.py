"""Soil particle assemblies A (spheres), B (clumps), C (elongated clumps) and their deposition into a bin.

The paper takes shapes and size distributions from Tamas and Bernon (2021) without stating them; warpdem's choices,
all parameters of :class:`AssemblySpec`:

- sizes: member-sphere radii uniform in r (1 +- spread), r = ``radius`` (default spread 0.2);
- A: single spheres;
- B: compact clumps: two equal spheres with centre distance r (aspect ratio 1.5);
- C: elongated clumps: three spheres in a row with centre distance r (aspect ratio 2.0), a fraction
  ``elongated_fraction`` = 0.9 of the particles ("90 % elongated particles", the paper's conclusions), the rest
  single spheres.

Generation: particles on a jittered lattice above the bin floor with random orientations (no overlaps), deposition
under gravity with local damping until the kinetic energy per particle falls below a threshold, then the bed is cut
to its depth (particles whose centre lies above it are removed) and settles again. A packed bed is a :class:`Bed`
(member spheres with their particle index) that can be saved to and loaded from ``.npz``.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

import warpdem as wd
from warpdem.errors import InputError
from warpdem.files import write_atomic
from warpdem.mass import quats_to_matrices

from . import paper
from .demo import box_mesh

KINDS = ("A", "B", "C")


@dataclass
class AssemblySpec:
    """Particle shape and size. Lengths [m]."""

    kind: str = "C"
    radius: float = 0.015
    """mean member-sphere radius [m]."""
    spread: float = 0.2
    """relative half-width of the uniform radius distribution [-]."""
    elongated_fraction: float = 0.9
    """assembly C: fraction of particles that are elongated clumps [-]."""

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {self.kind!r}")
        if not self.radius > 0:
            raise ValueError(f"radius must be positive, got {self.radius!r}")
        if not 0 <= self.spread < 1:
            raise ValueError(f"spread must be in [0, 1), got {self.spread!r}")
        if not 0 <= self.elongated_fraction <= 1:
            raise ValueError(f"elongated_fraction must be in [0, 1], got {self.elongated_fraction!r}")

    def template(self, shape: str) -> np.ndarray:
        """Member centres of one particle of radius 1 along x, centred (k, 3)."""
        if shape == "sphere":
            return np.zeros((1, 3))
        if shape == "pair":
            return np.array([[-0.5, 0.0, 0.0], [0.5, 0.0, 0.0]])
        return np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])

    def shapes(self, n: int, rng: np.random.Generator) -> list[str]:
        """Shape of each of n particles."""
        if self.kind == "A":
            return ["sphere"] * n
        if self.kind == "B":
            return ["pair"] * n
        return ["rod" if u < self.elongated_fraction else "sphere" for u in rng.random(n)]


def particle_volume(radius: float, n_members: int) -> float:
    """Volume [m^3] of a particle of ``n_members`` equal spheres of ``radius`` in a row at centre distance radius
    (lens overlaps of neighbours subtracted; non-neighbours at distance 2r only touch)."""
    v = 4.0 / 3.0 * math.pi * radius**3
    d = radius
    lens = math.pi * (2 * radius - d) ** 2 * (d**2 + 4 * d * radius) / (12 * d)
    return n_members * v - (n_members - 1) * lens


@dataclass
class Bed:
    """A deposited soil bed: member spheres grouped into particles. Lengths [m]."""

    spec: AssemblySpec
    bin_size: tuple[float, float, float]
    """inner bin size (x width, y length, z height of the walls) [m]; the bin spans x in [-W/2, W/2], y in [0, L],
    z in [0, H]."""
    depth: float
    """bed depth [m]."""
    centres: np.ndarray
    """member sphere centres [m] (n_spheres, 3)."""
    radii: np.ndarray
    """member sphere radii [m] (n_spheres,)."""
    particle: np.ndarray
    """particle index of each member (n_spheres,), members of a particle contiguous."""
    porosity: float = math.nan
    coordination: float = math.nan
    """mean coordination number after deposition (member contacts between different particles, per particle)."""
    seed: int = 0
    wall_s: float = 0.0
    population_seed: int | None = None
    """with replica beds (:func:`deposit`'s ``population_seed``): the seed of the particles' shapes and sizes, shared
    by every replica; None for a bed whose shapes, sizes and places all come from ``seed``."""
    population_index: np.ndarray | None = None
    """with replica beds: each particle's index in the shared population (n_particles,), increasing."""

    @property
    def n_particles(self) -> int:
        return int(self.particle.max()) + 1 if len(self.particle) else 0

    def save(self, path: str | Path) -> None:
        """Write the bed to ``path`` (.npz) atomically: a temporary file of a unique name, then renamed, so that
        a killed run never leaves a truncated bed and two runs never write into one file."""
        write_atomic(path, lambda tmp: np.savez_compressed(
            tmp, centres=self.centres, radii=self.radii, particle=self.particle, bin_size=np.array(self.bin_size),
            depth=self.depth, porosity=self.porosity, coordination=self.coordination, seed=self.seed,
            wall_s=self.wall_s, spec=np.array(str(asdict(self.spec))),
            **({} if self.population_seed is None else {"population_seed": self.population_seed,
                                                         "population_index": self.population_index})))

    @staticmethod
    def load(path: str | Path) -> Bed:
        """Read a bed written by :meth:`save`; a file that is not one raises InputError naming it."""
        import ast
        import zipfile

        try:
            with np.load(path) as d:
                spec = AssemblySpec(**ast.literal_eval(str(d["spec"])))
                bed = Bed(spec, tuple(float(v) for v in d["bin_size"]), float(d["depth"]), d["centres"],
                          d["radii"], d["particle"], float(d["porosity"]), float(d["coordination"]), int(d["seed"]),
                          float(d["wall_s"]))
                if "population_seed" in d:
                    bed.population_seed = int(d["population_seed"])
                    bed.population_index = np.asarray(d["population_index"], dtype=np.int64)
        except (OSError, EOFError, KeyError, ValueError, SyntaxError, TypeError, zipfile.BadZipFile) as e:
            raise InputError(f"{str(path)!r} is not a readable bed ({type(e).__name__}: {e}); delete it to deposit "
                             "the bed again") from None
        n = len(bed.centres)
        if bed.centres.shape != (n, 3) or bed.radii.shape != (n,) or bed.particle.shape != (n,):
            raise InputError(f"{str(path)!r} is not a consistent bed (centres {bed.centres.shape}, radii "
                             f"{bed.radii.shape}, particle {bed.particle.shape}); delete it to deposit it again")
        return bed

    def add_to(self, b: wd.ModelBuilder, material: str, *, group: str = "soil",
               keep: np.ndarray | None = None) -> np.ndarray:
        """Add the particles (all, or those with ``keep[particle]``) to a builder: single spheres first, then the
        clumps. Returns the bed's member indices in the order their spheres were added (n_added_spheres,)."""
        starts = np.flatnonzero(np.r_[True, np.diff(self.particle) != 0])
        ends = np.r_[starts[1:], len(self.particle)]
        single = (ends - starts) == 1
        sel = np.ones(len(starts), bool) if keep is None else np.asarray(keep, bool)
        sph = starts[single & sel]
        if len(sph):
            b.add_spheres(self.centres[sph], self.radii[sph], material, group=group)
        s, e = starts[~single & sel], ends[~single & sel]
        members = np.repeat(s, e - s) + np.arange(int((e - s).sum())) - np.repeat(np.cumsum(e - s) - (e - s), e - s)
        if len(s):
            b.add_clumps(self.centres[members], self.radii[members], e - s, material, group=group)
        return np.concatenate([sph, members]).astype(np.int64)


def bin_mesh(size: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """An open-top box: x in [-W/2, W/2], y in [0, L], z in [0, H]; floor and four walls. Returns (v (8, 3), f)."""
    v, f = box_mesh(size)
    v[:, 0] -= size[0] / 2
    return v, f


POPULATION_STREAM, PLACES_STREAM = 1, 2
"""replica beds draw their shapes and sizes from the random streams (population seed, 1, 0 or 1) and their places
from (seed, 2, population seed): independent streams even where both seeds are equal."""


def loose_particles(spec: AssemblySpec, size: tuple[float, float, float], n_particles: int,
                    seed: int = 0, population_seed: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``n_particles`` non-overlapping particles on a jittered lattice over x in [-W/2, W/2], y in [0, L], from the
    floor up (as many layers as needed).

    ``population_seed``: the particles' shapes and sizes come from it, their lattice cells, orientations and
    jitter from ``seed`` (replica beds: the same particles, each set down elsewhere); None: all from ``seed``.

    Returns member centres [m] (n, 3), radii [m] (n,), particle index (n,).
    """
    # replica beds: the places from a stream of their own, apart from the population's (``population``)
    rng = np.random.default_rng(seed if population_seed is None else [seed, PLACES_STREAM, population_seed])
    r_max = spec.radius * (1 + spec.spread)
    extent = {"A": 1.0, "B": 1.5, "C": 2.0}[spec.kind] * r_max  # bounding radius of a particle
    pitch = 2.02 * extent
    w, length, _ = size
    nx, ny = int(w / pitch), int(length / pitch)
    nz = max(1, math.ceil(n_particles / max(nx * ny, 1)))
    if min(nx, ny) < 1:
        raise ValueError(f"the bin {size} is too small for particles of bounding radius {extent:.4g} m")
    ix, iy, iz = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    cells = (np.stack([ix, iy, iz], -1).reshape(-1, 3) + 0.5) * pitch
    cells[:, 0] += -w / 2 + (w - nx * pitch) / 2
    cells[:, 1] += (length - ny * pitch) / 2
    cells = cells[np.argsort(cells[:, 2], kind="stable")][:n_particles]
    n = len(cells)
    if population_seed is None:
        shapes = spec.shapes(n, rng)
        radii_p = rng.uniform(spec.radius * (1 - spec.spread), spec.radius * (1 + spec.spread), n)
    else:
        shapes, radii_p = population(spec, n, population_seed)
        cells = cells[rng.permutation(n)]
    rot = quats_to_matrices(rng.normal(size=(n, 4)))  # uniformly random rotations
    centres, radii, particle = [], [], []
    for k in range(n):
        t = spec.template(shapes[k]) * radii_p[k]
        room = pitch / 2 - np.linalg.norm(t, axis=1).max() - radii_p[k]
        c = cells[k] + rng.uniform(-1, 1, 3) * max(room, 0.0) * 0.9
        centres.append(c + t @ rot[k].T)
        radii.append(np.full(len(t), radii_p[k]))
        particle.append(np.full(len(t), k))
    return np.concatenate(centres), np.concatenate(radii), np.concatenate(particle)


def population(spec: AssemblySpec, n: int, seed: int) -> tuple[list[str], np.ndarray]:
    """The shapes and radii [m] (n,) of ``n`` particles drawn from ``seed`` (replica beds share them); each from a
    stream of its own, so that a longer draw begins with the same particles."""
    shapes = spec.shapes(n, np.random.default_rng([seed, POPULATION_STREAM, 0]))
    radii = np.random.default_rng([seed, POPULATION_STREAM, 1]).uniform(spec.radius * (1 - spec.spread),
                                                                       spec.radius * (1 + spec.spread), n)
    return shapes, radii


def deposit(spec: AssemblySpec, bin_size: tuple[float, float, float], depth: float, *, seed: int = 0,
            device: str | None = None, friction_angle: float = 30.0, damping: float = 0.4,
            ke_per_particle: float = 1e-6, max_time: float = 3.0, porosity_guess: float = 0.45,
            progress: object | None = None, population_seed: int | None = None) -> Bed:
    """Deposit particles under gravity into the bin and cut the bed to ``depth`` [m].

    ``population_seed``: a replica bed. Its particles' shapes and sizes come from ``population_seed`` and their
    places from ``seed``, so that replicas of one population seed differ only in where each particle lies and which
    ones the cut removed (``Bed.population_index``): such beds can be worlds of one simulation
    (``scenes.soil_bin.run_soil_bin`` with a list of beds).

    Enough particles for 1.15 x depth at porosity ``porosity_guess`` are placed on a loose lattice, deposited with
    local damping ``damping`` and contact friction ``friction_angle`` [deg] (no cohesion) until the mean kinetic
    energy per particle is below ``ke_per_particle`` [J] (or ``max_time`` [s]), then particles whose centre is above
    ``depth`` are removed and the rest settles again. Porosity is measured in the central half of the bed (x, y)
    below depth - 2 r_max, with each particle counted whole where its centre lies; the coordination number over all
    particles. ``progress(phase, simulated time [s], kinetic energy per particle [J])`` after every 0.02 s of each
    phase ("fill", "cut"); a phase that comes to rest early reports ``max_time`` last (it is done).
    """
    t0 = time.perf_counter()
    w, length, h = bin_size
    if not 0 < depth < h:
        raise ValueError(f"depth must be in (0, bin height {h}), got {depth!r}")
    f = spec.elongated_fraction
    v_mean = {"A": particle_volume(spec.radius, 1), "B": particle_volume(spec.radius, 2),
              "C": f * particle_volume(spec.radius, 3) + (1 - f) * particle_volume(spec.radius, 1)}[spec.kind]
    v_particle = v_mean * (1 + spec.spread**2)  # <(1 + u)^3> for u uniform in [-spread, spread]
    n_needed = math.ceil(1.15 * depth * w * length * (1 - porosity_guess) / v_particle)
    centres, radii, particle = loose_particles(spec, (w, length, h), n_needed, seed, population_seed)
    index = np.arange(int(particle.max()) + 1)  # each particle's index in the population
    mat = wd.Material(young=paper.SOIL_YOUNG, poisson=paper.SOIL_POISSON, density=paper.SOIL_DENSITY,
                      friction_angle=friction_angle)
    bed = Bed(spec, bin_size, depth, centres, radii, particle, seed=seed)
    for phase in ("fill", "cut"):
        b = wd.ModelBuilder(gravity=(0.0, 0.0, -9.81))
        b.add_material("soil", mat)
        b.add_material("wall", wd.Material(young=paper.TOOL_YOUNG, poisson=paper.TOOL_POISSON, density=7850.0,
                                           friction_angle=friction_angle))
        v, f = bin_mesh((w, length, max(h, centres[:, 2].max() + 2 * spec.radius)))
        b.add_mesh("bin", v, f, "wall")
        order = bed.add_to(b, "soil")
        b.set_local_damping("soil", damping)
        model, state = b.finalize(device)
        dt = 0.3 * wd.pwave_timestep(model)
        wd.check_step_count("deposition", max_time, dt, "0.3 x the P-wave step (Young's moduli, particle size)")
        sim = wd.Simulation(model, state, dt=dt)
        n_particles = bed.n_particles
        chunk = max(1, int(0.02 / dt))
        steps = 0
        while steps * dt < max_time:
            sim.advance(chunk)
            steps += chunk
            ke = float(wd.observers.kinetic_energy(sim)[0])
            if progress is not None:
                progress(phase, steps * dt, ke / n_particles)
            if steps * dt > 0.1 and ke / n_particles < ke_per_particle:
                if progress is not None:  # at rest early: the phase is done, as a bar over max_time shows it
                    progress(phase, max_time, ke / n_particles)
                break
        centres = np.empty_like(bed.centres)
        centres[order] = sim.data.sphere_pos.numpy()
        if phase == "fill":
            centre_z = np.bincount(bed.particle, weights=centres[:, 2]) / np.bincount(bed.particle)
            keep = centre_z <= depth
            keep_member = keep[bed.particle]
            new_index = np.cumsum(keep) - 1
            bed = Bed(spec, bin_size, depth, centres[keep_member], bed.radii[keep_member],
                      new_index[bed.particle[keep_member]], seed=seed)
            index = index[keep]
        else:
            bed.centres = centres
            z_ss = wd.observers.coordination_number("soil")(sim)
            bed.coordination = float(z_ss[0])
    bed.porosity = porosity(bed)
    bed.wall_s = time.perf_counter() - t0
    if population_seed is not None:
        bed.population_seed, bed.population_index = int(population_seed), index.astype(np.int64)
    return bed


def porosity(bed: Bed) -> float:
    """Porosity [-] in the central half (x, y) of the bed below depth - 2 r_max (particles counted whole where
    their centre lies, volumes with the overlaps of clump members removed)."""
    w, length, _ = bed.bin_size
    r_max = bed.spec.radius * (1 + bed.spec.spread)
    z_top = bed.depth - 2 * r_max
    lo = np.array([-w / 4, length / 4, 2 * r_max])
    hi = np.array([w / 4, 3 * length / 4, z_top])
    counts = np.bincount(bed.particle)
    centre = np.stack([np.bincount(bed.particle, weights=bed.centres[:, k]) / counts for k in range(3)], -1)
    first = np.flatnonzero(np.r_[True, np.diff(bed.particle) != 0])
    vol = np.array([particle_volume(bed.radii[s], c) for s, c in zip(first, counts, strict=True)])
    inside = np.all((centre >= lo) & (centre <= hi), axis=1)
    return float(1.0 - vol[inside].sum() / np.prod(hi - lo))
