"""VTK output (warpdem.vtk) read back with meshio, against the simulation's arrays and a closed-form pose."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DEVICE, square

import warpdem as wd

DT = 5e-5  # [s], below the spheres' critical step


def _scene(n_worlds: int = 2) -> tuple[wd.Simulation, np.ndarray, np.ndarray]:
    b = wd.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_material("m", wd.Material(young=1e7, poisson=0.3, density=2700.0, friction_angle=30.0))
    rng = np.random.default_rng(1)
    b.add_spheres(rng.uniform(-0.05, 0.05, (6, 3)) * [1, 1, 0] + [0, 0, 1.0], np.full(6, 0.004), "m")
    v, f = square((2.0, 0.0, 0.0), 0.05)
    # a kinematic plate: constant velocity and spin about z through its centre (every DoF imposed)
    b.add_mesh("plate", v, f, "m", kind="kinematic", velocity=(0.1, 0.0, 0.0), angular_velocity=(0.0, 0.0, 2.0))
    model, state = b.finalize(DEVICE, n_worlds=n_worlds)
    return wd.Simulation(model, state, dt=DT), v, f


def test_frames_hold_the_spheres_and_the_meshes_in_their_current_pose(tmp_path) -> None:
    """Reference: the simulation's sphere arrays (to the bit, float64 positions) and the plate's closed-form pose
    after t: R_z(omega t) (x0 - c) + c + v t (imposed velocities, so exact up to round-off, 1e-9 m)."""
    meshio = pytest.importorskip("meshio")
    from warpdem.vtk import VtkWriter

    sim, v0, _ = _scene()
    writer = VtkWriter(tmp_path / "vtk")
    rec = sim.run(300, record_every=100, observers={"vtk": writer.as_observer(every=2)})
    assert list(rec["vtk"].reshape(-1)) == [1, 1, 2, 2]  # frames at the records 0 and 2 (steps 0 and 200)
    s = meshio.read(tmp_path / "vtk" / "spheres_000000200.vtu")
    # the run went on to step 300: compare the step-200 frame with a second run stopped at 200
    sim2, _, _ = _scene()
    sim2.advance(200)
    np.testing.assert_array_equal(s.points, sim2.data.sphere_pos.numpy())
    np.testing.assert_array_equal(s.point_data["radius"], sim2.model.host["sphere_radius"])
    np.testing.assert_allclose(s.point_data["velocity"], sim2.data.sphere_vel.numpy(), rtol=0, atol=0)
    assert list(s.point_data["world"]) == [0] * 6 + [1] * 6
    mesh = meshio.read(tmp_path / "vtk" / "meshes_000000200.vtu")
    t = 200 * DT
    c = v0.mean(axis=0)
    a = 2.0 * t
    rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    expected = (v0 - c) @ rz.T + c + np.array([0.1 * t, 0, 0])
    pts = mesh.points.reshape(2, len(v0), 3)  # two worlds
    for w in range(2):  # compared as sets of points (the mesh keeps its own vertex order)
        d = np.linalg.norm(pts[w][:, None, :] - expected[None, :, :], axis=2)
        assert d.min(axis=1).max() < 1e-9
    assert list(np.unique(mesh.cell_data["world"][0])) == [0, 1]
    pvd = (tmp_path / "vtk" / "spheres.pvd").read_text()
    assert 'file="spheres_000000000.vtu"' in pvd and 'file="spheres_000000200.vtu"' in pvd


def test_a_writer_on_a_folder_with_frames_continues_its_index_and_one_world_can_be_chosen(tmp_path) -> None:
    """A resumed run adds its frames to the index (named by step, nothing overwritten but the same step); a bad
    world or frame interval is a named error."""
    pytest.importorskip("meshio")
    from warpdem.vtk import VtkWriter

    sim, _, _ = _scene()
    VtkWriter(tmp_path).write(sim)
    sim.advance(50)
    again = VtkWriter(tmp_path)
    again.write(sim)
    assert [s for _, s in again.frames] == [0, 50]
    one = VtkWriter(tmp_path / "w1", world=1)
    one.write(sim)
    import meshio

    s = meshio.read(tmp_path / "w1" / "spheres_000000050.vtu")
    np.testing.assert_array_equal(s.points, sim.data.sphere_pos.numpy()[6:])
    with pytest.raises(wd.InputError, match="world must be in"):
        VtkWriter(tmp_path / "w5", world=5).write(sim)
    with pytest.raises(wd.InputError, match="every must be an integer >= 1"):
        VtkWriter(tmp_path).as_observer(every=0)


def test_soil_bin_cli_writes_paraview_frames_of_each_run(tmp_path) -> None:
    """`warpdem soil-bin --vtk 20` at ci scale: frames of the rigid run every 20th record (records at 500 Hz), the
    frame count following from the run's own record count; the series are unchanged by the frames (compared with
    summary.json of the same run without --vtk, to the bit on the CPU)."""
    meshio = pytest.importorskip("meshio")
    import json
    import subprocess
    import sys

    def run(out: str, *extra: str) -> None:
        r = subprocess.run([sys.executable, "-m", "calibration.cli", "--quiet", "soil-bin", "--scale", "ci",
                            "--springs", "0", "--device", "cpu", "--out", str(tmp_path / out), *extra],
                           capture_output=True, text=True, timeout=900)
        assert r.returncode == 0, r.stderr

    run("a", "--vtk", "20")
    run("b")
    series = np.load(tmp_path / "a" / "series.npz")
    n_records = len(series["rigid_time"])
    frames = sorted((tmp_path / "a" / "vtk" / "rigid").glob("spheres_*.vtu"))
    assert len(frames) == (n_records - 1) // 20 + 1
    last = meshio.read(frames[-1])
    assert last.points.shape[1] == 3 and len(last.point_data["radius"]) == len(last.points)
    a = json.loads((tmp_path / "a" / "summary.json").read_text())
    b = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert a == b
