"""Live view and recording of a running simulation with Rerun (https://rerun.io).

    viewer = RerunViewer(sim, speed_range=(0.2, 0.7), hide_outside_range=True, save_path="cut.rrd")
    draught = observers.mesh_wrench("blade", world=0)
    sim.run(20_000, record_every=100, observers={"view": viewer.as_observer({
        "draught_n": lambda s: -draught(s)[0, 0], "kinetic_energy_j": observers.kinetic_energy})})
    viewer.close()

What one frame holds (entity paths of the recording):

- ``world/particles``: ``Points3D`` of the chosen world's spheres, positions [m] (float32), radii [m], colour from
  the speed |v| [m/s] mapped over ``speed_range`` through a colormap (below the range: the first colour, above it:
  the last). With ``hide_outside_range`` only the spheres whose speed lies inside the range are shown (the paper's
  Fig. 15 showed only the particles moving at 0.2-0.7 m/s).
- ``world/meshes/<name>``: each mesh instance of that world, a ``Mesh3D`` logged once (static) with its vertices
  in the owning body's principal frame [m], and every frame a ``Transform3D`` (translation = body centre of mass
  [m], quaternion = body orientation, principal frame to world, x, y, z, w as in Rerun and in Warp).
- ``plots/<name>``: ``Scalars`` time series (draught, displacement, kinetic energy, ... as the caller gives them).

Two timelines index the frames: ``sim_time`` (the simulated time, a duration in seconds) and ``step`` (a sequence,
the number of steps done). The recording goes to a spawned viewer (``spawn=True``), to an ``.rrd`` file
(``save_path``; no display needed; open it later with ``rerun FILE.rrd``), or to both.

Rerun is only needed when this module is imported (rerun-sdk >= 0.23: ``rr.Scalars``, ``RecordingStream.set_time``).
"""

from __future__ import annotations

import math
import uuid
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np
import rerun as rr

from .errors import InputError

if not hasattr(rr, "Scalars") or not hasattr(rr.RecordingStream, "set_time"):  # pragma: no cover - old SDKs
    raise ImportError(f"warpdem.viewer needs rerun-sdk >= 0.23 (rr.Scalars), found {rr.__version__}")

#: Colormaps as (k, 3) uint8 tables of colours at evenly spaced stops from 0 to 1, linearly interpolated between
#: stops. "turbo" and "viridis" are matplotlib's maps sampled at 17 stops (within 8/255 of the full maps);
#: turbo runs from #30123b (slow) to #7a0403 (fast).
COLORMAPS: dict[str, np.ndarray] = {
    "turbo": np.array(
        [[48, 18, 59], [64, 64, 162], [70, 107, 227], [66, 148, 255], [40, 188, 235], [24, 221, 194],
         [50, 242, 152], [109, 254, 98], [164, 252, 60], [205, 236, 52], [238, 207, 58], [253, 172, 52],
         [251, 126, 33], [235, 80, 14], [208, 47, 5], [169, 22, 1], [122, 4, 3]], dtype=np.uint8),
    "viridis": np.array(
        [[68, 1, 84], [72, 24, 106], [71, 45, 123], [66, 64, 134], [59, 82, 139], [51, 99, 141], [44, 114, 142],
         [38, 130, 142], [33, 145, 140], [31, 160, 136], [40, 174, 128], [63, 188, 115], [94, 201, 98],
         [132, 212, 75], [173, 220, 48], [216, 226, 25], [253, 231, 37]], dtype=np.uint8),
    "gray": np.array([[0, 0, 0], [255, 255, 255]], dtype=np.uint8),
}

#: the statistics an :meth:`RerunViewer.as_observer` function returns, in order
STAT_NAMES = ("speed_min", "speed_mean", "speed_max", "points_shown")

_MESH_COLOR = np.array([170, 170, 180], dtype=np.uint8)


def colormap_table(colormap: str | object) -> np.ndarray:
    """The (k, 3) uint8 table of a colormap given by name (a key of :data:`COLORMAPS`) or as k >= 2 RGB colours
    (0-255) at evenly spaced stops."""
    if isinstance(colormap, str):
        if colormap not in COLORMAPS:
            raise InputError(f"colormap must be one of {sorted(COLORMAPS)} or a (k, 3) RGB table, got {colormap!r}")
        return COLORMAPS[colormap]
    table = np.asarray(colormap, dtype=np.float64)
    if table.ndim != 2 or table.shape[1] != 3 or len(table) < 2 or not np.all(np.isfinite(table)) \
            or np.any(table < 0) or np.any(table > 255):
        raise InputError(f"colormap must be one of {sorted(COLORMAPS)} or a (k >= 2, 3) table of RGB values in "
                         f"0..255, got an array of shape {table.shape}")
    return np.round(table).astype(np.uint8)


