"""The Rerun viewer: write recordings of a small two-world scene to .rrd files, read them back and check what they
hold against the simulation and against values computed independently from the scene's inputs.

Scene: 27 spheres (r = 1 cm, 5 cm apart, no gravity, no contacts) moving at prescribed constant velocities, and a
kinematic blade far from them that translates (and in world 1 also spins about z). The viewer shows world 1.
"""

from __future__ import annotations

import numpy as np
import pytest

rr = pytest.importorskip("rerun")
pa = pytest.importorskip("pyarrow")
RrdReader = pytest.importorskip("rerun.chunk").RrdReader

from conftest import DEVICE  # noqa: E402

import warpdem as wd  # noqa: E402
from warpdem import observers  # noqa: E402
from warpdem.viewer import COLORMAPS, RerunViewer, speed_colors  # noqa: E402

RADIUS = 0.01
DENSITY = 2700.0
SPEED_RANGE = (0.2, 0.7)
# Turbo's end colours as published (Google's Turbo, matplotlib "turbo"): #30123b and #7a0403; mid-point #a4fc3c
TURBO_FIRST, TURBO_LAST, TURBO_MID = (0x30, 0x12, 0x3B), (0x7A, 0x04, 0x03), (0xA4, 0xFC, 0x3C)
BLADE_VEL = np.array([[0.5, 0.0, 0.0], [0.2, 0.0, 0.1]])  # per world [m/s]
BLADE_ANGVEL = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 2.0]])  # per world [rad/s]
WORLD = 1
DT, STEPS, EVERY = 1e-4, 40, 10


