"""Replica beds as worlds of one simulation.

A model's worlds share one layout (the same bodies, spheres, radii and member offsets), so beds can be worlds of
one simulation only if they hold the same particles. Replica beds (``assemblies.deposit(population_seed=...)``)
do: every replica draws the same population of shapes and sizes and sets each particle down elsewhere; they differ
in where each particle lies and in which particles the cut to depth (and the tool's starting trench) removed.

The shared layout is the union of the particles that some world keeps, in population order. A world's own
particles lie where its bed has them; the others are parked in a garage below the bin (a lattice of slots, each
wider than a particle and the candidate skin, so that they touch nothing) and held still (every degree of freedom
blocked, in the body group ``PARKED_GROUP``, which the soil's observers leave out). Their cost is that of idle
bodies: integration and the broad phase, no contacts.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

import warpdem as wd
from warpdem.builder import fit_poses, hold_bodies, set_poses
from warpdem.errors import InputError

from .assemblies import Bed

PARKED_GROUP = "parked"
"""the body group of the particles a world's bed lacks (held still in the garage)."""
GARAGE_GAP = 0.05
"""[m] between the bin's floor (z = 0) and the top of the garage's slots."""
SLOT_CLEARANCE = 0.01
"""[m] between two parked particles' bounding spheres (more than any run's candidate skin)."""


@dataclass
class ReplicaLayout:
    """The shared layout of replica beds, one per world.

    Attributes:
        bed: world 0's soil as a bed in the shared layout (its own particles where its bed has them, the rest
            parked), to add to the builder.
        centres: each world's member centres [m] in the layout's member order, (n_worlds, n_members, 3).
        parked: particles each world parks, (n_worlds, n_particles) bool.
        n_particles: particles each world simulates (its bed's, less the trench), (n_worlds,).
        garage_bottom: [m] the lowest z of a parked sphere.
    """

    bed: Bed
    centres: np.ndarray
    parked: np.ndarray
    n_particles: np.ndarray
    garage_bottom: float


def perturbed(bed: Bed, seeds: list[int], amplitude: float = 1e-9) -> list[Bed]:
    """Realizations of one bed that can be worlds of one simulation: each particle of copy k moved by a uniform random
    displacement in [-amplitude, amplitude) [m] per axis (``np.random.RandomState(seeds[k])``; seed 0: no move, the
    bed itself). A soil bin's dynamics are chaotic, so runs on such copies scatter as independent runs of one bed
    do, with no bed-to-bed scatter (the Yade twins' ``--perturb 1e-9 --seed k`` draws the same displacements).
    ``amplitude`` [m] must be below the bed's smallest radius / 100. Returns len(seeds) beds (shared population:
    the bed's own particles, in order)."""
    if not (0.0 < amplitude < 0.01 * float(np.min(bed.radii))):
        raise InputError(f"amplitude must be positive and below 1 % of the smallest radius "
                         f"({0.01 * float(np.min(bed.radii)):.3g} m), got {amplitude!r}")
    if len(set(seeds)) != len(seeds) or any(int(s) < 0 for s in seeds):
        raise InputError(f"seeds must be distinct non-negative integers, got {list(seeds)}")
    n = bed.n_particles
    out = []
    for seed in seeds:
        shift = np.zeros((n, 3)) if seed == 0 else np.random.RandomState(int(seed)).uniform(-amplitude, amplitude,
                                                                                             (n, 3))
        out.append(replace(bed, centres=bed.centres + shift[bed.particle], population_seed=bed.seed,
                           population_index=np.arange(n)))
    return out


def check_replicas(beds: list[Bed]) -> None:
    """Refuse beds that cannot share one layout, naming the difference."""
    first = beds[0]
    for k, b in enumerate(beds):
        if b.population_seed is None or b.population_index is None:
            raise InputError(f"beds[{k}] is not a replica bed (deposited without a population_seed): only replica "
                             "beds of one population can be worlds of one simulation")
        for name in ("population_seed", "spec", "bin_size", "depth"):
            if getattr(b, name) != getattr(first, name):
                raise InputError(f"beds must share their {name}: beds[0] has {getattr(first, name)!r}, beds[{k}] "
                                 f"{getattr(b, name)!r}")


def _slices(bed: Bed) -> tuple[np.ndarray, np.ndarray]:
    """First member and member count of each particle of a bed (n_particles,)."""
    starts = np.flatnonzero(np.r_[True, np.diff(bed.particle) != 0])
    return starts, np.diff(np.r_[starts, len(bed.particle)])