def speed_colors(speed: object, speed_range: tuple[float, float], colormap: str | object = "turbo") -> np.ndarray:
    """Colours (n, 3) uint8 of speeds [m/s] (n,): t = (speed - lo) / (hi - lo) clipped to [0, 1], then linear
    interpolation in the colormap table (t = 0: its first colour, t = 1: its last)."""
    table = colormap_table(colormap).astype(np.float64)
    lo, hi = float(speed_range[0]), float(speed_range[1])
    t = np.clip((np.asarray(speed, dtype=np.float64) - lo) / (hi - lo), 0.0, 1.0)
    x = t * (len(table) - 1)
    i = np.minimum(np.floor(x).astype(np.int64), len(table) - 2)
    f = (x - i)[:, None]
    return np.round(table[i] * (1.0 - f) + table[i + 1] * f).astype(np.uint8)


def select_world(value: object, n_worlds: int, world: int) -> np.ndarray:
    """An observer value as a flat float64 array for one world: a value whose leading axis has length ``n_worlds``
    (per-world observers such as ``kinetic_energy``) is indexed at ``world``; anything else is taken as it is.
    (With n_worlds > 1 an observer returning one world's vector of length n_worlds is ambiguous: select the world
    in the observer instead.)"""
    v = np.asarray(value, dtype=np.float64)
    if v.ndim >= 1 and v.shape[0] == n_worlds:
        v = v[world]
    return v.reshape(-1)


def _entity_part(name: str) -> str:
    return rr.escape_entity_path_part(str(name))