def _scene_inputs() -> dict[str, np.ndarray]:
    """Sphere centres (27, 3) [m], per-world velocities (2, 27, 3) [m/s], blade vertices (4, 3) [m] and faces."""
    g = np.arange(3) * 0.05
    pos = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3) + 0.1
    speeds = np.concatenate([[0.05, 0.1, 0.15], np.linspace(0.25, 0.65, 21), [0.75, 0.85, 0.95]])
    rng = np.random.default_rng(3)
    dirs = rng.normal(size=(len(pos), 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    vel = np.repeat((speeds[:, None] * dirs)[None], 2, axis=0)
    vel[1, 0] = 0.3 * dirs[0]  # world 1 differs: its first sphere moves at 0.3 m/s (inside the range)
    blade_v = np.array([[-1.0, -0.05, 0.0], [-1.0, 0.05, 0.0], [-1.0, 0.05, 0.1], [-1.0, -0.05, 0.1]]) + [0, 0.1, 0]
    return {"pos": pos, "vel": vel, "blade_v": blade_v, "blade_f": np.array([[0, 1, 2], [0, 2, 3]])}


def _build(inputs: dict[str, np.ndarray]) -> wd.Simulation:
    b = wd.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    b.add_material("m", wd.Material(young=1e7, poisson=0.3, density=DENSITY, friction_angle=30.0))
    b.add_spheres(inputs["pos"], RADIUS, "m", velocities=inputs["vel"][0], name="first")
    b.add_mesh("blade", inputs["blade_v"], inputs["blade_f"], "m", kind="kinematic")
    model, state = b.finalize(DEVICE, n_worlds=2, overrides={
        "body:first:velocity": inputs["vel"][:, 0], "body:blade:velocity": BLADE_VEL,
        "body:blade:angular_velocity": BLADE_ANGVEL})
    return wd.Simulation(model, state, dt=DT)


def _column(col: object) -> list:
    if pa.types.is_duration(col.type):
        return col.cast(pa.int64()).to_pylist()  # nanoseconds
    return col.to_pylist()


def read_rrd(path: object) -> tuple[dict[str, dict], dict[str, dict[int, dict]]]:
    """Everything in the recording of an .rrd file, read with rerun.chunk.RrdReader (no viewer, no datafusion):
    static[entity][component] = value, and frames[entity][step][component] = value ("sim_time" in ns)."""
    static: dict[str, dict] = {}
    frames: dict[str, dict[int, dict]] = {}
    for chunk in RrdReader(path).stream():
        batch = chunk.to_record_batch()
        cols = {n: _column(c) for n, c in zip(batch.schema.names, batch.columns, strict=True)
                if n not in ("log_time", "rerun.controls.RowId")}
        for row in range(chunk.num_rows):
            values = {n: c[row] for n, c in cols.items() if c[row] is not None}
            if chunk.is_static:
                static.setdefault(chunk.entity_path, {}).update(values)
            else:
                frames.setdefault(chunk.entity_path, {}).setdefault(values["step"], {}).update(values)
    return static, frames


def _unpack_rgba(packed: list[int]) -> np.ndarray:
    p = np.asarray(packed, dtype=np.uint32)
    return np.stack([(p >> 24) & 255, (p >> 16) & 255, (p >> 8) & 255, p & 255], axis=1)


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion given as x, y, z, w."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """Run the scene once with three viewers (all spheres; only those in the speed range; at most 5 points) and
    snapshot observers that keep what the simulation held at each frame (copies: on the CPU Warp's .numpy() is a
    view that later steps overwrite)."""
    tmp = tmp_path_factory.mktemp("rrd")
    inputs = _scene_inputs()
    sim = _build(inputs)
    m = sim.model
    blade = m.body_index("blade", WORLD)
    blades = [m.body_index("blade", w) for w in range(m.n_worlds)]  # per-world observer: (n_worlds, 2) below
    s0 = WORLD * m.spheres_per_world
    paths = {k: tmp / f"{k}.rrd" for k in ("all", "hide", "sub")}
    full = RerunViewer(sim, world=WORLD, speed_range=SPEED_RANGE, save_path=paths["all"], application_id="t_all")
    hide = RerunViewer(sim, world=WORLD, speed_range=SPEED_RANGE, hide_outside_range=True, save_path=paths["hide"])
    with RerunViewer(sim, world=WORLD, speed_range=SPEED_RANGE, max_points=5, save_path=paths["sub"]) as sub:
        series = sim.run(STEPS, record_every=EVERY, observers={
            "pos": lambda s: s.data.sphere_pos.numpy()[s0:s0 + m.spheres_per_world].copy(),
            "body_pos": lambda s: s.state.body_pos.numpy()[blade].copy(),
            "body_quat": lambda s: s.state.body_quat.numpy()[blade].copy(),
            "ke": observers.kinetic_energy,
            "all": full.as_observer({"kinetic_energy": observers.kinetic_energy,
                                     "blade_xz": lambda s: s.state.body_pos.numpy()[blades][:, [0, 2]]}),
            "hide": hide.as_observer(),
            "sub": sub.as_observer(),
        })
    full.close()
    hide.close()
    hide.close()  # idempotent
    return {"inputs": inputs, "series": series, "model": m, "sim": sim, "paths": paths,
            "reads": {k: read_rrd(p) for k, p in paths.items()}}


def test_frames_and_timelines(recorded: dict) -> None:
    series = recorded["series"]
    static, frames = recorded["reads"]["all"]
    # reference: Simulation.run records at steps 0, 10, 20, 30, 40 (record_every=10 over 40 steps)
    assert sorted(frames["/world/particles"]) == list(range(0, STEPS + 1, EVERY)) == series["step"].tolist()
    for step, t in zip(series["step"], series["time"], strict=True):
        # reference: state.time at that frame, as recorded by Simulation.run; the timeline stores nanoseconds
        assert frames["/world/particles"][step]["sim_time"] == pytest.approx(t * 1e9, abs=1.0)
    # reference: the viewer logs a z-up view and a legend once, and the blueprint is a separate store
    assert "ViewCoordinates:xyz" in static["/world"]
    assert "0.2 m/s" in static["/legend"]["TextDocument:text"][0]


def test_particles_positions_radii_colours(recorded: dict) -> None:
    inputs, series = recorded["inputs"], recorded["series"]
    frames = recorded["reads"]["all"][1]["/world/particles"]
    speeds = np.linalg.norm(inputs["vel"][WORLD], axis=1)  # prescribed, constant (no contacts, no gravity)
    n = len(inputs["pos"])
    for k, step in enumerate(series["step"]):
        f = frames[step]
        pos = np.asarray(f["Points3D:positions"])
        # reference: one point per sphere of the world, at the simulation's positions of that frame (float32)
        assert pos.shape == (n, 3)
        np.testing.assert_allclose(pos, series["pos"][k], rtol=0, atol=1e-7)
        # reference: x0 + v t from the scene's inputs (constant velocities)
        np.testing.assert_allclose(pos, inputs["pos"] + inputs["vel"][WORLD] * series["time"][k], atol=1e-6)
        # reference: the radius given to the builder
        np.testing.assert_allclose(f["Points3D:radii"], RADIUS, rtol=1e-6)
        rgba = _unpack_rgba(f["Points3D:colors"])
        assert np.all(rgba[:, 3] == 255)
        # reference: Turbo's published end colours for the slowest (0.1 < lo) and fastest (0.95 > hi) spheres
        assert tuple(rgba[np.argmin(speeds), :3]) == TURBO_FIRST
        assert tuple(rgba[np.argmax(speeds), :3]) == TURBO_LAST
        # reference: the sphere at 0.45 m/s, the middle of the range, gets Turbo's mid-point colour
        assert tuple(rgba[np.argmin(np.abs(speeds - 0.45)), :3]) == TURBO_MID
        # reference: every sphere at or below lo has the first colour, at or above hi the last
        assert np.all(rgba[speeds <= SPEED_RANGE[0], :3] == TURBO_FIRST)
        assert np.all(rgba[speeds >= SPEED_RANGE[1], :3] == TURBO_LAST)


def test_hide_outside_range(recorded: dict) -> None:
    inputs, series = recorded["inputs"], recorded["series"]
    frames = recorded["reads"]["hide"][1]["/world/particles"]
    speeds = np.linalg.norm(inputs["vel"][WORLD], axis=1)
    inside = (speeds >= SPEED_RANGE[0]) & (speeds <= SPEED_RANGE[1])
    assert np.min(np.abs(speeds[:, None] - np.array(SPEED_RANGE))) > 1e-3  # no speed sits on a range boundary
    assert inside.sum() == 22  # 21 in the linspace plus world 1's first sphere at 0.3 m/s
    for k, step in enumerate(series["step"]):
        pos = np.asarray(frames[step]["Points3D:positions"])
        # reference: the spheres whose prescribed speed lies in [0.2, 0.7] m/s, in index order
        assert pos.shape == (inside.sum(), 3)
        np.testing.assert_allclose(pos, series["pos"][k][inside], atol=1e-7)
        # reference: the run's returned statistics (min, mean, max speed, points shown) against the inputs
        np.testing.assert_allclose(series["hide"][k][:3], [speeds.min(), speeds.mean(), speeds.max()], rtol=1e-6)
        assert series["hide"][k][3] == inside.sum()


def test_max_points(recorded: dict) -> None:
    series = recorded["series"]
    frames = recorded["reads"]["sub"][1]["/world/particles"]
    chosen = None
    for k, step in enumerate(series["step"]):
        pos = np.asarray(frames[step]["Points3D:positions"])
        # reference: max_points=5 shows 5 spheres, each one of the simulation's, the same ones every frame
        assert pos.shape == (5, 3)
        d = np.linalg.norm(pos[:, None, :] - series["pos"][k][None, :, :], axis=2)
        idx = np.argmin(d, axis=1)
        assert np.all(d[np.arange(5), idx] < 1e-6)
        assert chosen is None or np.array_equal(idx, chosen)
        chosen = idx


def test_mesh_geometry_and_pose(recorded: dict) -> None:
    inputs, series, model = recorded["inputs"], recorded["series"], recorded["model"]
    static, frames = recorded["reads"]["all"]
    mesh = static["/world/meshes/blade"]
    local = np.asarray(mesh["Mesh3D:vertex_positions"])
    # reference: the builder's body-frame vertices and faces
    np.testing.assert_allclose(local, model.host["mesh_vertices_local"][0], atol=1e-7)
    assert np.asarray(mesh["Mesh3D:triangle_indices"]).tolist() == inputs["blade_f"].tolist()
    centre0 = inputs["blade_v"].mean(axis=0)  # a kinematic mesh's body sits at its vertex mean
    for k, step in enumerate(series["step"]):
        f = frames["/world/meshes/blade"][step]
        t = np.asarray(f["Transform3D:translation"]).reshape(3)
        q = np.asarray(f["Transform3D:quaternion"]).reshape(4)
        # reference: the simulation's body_pos and body_quat (x, y, z, w) of world 1's blade at that frame
        np.testing.assert_allclose(t, series["body_pos"][k], atol=1e-6)
        np.testing.assert_allclose(q, series["body_quat"][k], atol=1e-6)
        # reference: rigid motion from the inputs: centre + v t, and a rotation by w t about z (world 1 spins)
        time = series["time"][k]
        np.testing.assert_allclose(t, centre0 + BLADE_VEL[WORLD] * time, atol=1e-6)
        a = BLADE_ANGVEL[WORLD, 2] * time
        rz = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
        world_vertices = local @ _quat_matrix(q).T + t  # what a viewer draws, with the xyzw convention
        np.testing.assert_allclose(world_vertices, (inputs["blade_v"] - centre0) @ rz.T + t, atol=1e-6)
    assert series["time"][-1] * BLADE_ANGVEL[WORLD, 2] > 0.005  # the blade did turn measurably


def test_scalar_series(recorded: dict) -> None:
    inputs, series = recorded["inputs"], recorded["series"]
    frames = recorded["reads"]["all"][1]
    ke_ref = 0.5 * DENSITY * 4.0 / 3.0 * np.pi * RADIUS**3 * np.sum(inputs["vel"][WORLD] ** 2)  # m v^2 / 2
    for k, step in enumerate(series["step"]):
        ke = frames["/plots/kinetic_energy"][step]["Scalars:scalars"]
        # reference: the run's kinetic_energy observer for world 1, and m v^2 / 2 from the inputs
        assert ke == [pytest.approx(series["ke"][k][WORLD], rel=1e-12)]
        assert ke[0] == pytest.approx(ke_ref, rel=1e-9)
        # reference: world 1's blade x and z, recorded by the run (a per-world (2, 2) observer value: the viewer takes
        # its world's row, two series under one name)
        np.testing.assert_allclose(frames["/plots/blade_xz"][step]["Scalars:scalars"], series["body_pos"][k][[0, 2]],
                                   rtol=1e-12)


def test_log_frame_direct_and_speed_colors(tmp_path: object) -> None:
    inputs = _scene_inputs()
    sim = _build(inputs)
    path = tmp_path / "direct.rrd"
    sim2 = _build(inputs)  # a second simulation (another Model object), two steps on
    sim2.advance(2)
    with RerunViewer(sim, world=0, speed_range=(0.0, 2.0), colormap="gray", save_path=path) as v:
        stats = v.log_frame(sim, {"draught_n": 12.5, "force": [1.0, -2.0, 3.0]})
        v.as_observer({"per_world": lambda s: [4.0, 5.0]}, select_worlds=False)(sim2)
        pos2 = sim2.data.sphere_pos.numpy()[: len(inputs["pos"])].copy()
    _, frames = read_rrd(path)
    # reference: the values passed to log_frame, at step 0
    assert frames["/plots/draught_n"][0]["Scalars:scalars"] == [12.5]
    assert frames["/plots/force"][0]["Scalars:scalars"] == [1.0, -2.0, 3.0]
    # reference: with select_worlds=False a (n_worlds,) value is logged whole; the frame of the other simulation
    # (its model's scene is set up on the fly) is at its step, 2, with its positions
    assert frames["/plots/per_world"][2]["Scalars:scalars"] == [4.0, 5.0]
    np.testing.assert_allclose(frames["/world/particles"][2]["Points3D:positions"], pos2, atol=1e-7)
    speeds = np.linalg.norm(inputs["vel"][0], axis=1)
    # reference: gray maps t = |v| / 2 linearly onto 0..255
    rgb = _unpack_rgba(frames["/world/particles"][0]["Points3D:colors"])[:, :3]
    np.testing.assert_allclose(rgb, np.repeat(np.round(speeds / 2.0 * 255)[:, None], 3, axis=1), atol=1)
    assert stats[3] == len(speeds)
    # reference: the table's ends at and beyond the range limits, and the midpoint of a two-stop table
    cols = speed_colors([-1.0, 0.2, 0.7, 5.0], SPEED_RANGE, "turbo")
    assert tuple(cols[0]) == tuple(cols[1]) == TURBO_FIRST and tuple(cols[2]) == tuple(cols[3]) == TURBO_LAST
    assert speed_colors([0.5], (0.0, 1.0), [[0, 0, 0], [200, 100, 50]]).tolist() == [[100, 50, 25]]
    assert len(COLORMAPS["turbo"]) == 17


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"speed_range": (0.7, 0.2)}, "speed_range"),
        ({"speed_range": (0.5, 0.5)}, "speed_range"),
        ({"speed_range": (-1.0, 0.5)}, "speed_range"),
        ({"speed_range": "fast"}, "speed_range"),
        ({"world": 2}, "world must be in \\[0, 2\\).*got 2"),
        ({"world": -1}, "world"),
        ({"colormap": "jet"}, "colormap.*'jet'"),
        ({"colormap": [[0, 0, 0]]}, "colormap"),
        ({"max_points": 0}, "max_points.*0"),
        ({"save_path": None}, "spawn=False and save_path=None"),
        ({"save_path": "/nonexistent_dir_xyz/a.rrd"}, "save_path"),
    ],
)
def test_invalid_arguments(tmp_path: object, recorded: dict, kwargs: dict, match: str) -> None:
    sim = recorded["sim"]
    args = {"save_path": tmp_path / "x.rrd", **kwargs}
    with pytest.raises(ValueError, match=match):
        RerunViewer(sim, **args)