def shared_layout(beds: list[Bed], keeps: list[np.ndarray], garage: tuple[float, float, float, float]
                  ) -> ReplicaLayout:
    """The shared layout of replica ``beds`` (one per world), each keeping the particles ``keeps[w]``
    ((n_particles of bed w,) bool; e.g. those outside the tool's starting trench).

    ``garage``: (x_min, x_max, y_min, y_max) [m] of the region below the bin where parked particles go; the slots
    fill it layer after layer downwards from z = -GARAGE_GAP."""
    check_replicas(beds)
    active = [b.population_index[np.asarray(k, bool)] for b, k in zip(beds, keeps, strict=True)]
    union = np.unique(np.concatenate(active))
    n_w, n_u = len(beds), len(union)
    # each particle's members as its first holder has them (its shape and radius are the population's)
    donor_members: list[np.ndarray | None] = [None] * n_u
    donor_radius = np.zeros(n_u)
    centres_of: list[dict[int, np.ndarray]] = []
    for b, act in zip(beds, active, strict=True):
        starts, counts = _slices(b)
        where = {int(u): p for p, u in enumerate(b.population_index)}
        own = {}
        for u in act:
            p = where[int(u)]
            own[int(u)] = b.centres[starts[p]:starts[p] + counts[p]]
            j = int(np.searchsorted(union, u))
            if donor_members[j] is None:
                donor_members[j] = own[int(u)]
                donor_radius[j] = b.radii[starts[p]]
        centres_of.append(own)
    counts = np.array([len(m) for m in donor_members])
    template = [m - m.mean(axis=0) for m in donor_members]
    reach = max(float(np.linalg.norm(t, axis=1).max()) for t in template) + float(donor_radius.max())
    pitch = 2.0 * reach + SLOT_CLEARANCE
    parked = np.stack([~np.isin(union, act) for act in active])
    slot_of = np.full(n_u, -1)
    somewhere = np.flatnonzero(parked.any(axis=0))  # a slot for each particle parked in some world
    slot_of[somewhere] = np.arange(len(somewhere))
    x0, x1, y0, y1 = garage
    nx, ny = int((x1 - x0) / pitch), int((y1 - y0) / pitch)
    if min(nx, ny) < 1:
        raise InputError(f"the garage {garage} is too small for a parked particle of reach {reach:.4g} m")
    s = np.arange(len(somewhere))
    layer, rest = np.divmod(s, nx * ny)
    iy, ix = np.divmod(rest, nx)
    slots = np.stack([x0 + (ix + 0.5) * pitch, y0 + (iy + 0.5) * pitch, -GARAGE_GAP - (layer + 0.5) * pitch], 1)
    garage_bottom = float(slots[:, 2].min() - reach) if len(slots) else -GARAGE_GAP
    centres = np.zeros((n_w, int(counts.sum()), 3))
    first = np.r_[0, np.cumsum(counts)[:-1]]
    for w in range(n_w):
        for j, u in enumerate(union):
            c = centres_of[w].get(int(u))
            if c is None:
                c = slots[slot_of[j]] + template[j]
            centres[w, first[j]:first[j] + counts[j]] = c
    b0 = beds[0]
    bed = Bed(b0.spec, b0.bin_size, b0.depth, centres[0], np.repeat(donor_radius, counts),
              np.repeat(np.arange(n_u), counts), seed=b0.seed, population_seed=b0.population_seed,
              population_index=union)
    return ReplicaLayout(bed, centres, parked, (~parked).sum(axis=1), garage_bottom)


def place_worlds(model: wd.Model, state: wd.State, layout: ReplicaLayout, members: np.ndarray,
                 first_sphere: int) -> None:
    """Put each world's particles where its bed has them and park the rest: ``members`` is what
    ``layout.bed.add_to`` returned (the layout's member of each soil sphere, in the order added) and
    ``first_sphere`` the soil's first sphere within a world. Before a Simulation is made of the state."""
    n_w = len(layout.centres)
    spw = model.spheres_per_world
    local = first_sphere + np.arange(len(members))
    particle_of = layout.bed.particle[members]
    # world 0 was built from layout.bed as it is, and so is a world on the same bed
    moved = [w for w in range(1, n_w) if not np.array_equal(layout.centres[w], layout.centres[0])]
    if moved:
        bodies, pos, quat = fit_poses(model, np.concatenate([w * spw + local for w in moved]),
                                      np.concatenate([layout.centres[w, members] for w in moved]))
        set_poses(state, bodies, pos, quat)
    parked = np.concatenate([w * spw + local[layout.parked[w][particle_of]] for w in range(n_w)])
    if len(parked):
        hold_bodies(model, state, np.unique(model.host["sphere_body"][parked]), PARKED_GROUP)