class RerunViewer:
    """Streams one world of a simulation to Rerun: particles coloured by speed, tool meshes and their pose, and
    scalar time series. See the module docstring for what each frame holds.

    Args:
        sim: the :class:`~warpdem.Simulation` to show (its model sets the scene; a later :meth:`log_frame` with a
            simulation of another model logs that model's meshes and carries on in the same recording).
        world: which world of a batched model to show, 0 <= world < n_worlds.
        speed_range: (lo, hi) speeds [m/s], 0 <= lo < hi, mapped to the ends of the colormap.
        hide_outside_range: show only the spheres with lo <= |v| <= hi.
        application_id: Rerun application id (the viewer groups recordings by it).
        spawn: start a Rerun viewer process and stream to it.
        save_path: write the recording to this ``.rrd`` file (no display needed). With ``spawn`` too, both get it.
        colormap: a name in :data:`COLORMAPS` ("turbo", "viridis", "gray") or a (k, 3) RGB table (0-255).
        max_points: show at most this many spheres of the world (a fixed random subset, the same every frame; the
            speed statistics still cover every sphere of the world). None: all.
        recording_id: Rerun recording id (default: a new UUID).

    Raises:
        InputError (a ValueError) naming the parameter and its value when an argument is out of range.
    """

    def __init__(
        self,
        sim: object,
        *,
        world: int = 0,
        speed_range: tuple[float, float] = (0.0, 1.0),
        hide_outside_range: bool = False,
        application_id: str = "warpdem",
        spawn: bool = False,
        save_path: str | Path | None = None,
        colormap: str | object = "turbo",
        max_points: int | None = None,
        recording_id: str | None = None,
    ) -> None:
        self.speed_range = self._check_speed_range(speed_range)
        self.colormap = colormap_table(colormap)
        self.hide_outside_range = bool(hide_outside_range)
        if max_points is not None and (isinstance(max_points, bool) or not isinstance(max_points, (int, np.integer))
                                       or max_points < 1):
            raise InputError(f"max_points must be None or an integer >= 1, got {max_points!r}")
        self.max_points = None if max_points is None else int(max_points)
        if isinstance(world, bool) or not isinstance(world, (int, np.integer)):
            raise InputError(f"world must be an integer, got {world!r}")
        self.world = int(world)
        if not isinstance(application_id, str) or not application_id:
            raise InputError(f"application_id must be a non-empty string, got {application_id!r}")
        if not spawn and save_path is None:
            raise InputError("RerunViewer needs somewhere to send the recording: spawn=True (a viewer window) "
                             "and/or save_path='FILE.rrd', got spawn=False and save_path=None")
        if save_path is not None:
            save_path = Path(save_path)
            if not save_path.parent.is_dir():
                raise InputError(f"save_path must be in an existing directory, got {str(save_path)!r}")
        self.save_path = save_path
        self._model = None
        self._check_model(sim.model)

        self.recording_id = recording_id or str(uuid.uuid4())
        self.rec = rr.RecordingStream(application_id, recording_id=self.recording_id)
        blueprint = self._blueprint()
        if spawn and save_path is not None:
            self.rec.spawn(connect=False)
            self.rec.set_sinks(rr.GrpcSink(), rr.FileSink(str(save_path)), default_blueprint=blueprint)
        elif spawn:
            self.rec.spawn(default_blueprint=blueprint)
        else:
            self.rec.save(str(save_path), default_blueprint=blueprint)
        self._closed = False
        self._log_static_scene(sim.model)

    # ------------------------------------------------------------------ setup
    @staticmethod
    def _check_speed_range(speed_range: object) -> tuple[float, float]:
        try:
            lo, hi = (float(x) for x in speed_range)  # type: ignore[union-attr]
        except (TypeError, ValueError):
            raise InputError(f"speed_range must be (lo, hi) in m/s, got {speed_range!r}") from None
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo < 0.0 or lo >= hi:
            raise InputError(f"speed_range must be (lo, hi) with 0 <= lo < hi, finite, in m/s, got {speed_range!r}")
        return lo, hi

    def _check_model(self, model: object) -> None:
        if not 0 <= self.world < model.n_worlds:
            raise InputError(f"world must be in [0, {model.n_worlds}) for a model of {model.n_worlds} world(s), "
                             f"got {self.world}")

    @staticmethod
    def _blueprint() -> object:
        import rerun.blueprint as rrb

        return rrb.Blueprint(
            rrb.Horizontal(rrb.Spatial3DView(name="scene", origin="world"),
                           rrb.TimeSeriesView(name="plots", origin="plots"), column_shares=[3, 2]),
            collapse_panels=True,
        )

    def _log_static_scene(self, model: object) -> None:
        """Scene setup for a model: subset of spheres shown, radii, mesh geometry (static), axes and legend."""
        self._model = model
        n = model.spheres_per_world
        self._s0 = self.world * n
        if self.max_points is not None and n > self.max_points:
            rng = np.random.default_rng(0)
            self._subset = np.sort(rng.choice(n, self.max_points, replace=False))
        else:
            self._subset = None
        radii = np.asarray(model.host["sphere_radius"][self._s0:self._s0 + n], dtype=np.float32)
        self._radii = radii if self._subset is None else radii[self._subset]

        g = np.asarray(model.gravity, dtype=np.float64)
        if np.linalg.norm(g[:2]) <= 1e-12 * max(abs(g[2]), 1.0) and g[2] <= 0.0:
            self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        lo, hi = self.speed_range
        self.rec.log("legend", rr.TextDocument(
            f"Particle colour: speed |v| from {lo:g} m/s (first colour) to {hi:g} m/s (last colour)"
            + (f"; only particles with {lo:g} <= |v| <= {hi:g} m/s are shown" if self.hide_outside_range else "")
            + f". World {self.world} of {model.n_worlds}.", media_type=rr.MediaType.MARKDOWN), static=True)

        # meshes of the chosen world: geometry once, in the owning body's principal frame
        nm = model.meshes_per_world
        names = {i: name for name, i in model.names.get("mesh", {}).items()}
        self._meshes = []  # (entity path, global body index)
        for i in range(nm):
            path = f"world/meshes/{_entity_part(names.get(i, f'mesh{i}'))}"
            body = int(model.host["mesh_body"][self.world * nm + i])
            verts = np.asarray(model.host["mesh_vertices_local"][i], dtype=np.float32)
            faces = np.asarray(model.host["mesh_faces"][i], dtype=np.uint32)
            self.rec.log(path, rr.Mesh3D(vertex_positions=verts, triangle_indices=faces, albedo_factor=_MESH_COLOR),
                         static=True)
            self._meshes.append((path, body))

    # ------------------------------------------------------------------ frames
    def log_frame(self, sim: object, scalars: Mapping[str, object] | None = None) -> np.ndarray:
        """Log the current state of ``sim`` at its time (``sim_time`` [s]) and step (``step``).

        Args:
            sim: the simulation (sphere_pos vec3d [m], sphere_vel vec3f [m/s], state.body_pos / body_quat).
            scalars: name -> value, logged under ``plots/<name>``; a value may be a float or an array (several
                series under one name, e.g. a force vector), taken as given (no world selection here).
        Returns:
            (4,) float64: min, mean and max speed [m/s] of the world's spheres and the number of points shown
            (see :data:`STAT_NAMES`); zeros for a world without spheres.
        """
        if self._closed:
            raise RuntimeError("RerunViewer.log_frame after close()")
        if sim.model is not self._model:
            self._check_model(sim.model)
            self._log_static_scene(sim.model)
        rec = self.rec
        rec.set_time("step", sequence=int(sim.state.step))
        rec.set_time("sim_time", duration=float(sim.state.time))

        stats = np.zeros(4, dtype=np.float64)
        n = self._model.spheres_per_world
        if n:
            pos = sim.data.sphere_pos[self._s0:self._s0 + n].numpy()
            vel = sim.data.sphere_vel[self._s0:self._s0 + n].numpy()
            speed = np.linalg.norm(vel.astype(np.float64), axis=1)
            stats[:3] = speed.min(), speed.mean(), speed.max()
            radii = self._radii
            if self._subset is not None:
                pos, speed = pos[self._subset], speed[self._subset]
            if self.hide_outside_range:
                lo, hi = self.speed_range
                keep = (speed >= lo) & (speed <= hi)
                pos, speed, radii = pos[keep], speed[keep], radii[keep]
            stats[3] = len(pos)
            rec.log("world/particles", rr.Points3D(
                np.ascontiguousarray(pos, dtype=np.float32).reshape(-1, 3),
                radii=radii, colors=speed_colors(speed, self.speed_range, self.colormap)))

        for path, body in self._meshes:
            x = sim.state.body_pos[body:body + 1].numpy()[0]
            q = sim.state.body_quat[body:body + 1].numpy()[0]  # x, y, z, w (Warp), as Rerun's xyzw
            rec.log(path, rr.Transform3D(translation=x.astype(np.float32),
                                         quaternion=rr.Quaternion(xyzw=q.astype(np.float32))))

        for name, value in (scalars or {}).items():
            v = np.asarray(value, dtype=np.float64).reshape(-1)
            if v.size:
                rec.log(f"plots/{_entity_part(name)}", rr.Scalars(v))
        return stats

    def as_observer(
        self, scalars: Mapping[str, Callable[[object], object]] | None = None, *, select_worlds: bool = True
    ) -> Callable[[object], np.ndarray]:
        """An observer for :meth:`Simulation.run` that logs a frame each time it is called (every ``record_every``
        steps) and returns the speed statistics of :meth:`log_frame` ((4,) float64, see :data:`STAT_NAMES`).

        Args:
            scalars: name -> observer ``f(sim)``; each value is logged under ``plots/<name>``.
            select_worlds: pass each value through :func:`select_world` (warpdem's per-world observers, with a
                leading axis of length n_worlds, are indexed at the viewer's world); False: log values as given.
        """
        scalars = dict(scalars or {})

        def observe(sim: object) -> np.ndarray:
            values = {k: f(sim) for k, f in scalars.items()}
            if select_worlds:
                values = {k: select_world(v, sim.model.n_worlds, self.world) for k, v in values.items()}
            return self.log_frame(sim, values)

        return observe

    # ------------------------------------------------------------------ end
    def close(self) -> None:
        """Flush everything logged and close the sinks (the .rrd file is complete after this). Idempotent.

        A spawned viewer that could not start or was closed (no display, say) only costs a warning here: the file
        sink, if any, is still completed."""
        if self._closed:
            return
        self._closed = True
        try:
            self.rec.flush()
        except RuntimeError as exc:  # a gRPC sink that never connected; the other sinks are flushed by disconnect
            warnings.warn(f"RerunViewer: could not flush to the viewer ({exc})", RuntimeWarning, stacklevel=2)
        self.rec.disconnect()

    def __enter__(self) -> RerunViewer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
