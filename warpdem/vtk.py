"""VTK output for ParaView (through meshio): the spheres and the triangle meshes of a simulation, frame by frame.

    writer = VtkWriter("out/vtk")                 # all worlds; VtkWriter(folder, world=0) for one
    sim.run(n, record_every=100, observers={"vtk": writer.as_observer(every=5)})
    # ParaView: open out/vtk/spheres.pvd (Glyph filter, scale by "radius") and out/vtk/meshes.pvd

Per frame, ``spheres_<step>.vtu`` holds one vertex cell per sphere at its centre [m] with the point data radius [m],
velocity [m/s], angular_velocity [rad/s], speed [m/s], body and world; ``meshes_<step>.vtu`` every mesh instance's
triangles in their current pose [m] with the cell data mesh (instance index within its world) and world. The two
``.pvd`` files index the frames by simulated time [s]. Files are named by step, every file is written atomically,
and a writer opened on a folder that holds frames continues its index (a resumed run adds its frames).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import numpy as np

from .errors import InputError
from .files import write_atomic
from .mass import quats_to_matrices


class VtkWriter:
    """Writes VTK frames of a simulation into ``folder`` (created if missing).

    Args:
        folder: output folder.
        world: the world to write (None: every world, each sphere and triangle tagged with its world).
    """

    PARTS = ("spheres", "meshes")

    def __init__(self, folder: str | Path, world: int | None = None) -> None:
        import meshio  # noqa: F401  (fail here, not at the first frame, if it is missing)

        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        if world is not None and (isinstance(world, bool) or not isinstance(world, int) or world < 0):
            raise InputError(f"world must be None or an integer >= 0, got {world!r}")
        self.world = world
        self.frames: list[tuple[float, int]] = self._read_index()

    def _read_index(self) -> list[tuple[float, int]]:
        path = self.folder / "spheres.pvd"
        if not path.exists():
            return []
        try:
            root = ET.parse(path).getroot()
            return [(float(d.get("timestep")), int(Path(d.get("file")).stem.split("_")[-1]))
                    for d in root.iter("DataSet")]
        except (ET.ParseError, TypeError, ValueError) as e:
            raise InputError(f"{path} is not a warpdem VTK index ({e}); remove it or write elsewhere") from None

    def write(self, sim: object) -> Path:
        """Write the current frame of ``sim``; returns the spheres file."""
        import meshio

        m = sim.model
        if self.world is not None and self.world >= m.n_worlds:
            raise InputError(f"world must be in [0, {m.n_worlds}), got {self.world}")
        step = int(sim.state.step)
        ns, nm = m.spheres_per_world, m.meshes_per_world
        sel = slice(None) if self.world is None else slice(self.world * ns, (self.world + 1) * ns)
        pos = sim.data.sphere_pos.numpy()[sel].astype(np.float64)
        vel = sim.data.sphere_vel.numpy()[sel].astype(np.float64)
        angvel = sim.data.sphere_angvel.numpy()[sel].astype(np.float64)
        n = len(pos)
        point_data = {
            "radius": np.asarray(m.host["sphere_radius"][sel], dtype=np.float64),
            "velocity": vel, "angular_velocity": angvel, "speed": np.linalg.norm(vel, axis=1),
            "body": np.asarray(m.host["sphere_body"][sel], dtype=np.int64),
            "world": np.asarray(m.host["sphere_world"][sel], dtype=np.int64),
        }
        spheres = meshio.Mesh(pos, [("vertex", np.arange(n, dtype=np.int64).reshape(-1, 1))], point_data=point_data)
        path = self.folder / f"spheres_{step:09d}.vtu"
        write_atomic(path, lambda p: meshio.write(p, spheres, file_format="vtu"))

        body_pos = sim.state.body_pos.numpy()
        rot = quats_to_matrices(sim.state.body_quat.numpy())
        worlds = range(m.n_worlds) if self.world is None else (self.world,)
        points, tris, mesh_id, world_id = [], [], [], []
        offset = 0
        for w in worlds:
            for i in range(nm):
                body = int(m.host["mesh_body"][w * nm + i])
                local = np.asarray(m.host["mesh_vertices_local"][i], dtype=np.float64)
                faces = np.asarray(m.host["mesh_faces"][i], dtype=np.int64)
                points.append(local @ rot[body].T + body_pos[body])
                tris.append(faces + offset)
                mesh_id.append(np.full(len(faces), i))
                world_id.append(np.full(len(faces), w))
                offset += len(local)
        if points:
            meshes = meshio.Mesh(np.concatenate(points), [("triangle", np.concatenate(tris))],
                                 cell_data={"mesh": [np.concatenate(mesh_id)], "world": [np.concatenate(world_id)]})
        else:
            meshes = meshio.Mesh(np.zeros((0, 3)), [("triangle", np.zeros((0, 3), np.int64))])
        write_atomic(self.folder / f"meshes_{step:09d}.vtu", lambda p: meshio.write(p, meshes, file_format="vtu"))

        self.frames = [f for f in self.frames if f[1] != step] + [(float(sim.state.time), step)]
        self.frames.sort(key=lambda f: f[1])
        for part in self.PARTS:
            root = ET.Element("VTKFile", type="Collection", version="0.1")
            coll = ET.SubElement(root, "Collection")
            for t, s in self.frames:
                ET.SubElement(coll, "DataSet", timestep=repr(t), part="0", file=f"{part}_{s:09d}.vtu")
            write_atomic(self.folder / f"{part}.pvd", lambda p, root=root: ET.ElementTree(root).write(p))
        return path

    def as_observer(self, every: int = 1) -> Callable[[object], np.ndarray]:
        """An observer for :meth:`warpdem.Simulation.run` that writes every ``every``-th record (the first
        included; a record repeated at the same step, as where a run continues in pieces, counts once); it returns
        the number of frames written so far, shape (1,)."""
        if isinstance(every, bool) or not isinstance(every, int) or every < 1:
            raise InputError(f"every must be an integer >= 1, got {every!r}")
        calls = [0, -1]  # records seen, step of the last one

        def observe(sim: object) -> np.ndarray:
            step = int(sim.state.step)
            if step != calls[1]:  # a run continued in pieces repeats its boundary record: count it once
                if calls[0] % every == 0:
                    self.write(sim)
                calls[0] += 1
                calls[1] = step
            return np.array([len(self.frames)], dtype=np.float64)

        return observe
