"""Broad phase against brute force: the candidate lists must equal the all-pairs set exactly."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DEVICE, point_triangle_distance

import warpdem as wd
from warpdem.mass import quat_to_matrix


def build(positions: np.ndarray, radii: np.ndarray, n_worlds: int = 1, mesh: tuple | None = None):
    b = wd.ModelBuilder(gravity=(0, 0, 0))
    b.add_material("m", wd.Material(young=1e7, poisson=0.3, density=2700, friction_angle=30))
    b.add_spheres(positions, radii, "m")
    if mesh is not None:
        b.add_mesh("mesh", mesh[0], mesh[1], "m")
    model, state = b.finalize(DEVICE, n_worlds=n_worlds)
    return wd.Simulation(model, state, dt=1e-7, max_speed=1e9), model


def ss_pairs(sim: wd.Simulation) -> set[tuple[int, int]]:
    ss = sim.contacts.ss.numpy()
    return {(i, int(ss["key_a"][k])) for i in range(len(ss["start"]))
            for k in range(ss["start"][i], ss["start"][i] + ss["count"][i])}


@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (-1.3, -0.7, -2.1), (2.0, 0.0, 0.0), (-0.05, 2.0, -1.0)])
def test_sphere_sphere_candidates_equal_brute_force(offset: tuple[float, float, float]) -> None:
    # Reference: all pairs (i < j, same world, different bodies) with gap |xi - xj| - ri - rj < skin. Negative,
    # large (2 m) and mixed coordinates, polydisperse radii (ratio 4), dense and overlapping; two worlds whose
    # particles coincide in space must not see each other. Exact set equality.
    rng = np.random.default_rng(7)
    n = 600
    pos = rng.uniform(-0.05, 0.05, (n, 3)) + np.asarray(offset)
    rad = rng.uniform(0.0025, 0.01, n)
    sim, model = build(pos, rad, n_worlds=2)
    x = sim.data.sphere_pos.numpy()
    r = model.host["sphere_radius"]
    world = model.host["sphere_world"]
    d = np.linalg.norm(x[:, None, :] - x[None, :, :], axis=2) - r[:, None] - r[None, :]
    i, j = np.nonzero((d < sim.skin) & (world[:, None] == world[None, :]))
    brute = {(a, b) for a, b in zip(i.tolist(), j.tolist(), strict=True) if a < b}
    assert ss_pairs(sim) == brute
    assert len(brute) > 2 * n  # dense enough to mean something


def test_sphere_triangle_candidates_equal_brute_force() -> None:
    # Reference: every (sphere, triangle) with exact distance(centre, triangle) < r + skin, computed on the host by
    # an independent routine (tests/conftest.py). Exact set equality, except pairs within 1e-9 m of the boundary.
    import trimesh

    rng = np.random.default_rng(11)
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    centre = np.array([2.0, -0.5, 0.3])
    verts = np.asarray(mesh.vertices) + centre
    faces = np.asarray(mesh.faces)
    n = 400
    pos = centre + rng.normal(0, 1, (n, 3)) * 0.05 / np.sqrt(3) * rng.uniform(0.6, 1.4, (n, 1))
    rad = rng.uniform(0.003, 0.008, n)
    sim, model = build(pos, rad, mesh=(verts, faces))
    st = sim.contacts.st.numpy()
    found = {(i, int(st["key_b"][k])) for i in range(n) for k in range(st["start"][i], st["start"][i] + st["count"][i])}
    tri = verts[faces]
    gap = point_triangle_distance(pos[:, None], tri[None, :, 0], tri[None, :, 1], tri[None, :, 2]) - rad[:, None]
    clear = np.abs(gap - sim.skin) > 1e-9
    brute = {(i, f) for i, f in zip(*np.nonzero((gap < sim.skin) & clear), strict=True)}
    assert {p for p in found if clear[p]} == brute
    assert len(brute) > n // 2


def test_rebuild_keeps_lists_exact_while_moving() -> None:
    # Reference: after many steps of random motion (spheres pass through each other, no forces: E tiny), the lists
    # from the displacement-triggered rebuilds still contain every pair in contact (gap < 0) at every check.
    rng = np.random.default_rng(5)
    n = 300
    pos = rng.uniform(-0.05, 0.05, (n, 3))
    rad = rng.uniform(0.003, 0.006, n)
    b = wd.ModelBuilder(gravity=(0, 0, 0))
    b.add_material("ghost", wd.Material(young=1e-6, poisson=0.3, density=2700, friction_angle=0))
    b.add_spheres(pos, rad, "ghost", velocities=rng.normal(0, 1.0, (n, 3)))
    model, state = b.finalize(DEVICE)
    sim = wd.Simulation(model, state, dt=2e-4)
    for _ in range(6):
        sim.advance(15)
        x = sim.data.sphere_pos.numpy()
        d = np.linalg.norm(x[:, None] - x[None], axis=2) - rad[:, None] - rad[None, :]
        i, j = np.nonzero(np.triu(d < 0, 1))
        assert {(a, b) for a, b in zip(i.tolist(), j.tolist(), strict=True)} <= ss_pairs(sim)
    assert sim.rebuild_count > 3


def test_mesh_in_body_frame_follows_rotation() -> None:
    # Reference: candidates are searched in the mesh's body frame; a rotated, translated dynamic mesh must give the
    # same candidate set as brute force in the world.
    b = wd.ModelBuilder(gravity=(0, 0, 0))
    b.add_material("m", wd.Material(young=1e7, poisson=0.3, density=2700, friction_angle=30))
    import trimesh

    box = trimesh.creation.box(extents=(0.2, 0.1, 0.05))
    b.add_mesh("box", np.asarray(box.vertices), np.asarray(box.faces), "m", kind="dynamic",
               angular_velocity=(3.0, 1.0, -2.0))
    rng = np.random.default_rng(2)
    pos = rng.uniform(-0.15, 0.15, (300, 3))
    b.add_spheres(pos, 0.01, "m", blocked="xyzXYZ")
    model, state = b.finalize(DEVICE)
    sim = wd.Simulation(model, state, dt=1e-3, force_dt=True)
    sim.advance(40)
    q, x0 = state.body_quat.numpy()[0], state.body_pos.numpy()[0]
    local = model.host["mesh_vertices_local"][0]
    verts = local @ quat_to_matrix(q).T + x0
    tri = verts[model.host["mesh_faces"][0]]
    st = sim.contacts.st.numpy()
    found = {(i, int(st["key_b"][k])) for i in range(300)
             for k in range(st["start"][i], st["start"][i] + st["count"][i])}
    x = sim.data.sphere_pos.numpy()
    # the lists are from the last rebuild; every pair in contact now must be listed
    gap = point_triangle_distance(x[:, None], tri[None, :, 0], tri[None, :, 1], tri[None, :, 2]) - 0.01
    touching = {(i, f) for i, f in zip(*np.nonzero(gap < 0), strict=True)}
    assert touching and touching <= found


def test_contact_counts_on_the_device_equal_brute_force() -> None:
    # Reference: overlapping pairs (gap < 0) counted by all pairs on the host, per world and per group; the
    # coordination number is 2 x (contacts inside the group) / (spheres of the group). Two groups share one box so
    # that the group filter matters. A mesh adds sphere-triangle contacts, which are compared with the host's
    # contact table (edge and vertex de-duplication makes a brute-force triangle count differ).
    import trimesh

    rng = np.random.default_rng(5)
    n = 300
    pos = rng.uniform(-0.04, 0.04, (n, 3))
    rad = rng.uniform(0.004, 0.008, n)
    mesh = trimesh.creation.box(extents=(0.03, 0.03, 0.03))
    b = wd.ModelBuilder(gravity=(0, 0, 0))
    b.add_material("m", wd.Material(young=1e5, poisson=0.3, density=2700, friction_angle=30))
    b.add_spheres(pos[: n // 2], rad[: n // 2], "m", group="a")
    b.add_spheres(pos[n // 2:], rad[n // 2:], "m", group="b")
    b.add_mesh("box", np.asarray(mesh.vertices), np.asarray(mesh.faces), "m")
    model, state = b.finalize(DEVICE, n_worlds=2)
    sim = wd.Simulation(model, state, dt=1e-9, max_speed=1e9, force_dt=True)
    sim.step()  # contacts become active in the first step; nothing moves measurably in 1 ns
    d = np.linalg.norm(pos[:, None] - pos[None], axis=2) - rad[:, None] - rad[None]
    assert np.abs(d[np.triu_indices(n, 1)]).min() > 1e-9  # no pair at the boundary
    touching = np.triu(d < 0, 1)
    counts = wd.observers.contact_count(sim)
    table = wd.observers.contact_table(sim)
    assert counts[:, 0].tolist() == [int(touching.sum())] * 2
    assert np.bincount(table["world"].astype(int) * 2 + table["kind"].astype(int), minlength=4).tolist() == \
        counts.reshape(-1).tolist()
    half = n // 2
    z_a = 2 * touching[:half, :half].sum() / half
    z_b = 2 * touching[half:, half:].sum() / (n - half)
    np.testing.assert_allclose(wd.observers.coordination_number("a")(sim), [z_a, z_a], rtol=1e-12)
    np.testing.assert_allclose(wd.observers.coordination_number("b")(sim), [z_b, z_b], rtol=1e-12)
    np.testing.assert_allclose(wd.observers.coordination_number()(sim), [2 * touching.sum() / n] * 2, rtol=1e-12)
    assert 1 < z_a < 12 and counts[0, 1] > 10  # a meaningful sample


def test_blocks_in_the_grids_order_partition_the_list() -> None:
    # Reference: a partition. Each sphere's block, allocated in the hash grid's cell order (as on CUDA), must hold
    # exactly its count, the blocks must not overlap and must fill [0, total) with total the sum of the counts.
    # On the CPU (threads in order) the blocks also follow the cells: of the spheres taken one after another in the
    # blocks' order, most pairs share a cell and a group (64 cells x 2 groups for 500 spheres: about 75 %; in the
    # spheres' own, random, order under 1 %).
    import warp as wp

    from warpdem.broadphase import allocate_blocks_kernel

    rng = np.random.default_rng(3)
    n, width = 500, 0.05
    x = rng.uniform(0.0, 0.2, (n, 3))
    groups = rng.integers(0, 2, n).astype(np.int32)
    grid = wp.HashGrid(8, 8, 8, device=DEVICE, dtype=wp.float64)
    grid.reserve(n, with_groups=True)
    grid.build(wp.array(x, dtype=wp.vec3d, device=DEVICE), width, groups=wp.array(groups, device=DEVICE))
    counts = rng.integers(1, 7, n).astype(np.int32)
    total = wp.zeros(1, dtype=int, device=DEVICE)
    start = wp.zeros(n, dtype=int, device=DEVICE)
    wp.launch(allocate_blocks_kernel, n, inputs=[grid.id, wp.array(counts, device=DEVICE), total], outputs=[start],
              device=DEVICE)
    s = start.numpy()
    assert total.numpy()[0] == counts.sum()
    cover = np.zeros(counts.sum(), int)
    for i in range(n):
        cover[s[i]:s[i] + counts[i]] += 1
    assert (cover == 1).all()
    if DEVICE == "cpu":
        key = [tuple(k) + (g,) for k, g in zip(np.floor(x / width).astype(int), groups, strict=True)]
        order = np.argsort(s)
        same = np.mean([key[a] == key[b] for a, b in zip(order[:-1], order[1:], strict=True)])
        assert same > 0.6


def test_the_skin_changes_the_rebuilds_not_the_physics() -> None:
    """Reference: a contact list that holds every pair closer than the skin, rebuilt before any sphere has moved
    half of it, holds every touching pair whatever the skin; pairs in the list that do not touch add nothing and the
    sums keep their order. So a passive ``ci`` soil-bin run (two tools in GA set 11's cohesive soil, 2,125 steps)
    with three times the default skin gives the same records to the bit on the CPU, with fewer rebuilds (measured:
    92 -> 30). (On CUDA the lists' blocks follow the grid and a pair's place in them may move: there the runs are
    compared by their steady means, within three combined standard errors; a paper-scale rigid run on an H200 gave
    the same draught to the bit at skins 0.2-0.8, benchmarks/README.md.)"""
    from scenes.soil_bin import SoilBinConfig, bed_for, run_soil_bin
    from warpdem.errors import InputError

    cfg = SoilBinConfig(scale="ci", assembly="A", springs=(16, 32), speed=(0.6, 0.6), travel=0.1,
                        steady_travel=0.05)
    bed = bed_for(cfg, device=DEVICE)
    runs = [run_soil_bin(cfg, [16, 32], bed=bed, device=DEVICE, speeds=[0.6, 0.6], skin_factor=f)
            for f in (None, 0.6)]
    assert runs[1].rebuilds < runs[0].rebuilds / 2, (runs[0].rebuilds, runs[1].rebuilds)
    assert runs[0].steps == runs[1].steps
    if DEVICE == "cpu":
        for k, v in runs[0].series.items():
            np.testing.assert_array_equal(v, runs[1].series[k], err_msg=k)
    for a, b in zip(runs[0].steady, runs[1].steady, strict=True):
        assert abs(a["draught_mean"] - b["draught_mean"]) <= 3 * np.hypot(a["draught_sem"], b["draught_sem"])
    with pytest.raises(InputError, match="skin_factor must be in"):
        run_soil_bin(cfg, [16, 32], bed=bed, device=DEVICE, skin_factor=0.0)
