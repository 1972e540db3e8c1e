"""Replica beds as worlds of one simulation (scenes.replica_beds, warpdem.builder.fit_poses / hold_bodies).

References: a rigid motion applied to clumps (closed form) for the pose fit; each replica bed run alone, with the
same tool pose, for the worlds of a shared-layout simulation (an independent build of the same physics: its own
layout, no parked particles)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import DEVICE

import warpdem as wd
from scenes import replica_beds
from scenes import soil_bin as sb
from warpdem.builder import fit_poses, hold_bodies, set_poses
from warpdem.errors import InputError
from warpdem.mass import quats_to_matrices

CFG = sb.SoilBinConfig(scale="ci", springs=(0,), travel=0.05, steady_travel=0.02)


def test_fit_poses_recovers_a_rigid_motion_of_clumps() -> None:
    # Reference: world 1 holds world 0's clumps (rods of three, a bent triple, a pair, a single sphere) moved by one
    # known rotation and translation. The fitted poses must put every sphere there within the float32 rounding of
    # the member offsets (the engine's own, ~1e-7 of a 1 cm offset) as world 0's built poses do.
    rng = np.random.default_rng(3)
    b = wd.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_material("m", wd.Material(young=1e7, poisson=0.3, density=2000.0, friction_angle=30.0))
    rod = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]) * 0.01
    parts, sizes = [], []
    for _ in range(6):
        rot = quats_to_matrices(rng.normal(size=(1, 4)))[0]
        parts.append(rng.uniform(0.0, 1.0, 3) + rod @ rot.T)
        sizes.append(3)
    parts += [np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.004, 0.008, 0.002]]) + 2.0,
              np.array([[0.0, 0.0, 0.0], [0.006, 0.0, 0.0]]) + 3.0, np.array([[0.5, 0.5, 0.5]])]
    sizes += [3, 2, 1]
    centres = np.concatenate(parts)
    b.add_clumps(centres, np.full(len(centres), 0.006), sizes, "m")
    model, state = b.finalize(DEVICE, n_worlds=2)
    rot = quats_to_matrices(rng.normal(size=(1, 4)))[0]
    moved = centres @ rot.T + np.array([0.3, -0.2, 0.1])
    ns = model.spheres_per_world
    bodies, pos, quat = fit_poses(model, np.arange(ns, 2 * ns), moved)
    assert np.array_equal(bodies, np.arange(model.bodies_per_world, 2 * model.bodies_per_world))
    set_poses(state, bodies, pos, quat)
    sim = wd.Simulation(model, state, dt=1e-6)
    at = sim.data.sphere_pos.numpy()
    built = np.abs(at[:ns] - centres).max()  # world 0 as the builder placed it
    assert built < 1e-9
    assert np.abs(at[ns:] - moved).max() < 2 * built + 1e-12
    with pytest.raises(InputError, match="every sphere of their bodies"):
        fit_poses(model, np.arange(ns + 1, 2 * ns), moved[1:])  # a rod without its first member


def test_hold_bodies_refuses_an_unknown_group() -> None:
    b = wd.ModelBuilder()
    b.add_material("m", wd.Material(young=1e7, poisson=0.3, density=2000.0, friction_angle=30.0))
    b.add_sphere((0.0, 0.0, 0.0), 0.01, "m")
    model, state = b.finalize(DEVICE)
    with pytest.raises(InputError, match="group must be one of"):
        hold_bodies(model, state, [0], "parked")


@pytest.fixture(scope="module")
def beds() -> list:
    return [sb.bed_for(CFG, device=DEVICE, replica=r) for r in range(2)]


def test_replica_beds_share_a_population_and_differ_in_places(beds: list) -> None:
    # Reference: the population drawn alone (assemblies.population) gives each particle's shape and size; two
    # replicas hold those particles (each the ones its cut kept) with the same radii and member counts, set down
    # in different places.
    from scenes.assemblies import population

    a, b = beds
    n_pop = int(max(a.population_index.max(), b.population_index.max())) + 1
    shapes, radii = population(a.spec, n_pop + 200, a.population_seed)  # a longer draw starts the same
    for bed in beds:
        starts = np.flatnonzero(np.r_[True, np.diff(bed.particle) != 0])
        counts = np.diff(np.r_[starts, len(bed.particle)])
        assert np.all(np.diff(bed.population_index) > 0)
        want = np.array([{"sphere": 1, "pair": 2, "rod": 3}[shapes[u]] for u in bed.population_index])
        np.testing.assert_array_equal(counts, want)
        np.testing.assert_array_equal(bed.radii[starts], radii[bed.population_index])
    shared = np.intersect1d(a.population_index, b.population_index)
    assert len(shared) > 0.5 * len(a.population_index)
    ca = {int(u): a.centres[a.particle == p].mean(axis=0) for p, u in enumerate(a.population_index)}
    cb = {int(u): b.centres[b.particle == p].mean(axis=0) for p, u in enumerate(b.population_index)}
    moved = np.array([np.linalg.norm(ca[int(u)] - cb[int(u)]) for u in shared])
    assert np.median(moved) > 10 * a.spec.radius  # each particle elsewhere, not jittered in place


@pytest.mark.parametrize("order", [(0, 1), (1, 0)])
def test_replica_world_zero_runs_as_its_bed_alone(beds: list, order: tuple[int, int]) -> None:
    # Reference: the bed of world 0 run alone, with the same tool pose (the beds' mean surface). World 0 is built
    # from its bed's centres as the lone run is, and its contacts, summed in fixed point, do not depend on the
    # parked particles or on the other world: the same draught and coordination to the bit (the kinetic energy to
    # float64 rounding). Both orders, so that each bed is checked (a later world's poses are fitted: next test).
    # The time step is the shared layout's (its smallest particle may be one that only the other bed holds): the
    # lone run takes the same one.
    pair = [beds[k] for k in order]
    tool = sb.place_tool(pair, CFG.working_depth)
    model, _, _ = sb.build_scene(CFG, pair, tool, [0, 0], [0.68, 0.68], DEVICE)
    cfg = replace(CFG, dt=sb.default_dt(model, CFG.spring_model, rigid=True))
    run = sb.run_soil_bin(cfg, [0, 0], bed=pair, device=DEVICE, speeds=[0.68, 0.68], tool=tool, place=False)
    alone = sb.run_soil_bin(cfg, [0], bed=pair[0], device=DEVICE, speeds=[0.68], tool=tool, place=False)
    assert run.n_particles[0] == alone.n_particles
    # the tool touched the bed and the soil moved (at this travel the tool meets a bed's surface in a few
    # records only: 1 to 4 of 39 on CUDA's beds), so the bits compared below are not those of an idle world
    assert np.count_nonzero(alone.series["draught"][:, 0]) >= 1 and alone.series["ke_soil"][:, 0].max() > 0.0
    for key in ("draught", "coordination"):
        np.testing.assert_array_equal(run.series[key][:, 0], alone.series[key][:, 0])
    # the kinetic energy is summed over other bodies in another order: float64 rounding
    np.testing.assert_allclose(run.series["ke_soil"][:, 0], alone.series["ke_soil"][:, 0], rtol=1e-12, atol=0.0)
    assert [r["replica_seed"] for r in run.steady] == list(order)
    offsets = [r["surface_offset"] for r in run.steady]
    assert abs(sum(offsets)) < 1e-12 and max(map(abs, offsets)) < CFG.preset["radius"]


def test_replica_worlds_start_where_their_beds_lie(beds: list) -> None:
    # Reference: each bed's member centres, less the tool's starting trench (clear_start). Every sphere a world
    # simulates (not parked) lies on a member centre of its own bed within the float32 rounding of the member
    # offsets (1e-9 m), and there is one such sphere per kept member. A later world's poses are fitted to its bed
    # (fit_poses); a cut of a collapsing bed is chaotic, so its draught is not compared to the bit.
    from scipy.spatial import cKDTree

    tool = sb.place_tool(beds, CFG.working_depth)
    model, state, _ = sb.build_scene(CFG, beds, tool, [0, 0], [0.68, 0.68], DEVICE)
    sim = wd.Simulation(model, state, dt=0.3 * wd.pwave_timestep(model), always_use_moment_law=True)
    pos = sim.data.sphere_pos.numpy()
    soil = model.host["body_group"][model.host["sphere_body"]] == model.group_index("soil")
    for w, bed in enumerate(beds):
        keep = sb.clear_start(bed, tool)[bed.particle]
        mine = soil & (model.host["sphere_world"] == w)
        dist, _ = cKDTree(bed.centres[keep]).query(pos[mine])
        assert mine.sum() == keep.sum()
        assert dist.max() < 1e-9


def test_parked_particles_hold_still_and_touch_nothing(beds: list) -> None:
    # Reference: the layout's parked flags. After a run, every parked sphere is where it started (bit for bit) and
    # has no sphere-sphere or sphere-triangle contact.
    tool = sb.place_tool(beds, CFG.working_depth)
    keeps = [sb.clear_start(b, tool) for b in beds]
    model, state, info = sb.build_scene(CFG, beds, tool, [0, 0], [0.68, 0.68], DEVICE)
    sim = wd.Simulation(model, state, dt=0.3 * wd.pwave_timestep(model), always_use_moment_law=True)
    parked_group = model.group_index(replica_beds.PARKED_GROUP)
    parked_body = model.host["body_group"] == parked_group
    parked_sphere = parked_body[model.host["sphere_body"]]
    assert parked_sphere.sum() > 0
    assert list(info["n_particles"]) == [int(k.sum()) for k in keeps]
    before = sim.data.sphere_pos.numpy()[parked_sphere]
    sim.advance(200)
    np.testing.assert_array_equal(sim.data.sphere_pos.numpy()[parked_sphere], before)
    rows = wd.observers.contact_table(sim)
    assert rows["body1"].size > 0
    for key in ("body1", "body2"):
        assert not parked_body[np.asarray(rows[key])].any()


def test_replica_beds_are_checked(beds: list) -> None:
    plain = sb.bed_for(CFG, device=DEVICE)
    with pytest.raises(InputError, match="not a replica bed"):
        sb.run_soil_bin(CFG, [0, 0], bed=[beds[0], plain], device=DEVICE, speeds=[0.68, 0.68])
    with pytest.raises(InputError, match="one per world"):
        sb.run_soil_bin(CFG, [0, 0], bed=beds[:1], device=DEVICE, speeds=[0.68, 0.68])
    with pytest.raises(InputError, match="replica must be"):
        sb.bed_for(CFG, device=DEVICE, replica=-1)


def test_study_on_replica_beds_pairs_each_replica_and_averages_them(beds: list, tmp_path: object) -> None:
    # References: (1) world 0 of the study's rigid run is replica bed 0 run alone with the same tool pose and time
    # step (an independent build of the same physics, as above): the same draught to the bit; (2) the table is the
    # replicas' statistics written out here in numpy: each passive world's reduction against the rigid world of
    # its own replica at its speed, 100 (rigid - passive) / rigid, then mean and std (ddof 1) / sqrt(n) over the
    # replicas. (2) checks the bookkeeping of replica_table, not physics.
    cfg = replace(CFG, springs=(0, 16))
    for r, bed in enumerate(beds):  # the fixture's beds, where run_study looks for them
        bed.save(sb.bed_path(cfg, tmp_path, r))
    study = sb.run_study(cfg, device=DEVICE, cache_dir=tmp_path, replicas=2)
    rigid, passive = study["runs"]["rigid"], study["runs"]["passive"]
    assert passive.springs == (16, 16) and [r["replica_seed"] for r in passive.steady] == [0, 1]
    v = passive.speeds[0]
    assert rigid.speeds == (v, v) and [r["replica_seed"] for r in rigid.steady] == [0, 1]
    tool = sb.place_tool(beds, cfg.working_depth)
    alone = sb.run_soil_bin(replace(cfg, dt=rigid.dt), [0], bed=beds[0], device=DEVICE, speeds=[v], tool=tool,
                            place=False)
    assert np.count_nonzero(alone.series["draught"][:, 0]) >= 1
    np.testing.assert_array_equal(rigid.series["draught"][:, 0], alone.series["draught"][:, 0])

    table = {r["springs"]: r for r in study["table"]}
    assert sorted(table) == [0, 16] and table[16]["replicas"] == 2
    p = np.array([r["draught_mean"] for r in passive.steady])
    q = np.array([r["draught_mean"] for r in rigid.steady])
    red = 100.0 * (q - p) / q
    for row, x in ((table[0], q), (table[16], p)):
        np.testing.assert_allclose(row["draught_mean"], x.mean(), rtol=1e-12)
        np.testing.assert_allclose(row["draught_sem"], x.std(ddof=1) / np.sqrt(2), rtol=1e-12)
    np.testing.assert_allclose(table[16]["reduction_pct"], red.mean(), rtol=1e-12)
    np.testing.assert_allclose(table[16]["reduction_sem"], red.std(ddof=1) / np.sqrt(2), rtol=1e-12)
    np.testing.assert_allclose([x["reduction_pct"] for x in table[16]["per_replica"]], red, rtol=1e-12)
    assert table[0]["reduction_pct"] is None
    # the report's table carries the replicas' means and standard errors, and says what they are
    from scenes.reproduce import write_soil_bin_report

    text = write_soil_bin_report(tmp_path, {"scale": "ci", "assembly": "C"}, study, DEVICE).read_text()
    assert "2 replica beds" in text and "comes from their scatter" in text
    row16 = next(line for line in text.splitlines() if line.startswith("| 16 |"))
    r = table[16]
    assert f"{r['draught_mean']:.4g} ± {r['draught_sem']:.2g}" in row16
    assert f"{r['reduction_pct']:.2g} ± {r['reduction_sem']:.2g}" in row16

    with pytest.raises(InputError, match="replicas must be an integer >= 1, got 0"):
        sb.run_study(cfg, device=DEVICE, cache_dir=tmp_path, replicas=0)
    with pytest.raises(InputError, match="pass no bed"):
        sb.run_study(cfg, device=DEVICE, bed=beds[0], replicas=2)


def test_perturbed_copies_are_realizations_of_one_bed() -> None:
    # References: (1) the Yade twins' perturbation (soil_bin_twin.py --perturb 1e-9 --seed k): each particle moved
    # by np.random.RandomState(k).uniform(-1e-9, 1e-9, (n_particles, 3)), its members together; seed 0 is the bed
    # itself; (2) the bed run alone, as the shared layout's world 0 must run (same draught to the bit); (3) chaos:
    # world 1, 1e-9 m away, draws another draught by the end of the run.
    plain = sb.bed_for(CFG, device=DEVICE)
    copies = replica_beds.perturbed(plain, [0, 3], 1e-9)
    np.testing.assert_array_equal(copies[0].centres, plain.centres)
    shift = np.random.RandomState(3).uniform(-1e-9, 1e-9, (plain.n_particles, 3))
    np.testing.assert_allclose(copies[1].centres - plain.centres, shift[plain.particle], rtol=0, atol=1e-15)
    for bad, words in (({"amplitude": 0.0}, "amplitude must be positive"), ({"seeds": [1, 1]}, "distinct")):
        with pytest.raises(InputError, match=words):
            replica_beds.perturbed(plain, **{"seeds": [0, 1], **bad})
    tool = sb.place_tool(plain, CFG.working_depth)
    run = sb.run_soil_bin(CFG, [0, 0], bed=copies, device=DEVICE, speeds=[0.68, 0.68], tool=tool, place=False)
    alone = sb.run_soil_bin(CFG, [0], bed=plain, device=DEVICE, speeds=[0.68], tool=tool, place=False)
    assert np.count_nonzero(alone.series["draught"][:, 0]) >= 1
    np.testing.assert_array_equal(run.series["draught"][:, 0], alone.series["draught"][:, 0])
    assert not np.array_equal(run.series["draught"][:, 1], run.series["draught"][:, 0])
